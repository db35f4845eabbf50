#!/bin/bash
# The GPU work still owed for the suite's table, in three H100 leases (each 30 minutes of device time: about
# 2.5 for the machine's start and the wheels' staging, the rest for this). Written 2026-12-05; card_parts.sh
# ran since (benchmarks/results/2026-12-05-h100c/host1.md). Each part writes to its own folder and touches
# `done` there. Poll with calls back to back: a machine left idle for 30 s between two calls is released,
# and its files with it; pack each part's files as soon as it is done (poll.sh does both in one call).
# LEASE=1 ran on 2026-12-05 17:35-18:00 UTC (benchmarks/results/2026-12-05-h100d/): a2c took 17 minutes (Ant's
# program 1002 s), swimmer_fast 8; 1,570 s of device time with the start. LEASE=2 ran on 2026-12-05
# 18:52-19:18 UTC (benchmarks/results/2026-12-05-h100e/): 26 minutes, 1,665 s of device time with the start and
# the staging (Pusher 174 s, HalfCheetah 225 s, Reacher 415 s, Swimmer 692 s, each with its replay after).
# LEASE=3 ran (below); LEASE=4 has not.
#   LEASE=1: Ant's and Humanoid's 1 M A2C side by side (suite_h100.sh PART=a2c, about 12-15 minutes going by
#            the H200) -> /tmp/out_a2c, then Swimmer's fast preset (about 7 minutes on an H100) -> /tmp/out_sw
#   LEASE=2: suite_h100.sh PART=rest (Pusher, HalfCheetah PPO, Reacher, Swimmer 1 M, one after another)
#            -> /tmp/out_rest. Bound by the GPU's latency per step at 2 to 64 envs; about 24 minutes, going
#            by about 1 ms a step in the fast presets of Swimmer and Reacher (1024 x 488 steps each) and
#            HalfCheetah's 16 seeds' 261 s on an H200: no margin. Swimmer goes last.
#   LEASE=3: PART=hopper_fast -> /tmp/out_hf (about 5 minutes, going by one H200's 47 s a run), then
#            PART=ant_anneal -> /tmp/out_ant (16 seeds in one program, about 13 minutes going by 5 seeds'
#            0.057 s an iteration). Ran on 2026-12-05 21:27-21:43 UTC (benchmarks/results/2026-12-05-h100f/),
#            after a first try at 20:05 got no machine: Hopper 4 runs in 3 minutes, Ant's program 802 s
#            and its replay 20 s; 1,112 s of device time with the start and the staging.
#   LEASE=4: PART=hopper_gpu -> /tmp/out_hg (Hopper's time to 3000 on an H100, about 6 minutes)
#   LEASE=1 setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/leases.sh > /tmp/leases.log 2>&1 < /dev/null &
HERE=benchmarks/results/2026-12-05-gpu-unrun
if [ "${LEASE:-1}" = 1 ]; then
  D=/tmp/out_a2c PART=a2c bash $HERE/suite_h100.sh
  D=/tmp/out_sw PART=swimmer_fast bash $HERE/suite_h100.sh
elif [ "$LEASE" = 2 ]; then
  D=/tmp/out_rest PART=rest bash $HERE/suite_h100.sh
elif [ "$LEASE" = 3 ]; then
  D=/tmp/out_hf PART=hopper_fast bash $HERE/suite_h100.sh
  D=/tmp/out_ant PART=ant_anneal bash $HERE/suite_h100.sh
else
  D=/tmp/out_hg PART=hopper_gpu bash $HERE/suite_h100.sh
fi
