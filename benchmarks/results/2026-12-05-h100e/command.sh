#!/bin/bash
# One H100 (a freshly started machine, 16 host cores, "Intel Xeon Processor"), 2026-12-05 18:52-19:18 UTC, the
# code at 71d1717, JAX 0.11.2, MJX 3.17.0, warp-lang 1.18.0, Gymnasium 1.4.0. The wheels staged as in the GPU
# recipe, then the second of the leases planned in ../2026-12-05-gpu-unrun/leases.sh:
LEASE=2 setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/leases.sh > /tmp/leases.log 2>&1 < /dev/null &
# which ran (../2026-12-05-gpu-unrun/suite_h100.sh PART=rest) four 1 M presets one after another, each alone on
# the GPU, seeds 0-4 in one vmapped program:
#   python benchmarks/suite.py run --runs TASK:ALGO:TASK_1m --seeds 0 1 2 3 4 --vmap-seeds --episodes 0
# for pusher:npg, half_cheetah:ppo, reacher:trpo and swimmer:trpo, each followed by its seeds' final mean policy
# replayed 10 episodes in Gymnasium v5 (python benchmarks/suite.py physics RUN --variants gymnasium
# --episodes 10): rest/physics_TASK.json. The run folders keep config.json, the run's log, and every 10th
# iteration's metrics with every evaluation and the last iteration: rest/run_files/.
