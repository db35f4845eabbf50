#!/bin/bash
# Scripts written for the day's GPU lease, not yet run: every start of a device machine failed (H100 and
# H200, fourteen tries between 09:15 and 11:33 UTC; other sessions' tries failed as well). The next session
# with a machine runs them as they are:
#   card.sh       the card's command: bare, warm, bare again, and bare with XLA's GPU autotuning off, MuJoCo,
#                 MJX and Warp compiled to bytecode after the install (SHORT=1: one bare, three warm, one
#                 without autotuning)
#   suite_1m.sh   HalfCheetah's 1 M PPO preset with lr 4e-5 annealed and advantages standardised per minibatch
#                 (32 seeds); Reacher's TRPO with 32768-sample updates from 512 envs x 64 steps (4 seeds)
#   both.sh       card.sh's short form, then suite_1m.sh
#   poll.sh       wait for a folder's `done`, then pack the small files of each folder into $OUT
# Install as in the GPU recipe (warp-lang carried in parts), then for example:
#   setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/both.sh > /tmp/both.log 2>&1 < /dev/null &
#   bash benchmarks/results/2026-12-05-gpu-unrun/poll.sh 540 /tmp/out35 /tmp/outc
