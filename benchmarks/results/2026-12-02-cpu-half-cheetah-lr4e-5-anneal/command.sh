# 2 CPU cores, JAX 0.10.2, MJX 3.17.0 (JAX implementation), 2026-12-02, the code at c473f0e: HalfCheetah with
# `half_cheetah_1m --algo ppo` and its learning rate starting at 4e-5, annealed linearly to 0 over the 1953
# iterations, nothing else changed; seeds 0-3 in one program (the GPU's second method, beside
# 2026-12-02-h200c/lr4_anneal.sh).
python -m jaxpg.cli --env half_cheetah --algo ppo --preset half_cheetah_1m --lr 4e-5 --anneal-lr-iterations 1953 \
  --seeds 0 1 2 3 --log-every 50 --run-dir /tmp/hcla/run --no-progress > train.log 2>&1
for S in 0 1 2 3; do python -m jaxpg.evaluate /tmp/hcla/run --gymnasium --episodes 10 --train-seed $S > gym$S.log 2>&1; done
# Ran as above: 32 minutes of training; Gymnasium 7343, 5271 (one episode of 10 at -0.01), 5375, 6836.
