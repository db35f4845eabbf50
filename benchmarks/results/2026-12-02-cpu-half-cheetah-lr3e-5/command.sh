# 2 CPU cores, JAX 0.10.2, MJX 3.17.0 (JAX implementation), 2026-12-02, the code at cb43db6: HalfCheetah with
# `half_cheetah_1m --algo ppo` (SB3 RL Zoo's settings, PyTorch's initialisation) and its learning rate raised
# from 2.0633e-5 to 3e-5, nothing else changed (config.json against 2026-11-29-cpu-half-cheetah-pytorch-init/'s
# differs only in lr and checkpoint_every), seeds 0-3 in one program, 1953 iterations; 31 minutes.
python -m jaxpg.cli --env half_cheetah --algo ppo --preset half_cheetah_1m --lr 3e-5 --seeds 0 1 2 3 \
  --log-every 50 --run-dir /tmp/hclr/run --no-progress > train.log 2>&1
for S in 0 1 2 3; do python -m jaxpg.evaluate /tmp/hclr/run --gymnasium --episodes 10 --train-seed $S > gym$S.log 2>&1; done
