# 2 CPU cores ("Intel Xeon Processor"), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics,
# 2026-11-29. hopper_1m (NPG, 0.98 M env steps) as typed, seeds 0-1 and 2-9 in two vmapped programs
# (the first at 8981cce's parent code, the second at 1bcf8d6; the training code is the same), 6 and
# 50 minutes. Then each seed's final policy played 10 episodes of Gymnasium's Hopper-v5 both ways:
# clip(mean) (every evaluation's "mean policy") and the clipped mean E[clip(a)] (--clipped-mean), at 1666a58.
python -m jaxpg.cli --env hopper --preset hopper_1m --seeds 0 1 --run-dir h1m --no-progress > train_seeds0-1.log
python -m jaxpg.cli --env hopper --preset hopper_1m --seeds 2 3 4 5 6 7 8 9 --run-dir h1m8 --no-progress > train_seeds2-9.log
python benchmarks/suite.py physics h1m h1m8 --variants gymnasium --actions mode clipped_mean --episodes 10 \
  --workers 2 --json physics.json > physics.log
