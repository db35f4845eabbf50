# 2 CPU cores (one core a program: taskset), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics,
# 2026-12-05, the code at acab5c1. Swimmer's fast preset (TRPO, 16 envs x 128 steps, 488 iterations) as
# typed (base) and with a 256x256 policy in place of 64x64 (wide), seeds 0-3 in one vmapped program each,
# the two programs side by side (base 403 s, wide 1213 s of training).
taskset -c 0 python -m jaxpg.cli --env swimmer --algo trpo --preset swimmer_fast --seeds 0 1 2 3 --run-dir run-base --no-progress > train_base.log
taskset -c 1 python -m jaxpg.cli --env swimmer --algo trpo --preset swimmer_fast --policy-hidden 256 256 --seeds 0 1 2 3 --run-dir run-wide --no-progress > train_wide.log
# each seed's final mean policy, 10 episodes in Gymnasium's Swimmer-v5 (gymnasium_*_seedS.log)
for V in base wide; do for S in 0 1 2 3; do
  python -m jaxpg.evaluate run-$V --gymnasium --episodes 10 --train-seed $S > gymnasium_${V}_seed$S.log
done; done
# seed 0 of base played as its clipped mean, E[clip(a)], in place of clip(mean)
python -m jaxpg.evaluate run-base --gymnasium --episodes 10 --train-seed 0 --mean-action clipped_mean > gymnasium_base_seed0_clipped_mean.log
# Ran as above (clipped mean: 356.45 against 357.32). Gymnasium: base 357, 346, 291, 147 (in-run MJX 364, 354, 297, 147);
# wide 351, 346, 140 (the slow gait), 352 (in-run 366, 352, 135, 355).
