# 2 CPU cores ("AMD EPYC"), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), 2026-11-28.
# Walker2d at Tianshou's TRPO settings (now --algo trpo --preset walker2d_1m), 8 seeds in one vmapped program.
# The run went 977 iterations (1,000,448 env steps, 2620 s with the replays' start); its checkpoint at 950
# was resumed to 976 iterations (999,424 env steps: the preset; a resume continues bit-identically) and
# each seed's final mean policy replayed 10 episodes in Gymnasium's Walker2d-v5.
TS="--algo trpo --num-envs 16 --horizon 64 --max-kl 0.01 --backtracks 10 --backtrack-ratio 0.8 --cg-iters 10 \
  --cg-damping 0.1 --gamma 0.99 --gae-lambda 0.95 --normalize-advantages --normalize-observations \
  --normalize-value-targets --value-lr 1e-3 --value-epochs 20 --value-batch-size 0 --policy-hidden 64 64 \
  --value-hidden 64 64 --policy-activation tanh --value-activation tanh --log-std-init -0.5 \
  --network-init orthogonal --policy-head-scale 0.01"
python -m jaxpg.cli --env walker2d $TS --seeds 0 1 2 3 4 5 6 7 --iterations 977 --eval-envs 8 --eval-every 245 \
  --log-every 61 --run-dir run --no-progress
for S in 0 1 2 3 4 5 6 7; do python -m jaxpg.evaluate run --gymnasium --episodes 10 --train-seed $S; done  # gymnasium_977_*
cp -r run run976 && rm -rf run976/checkpoints/977   # and metrics.jsonl cut after iteration 950
python -m jaxpg.cli --resume run976 --iterations 976 --no-progress
for S in 0 1 2 3 4 5 6 7; do python -m jaxpg.evaluate run976 --gymnasium --episodes 10 --train-seed $S; done  # gymnasium_976_*
