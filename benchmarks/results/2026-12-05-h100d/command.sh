#!/bin/bash
# One H100 (a freshly started machine, 16 host cores), 2026-12-05 17:35-18:00 UTC, the code at 3a5aeef,
# JAX 0.11.2, MJX 3.17.0, warp-lang 1.18.0, Gymnasium 1.4.0. The wheels staged as in the GPU recipe,
# then the first of the two leases planned in ../2026-12-05-gpu-unrun/leases.sh:
LEASE=1 setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/leases.sh > /tmp/leases.log 2>&1 < /dev/null &
# which ran, one after the other (../2026-12-05-gpu-unrun/suite_h100.sh):
#   a2c/ (PART=a2c): Ant's and Humanoid's 1 M A2C side by side, seeds 0-4 in one vmapped program each,
#     python benchmarks/suite.py run --runs TASK:a2c:TASK_1m --seeds 0 1 2 3 4 --vmap-seeds --episodes 0
#     then each seed's final mean policy replayed 10 episodes in Gymnasium v5 (python benchmarks/suite.py physics
#     RUN --variants gymnasium --episodes 10): physics_ant.json, physics_humanoid.json. The run folders keep
#     config.json and every 50th iteration's metrics (with every evaluation): run_files/.
#   swimmer_fast/ (PART=swimmer_fast): TRPO's swimmer_fast as typed, seed 0 bare, then seeds 0-2 warm:
#     python benchmarks/suite.py run --runs swimmer:trpo:swimmer_fast --seeds 0 1 2 --bare-first --episodes 10
# suite_fast_h100.json: ../2026-12-05-h100b/suite_fast_h100.json with Swimmer's rows taken from swimmer_fast/,
# for docs/suite_fast.png (python benchmarks/suite.py plot suite_fast_h100.json --out docs/suite_fast.png).
