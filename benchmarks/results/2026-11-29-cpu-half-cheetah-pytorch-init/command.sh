# 2 CPU cores, JAX 0.10.2, MJX 3.17.0 (JAX implementation), 2026-11-29: HalfCheetah with `half_cheetah_1m --algo ppo`
# (SB3 RL Zoo's settings) and PyTorch's default initialisation (the Zoo's `ortho_init=False`; the preset has
# glorot_uniform), seeds 0-3 in one program, 1953 iterations (0.9999 M env steps); 46 minutes on this machine.
python -m jaxpg.cli --env half_cheetah --algo ppo --preset half_cheetah_1m --network-init pytorch --seeds 0 1 2 3 \
  --log-every 50 --run-dir /tmp/hcpt/run --no-progress > train.log 2>&1
for S in 0 1 2 3; do python -m jaxpg.evaluate /tmp/hcpt/run --gymnasium --episodes 10 --train-seed $S > gym$S.log 2>&1; done
