# 2 CPU cores (AMD EPYC; one core a program: taskset), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast
# physics, 2026-12-05, the code at 3d0e838. HalfCheetah's 1 M-step PPO preset with PPO's two new options:
# each minibatch's advantages standardised on their own (mb, as SB3 does), and that plus advantages recomputed
# before every epoch after the first (mbre, Tianshou's recompute_advantage); seeds 0-3 in one program each,
# the two side by side (2269 s and 2467 s of training). The preset's seeds 0-3 on a CPU:
# 2026-11-29-cpu-half-cheetah-pytorch-init (Gymnasium 7170, 5348, 5659, 5735: median 5697).
taskset -c 0 python -m jaxpg.cli --env half_cheetah --algo ppo --preset half_cheetah_1m --normalize-minibatch-advantages \
  --seeds 0 1 2 3 --log-every 50 --run-dir run-mb --no-progress > train_mb.log
taskset -c 1 python -m jaxpg.cli --env half_cheetah --algo ppo --preset half_cheetah_1m --normalize-minibatch-advantages \
  --recompute-advantages --seeds 0 1 2 3 --log-every 50 --run-dir run-mbre --no-progress > train_mbre.log
# each seed's final mean policy, 10 episodes in Gymnasium's HalfCheetah-v5
for V in mb mbre; do for S in 0 1 2 3; do
  python -m jaxpg.evaluate run-$V --gymnasium --episodes 10 --train-seed $S > gymnasium_${V}_seed$S.log
done; done
# Ran as above. Gymnasium: mb 7535, 5044 +- 882, 6202, 4789 +- 1762 (median 5623); mbre 7093, 5218 +- 1804,
# 6194, 5393 +- 1561 (median 5793). In-run mean policy at 1 M (mean of the 4 seeds): 5604 (mb), 5646 (mbre).
