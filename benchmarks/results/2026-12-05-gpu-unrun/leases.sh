#!/bin/bash
# The GPU work still owed, in two H100 leases (each 30 minutes of device time: about 2.5 for the machine's
# start and the wheels' staging, the rest for this). Written 2026-12-05, not yet run. Each part writes to
# its own folder and touches `done` there; pack with ../2026-12-05-h100/poll.sh between calls.
#   LEASE=1: card_parts.sh (about 4 minutes) -> /tmp/outp, then Ant's and Humanoid's 1 M A2C side by side
#            (suite_h100.sh PART=a2c, about 12-15 minutes going by the H200) -> /tmp/out_a2c
#   LEASE=2: suite_h100.sh PART=rest (HalfCheetah PPO, Swimmer, Reacher, Pusher 1 M, one after another)
#            -> /tmp/out_rest, then PART=swimmer_fast -> /tmp/out_sw, then PART=hopper_gpu -> /tmp/out_hg
#   LEASE=1 setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/leases.sh > /tmp/leases.log 2>&1 < /dev/null &
HERE=benchmarks/results/2026-12-05-gpu-unrun
if [ "${LEASE:-1}" = 1 ]; then
  D=/tmp/outp bash $HERE/card_parts.sh
  D=/tmp/out_a2c PART=a2c bash $HERE/suite_h100.sh
else
  D=/tmp/out_rest PART=rest bash $HERE/suite_h100.sh
  D=/tmp/out_sw PART=swimmer_fast bash $HERE/suite_h100.sh
  D=/tmp/out_hg PART=hopper_gpu bash $HERE/suite_h100.sh
fi
