# 2 CPU cores ("Intel Xeon Processor"), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics, 2026-11-29,
# the code at 789744c: hopper_1m as it was then, with the noise held at log-std 1 by flags (today's hopper_1m but
# for its eval_action, which only changes how the in-run evaluation plays), seeds 0-3 in one vmapped program
# (28 minutes, the cores shared with a test run); then each final policy played 10 episodes of Gymnasium's
# Hopper-v5 both ways, clip(mean) and the clipped mean E[clip(a)].
python -m jaxpg.cli --env hopper --preset hopper_1m --seeds 0 1 2 3 --log-std-min 1 --log-std-final 1 \
  --anneal-log-std-iterations 120 --run-dir h1 --no-progress > train_seeds0-3.log
python benchmarks/suite.py physics h1 --variants gymnasium --actions mode clipped_mean --episodes 10 \
  --workers 1 --json physics.json > physics.log
