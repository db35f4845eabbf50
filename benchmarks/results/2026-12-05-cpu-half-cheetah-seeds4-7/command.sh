# 2 CPU cores (AMD EPYC; one core a program: taskset), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast
# physics, 2026-12-05, the code at acab5c1. HalfCheetah's 1 M-step PPO preset as typed (preset) and with its
# learning rate starting at 4e-5, annealed linearly to 0 over the 1953 iterations (lead), seeds 4-7 in one
# program each, the two side by side (2437 s and 2422 s of training). Seeds 0-3 of each ran before:
# 2026-11-29-cpu-half-cheetah-pytorch-init (the preset) and 2026-12-02-cpu-half-cheetah-lr4e-5-anneal (lead).
taskset -c 0 python -m jaxpg.cli --env half_cheetah --algo ppo --preset half_cheetah_1m --lr 4e-5 --anneal-lr-iterations 1953 \
  --seeds 4 5 6 7 --log-every 50 --run-dir run-lead --no-progress > train_lead.log
taskset -c 1 python -m jaxpg.cli --env half_cheetah --algo ppo --preset half_cheetah_1m \
  --seeds 4 5 6 7 --log-every 50 --run-dir run-preset --no-progress > train_preset.log
# each seed's final mean policy, 10 episodes in Gymnasium's HalfCheetah-v5
for V in lead preset; do for S in 4 5 6 7; do
  python -m jaxpg.evaluate run-$V --gymnasium --episodes 10 --train-seed $S > gymnasium_${V}_seed$S.log
done; done
# Ran as above. Gymnasium: lead 5552, 5813, 6061, 5689 (median 5751; in-run 5570, 5187, 6098, 5694);
# preset 6361 +- 1140, 5967 +- 1531, 5960, 5429 (median 5963; in-run 6629, 6206, 5643, 5273).
