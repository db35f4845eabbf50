# 2 CPU cores ("Intel Xeon Processor"), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics,
# 2026-11-29, the code at ef1b8ff. Reacher's TRPO preset within 1 M env steps (reacher_1m: 2 envs x 1024
# steps, 488 iterations, initial log-std -0.5) with the log-std bounds, 4 seeds in one vmapped program
# each, the two programs side by side (about 8 minutes each).
# ceil2: a ceiling falling from -0.5 to -2 over the run; fixed: the log-std held at -0.5.
python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 2 3 \
  --log-std-final -2 --anneal-log-std-iterations 488 --run-dir run-ceil2 --no-progress > train_ceil2.log
python -m jaxpg.cli --env reacher --algo trpo --preset reacher_1m --seeds 0 1 2 3 \
  --log-std-min -0.5 --log-std-final -0.5 --anneal-log-std-iterations 1 --run-dir run-fixed --no-progress > train_fixed.log
# each seed's final mean policy, 10 episodes in Gymnasium's Reacher-v5 (gymnasium_*_seedS.log)
python -m jaxpg.evaluate run-ceil2 --gymnasium --episodes 10 --train-seed S
