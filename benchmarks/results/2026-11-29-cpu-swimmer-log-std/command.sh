# 2 CPU cores ("Intel Xeon Processor"), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics,
# 2026-11-29, the code at ef1b8ff. Swimmer's fast preset (TRPO, 16 envs x 128 steps, 488 iterations,
# initial log-std 0.5) as typed (base) and with a log-std ceiling falling to -2.5 over the run (ceil25),
# seeds 0-3 in one vmapped program each, the two programs side by side (about 9 minutes each).
python -m jaxpg.cli --env swimmer --algo trpo --preset swimmer_fast --seeds 0 1 2 3 --run-dir run-base --no-progress > train_base.log
python -m jaxpg.cli --env swimmer --algo trpo --preset swimmer_fast --seeds 0 1 2 3 \
  --log-std-final -2.5 --anneal-log-std-iterations 488 --run-dir run-ceil25 --no-progress > train_ceil25.log
# each seed's final mean policy, 10 episodes in Gymnasium's Swimmer-v5 (gymnasium_*_seedS.log)
python -m jaxpg.evaluate run-base --gymnasium --episodes 10 --train-seed S
