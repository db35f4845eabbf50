#!/bin/bash
# 2 CPU cores (AMD EPYC), 2026-12-05, JAX 0.10.2, MuJoCo/MJX 3.17.0, warp-lang 1.19.0 (this machine's), the
# code at the commit that added card_command.py's `parts` mode. Caches filled by earlier runs of the same
# command (warm), in /tmp:
export JAXPG_COMPILATION_CACHE=/tmp/cpucache WARP_CACHE_PATH=/tmp/warpcache
python experiments/hopper.py --num-envs 256 --iterations 10 --impl warp --run-dir /tmp/cpurunw   # fills them
python benchmarks/card_command.py parts --json parts_warp.json -- --iterations 10 --impl warp > parts_warp.log 2>&1
python benchmarks/card_command.py parts --json parts_jax.json -- --iterations 10 > parts_jax.log 2>&1
# The profile of the evaluation's tracing (its lower() on the background thread under cProfile) was taken
# by hand with a patched jaxpg.train._EarlyCompile._compile; not kept as a script.
# The evaluation with as many episodes as training envs (256) against the preset's 16, three alternating
# warm runs each (eval_envs_ab/):
for i in 1 2 3; do for e in 16 256; do
  python benchmarks/card_command.py parts --json eval_envs_ab/e${e}_$i.json -- --iterations 10 --impl warp \
    --eval-envs $e > eval_envs_ab/e${e}_$i.log 2>&1
done; done
