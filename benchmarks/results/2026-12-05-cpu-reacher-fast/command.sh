#!/bin/bash
# TRPO's `reacher_fast` preset exactly as committed (512 envs x 64 steps, value minibatches of 1024, the
# mean policy evaluated every 50 iterations, blocks of 10), seed 0, on this machine's 2 CPU cores
# (JAX 0.10.2, MJX 3.17.0), 2026-12-05: Gymnasium -3.47 (10 episodes), whole process 955 s. The
# H100 runs (benchmarks/results/2026-12-05-h100/reacher_fast/) evaluated every 61 iterations.
python benchmarks/suite.py run --runs reacher:trpo:reacher_fast --seeds 0 --episodes 10 \
  --out /tmp/rfcpu/runs --json reacher_fast_cpu.json > run.log 2>&1
