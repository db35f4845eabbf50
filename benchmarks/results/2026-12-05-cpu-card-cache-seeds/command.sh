# 2 CPU cores (AMD EPYC), JAX 0.10.2, MJX 3.17.0, warp-lang 1.19.0, 2026-12-05, the code at dee72da. Does a
# second seed of the card's command load the first seed's cached XLA programs? One empty cache per
# implementation, seed 0 then seed 1 (MuJoCo Warp: then seed 0 again), listing the cache after each run.
export JAXPG_COMPILATION_CACHE=/tmp/cc
python experiments/hopper.py --num-envs 256 --iterations 10 --seed 0 --run-dir /tmp/r0 > jax_seed0.log
python experiments/hopper.py --num-envs 256 --iterations 10 --seed 1 --run-dir /tmp/r1 > jax_seed1.log
export JAXPG_COMPILATION_CACHE=/tmp/ccw
for s in 0 1 0; do
  python experiments/hopper.py --num-envs 16 --iterations 10 --impl warp --seed $s --run-dir /tmp/w$s --overwrite > warp_seed$s.log
done
# Ran as above: each cache held three programs (jit__lambda, jit_evaluate_state, jit_scan_updates) after the
# first run and no more after the others. First block: JAX 17.9 s (seed 0), 4.4 s (seed 1); Warp 8.6 s,
# 2.3 s, 2.1 s. The seed is not part of the programs' keys with either implementation.
