#!/bin/bash
# One H100 (a freshly started machine, 16 host cores, "Intel Xeon Processor"), 2026-12-05 21:27-21:43 UTC, the
# package code as at 71d1717 (start.txt names the device copy's stale git head; only docs and these scripts
# changed since), JAX 0.11.2, MJX 3.17.0, warp-lang 1.18.0, Gymnasium 1.4.0. The wheels staged as in the GPU
# recipe, then the third of the leases planned in ../2026-12-05-gpu-unrun/leases.sh:
LEASE=3 setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/leases.sh > /tmp/leases.log 2>&1 < /dev/null &
# which ran, one after the other, alone on the GPU (../2026-12-05-gpu-unrun/suite_h100.sh):
# 1. PART=hopper_fast -> hopper_fast/: Hopper's fast preset, seed 0 with empty caches (the machine's first
#    program: "bare"), then seeds 0-2 with the caches it filled ("warm"), one process each, each replayed 10
#    episodes in Gymnasium v5:
#      python benchmarks/suite.py run --runs hopper:ppo:hopper_gpu --seeds 0 1 2 --bare-first --episodes 10 \
#        --extra --iterations 150 --eval-every 10
# 2. PART=ant_anneal -> ant_anneal/: ant_1m's A2C with its learning rate decaying to 0 at 1 M env steps (then a
#    flag; now the preset's own), seeds 0-15 in one vmapped program, each seed's final mean policy replayed
#    10 episodes in Gymnasium v5 (Ant-v5 without contact forces):
#      python benchmarks/suite.py run --runs ant:a2c:ant_1m --seeds 0 1 ... 15 --vmap-seeds --episodes 0 \
#        --extra --anneal-lr-iterations 12500
#      python benchmarks/suite.py physics RUN --variants gymnasium --episodes 10 --workers 16
# The run folders keep config.json, the logs, and metrics thinned to every 10th iteration (Ant's: every 50th)
# with every evaluation: */run_files/.
