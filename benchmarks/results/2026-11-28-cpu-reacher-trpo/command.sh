# 2 CPU cores ("AMD EPYC"), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics, 2026-11-28.
# Reacher with TRPO at SB3 RL Zoo's tuned MuJoCo settings (2 envs x 1024 steps, 488 iterations =
# 999,424 env steps), 4 seeds in one vmapped program each; re0 = the Zoo's initial log-std 0, re05 and
# re05b = log-std -0.5 (now --algo trpo --preset reacher_1m). re0 and re05 ran side by side, re05b alone.
ZOO="--algo trpo --num-envs 2 --horizon 1024 --iterations 488 --gamma 0.99 --gae-lambda 0.95 --max-kl 0.01 \
  --cg-iters 25 --cg-damping 0.1 --backtracks 10 --backtrack-ratio 0.8 --normalize-advantages \
  --normalize-observations --normalize-value-targets --value-lr 1e-3 --value-epochs 20 --value-batch-size 128 \
  --policy-hidden 64 64 --value-hidden 64 64 --policy-activation tanh --value-activation tanh \
  --network-init orthogonal --policy-head-scale 0.01 --eval-envs 8 --eval-every 61 --log-every 20"
python -m jaxpg.cli --env reacher $ZOO --log-std-init 0 --seeds 0 1 2 3 --run-dir run-re0
python -m jaxpg.cli --env reacher $ZOO --log-std-init -0.5 --seeds 0 1 2 3 --run-dir run-re05
python -m jaxpg.cli --env reacher $ZOO --log-std-init -0.5 --seeds 4 5 6 7 --run-dir run-re05b
# each seed's final mean policy, 10 episodes in Gymnasium's Reacher-v5 (gymnasium_*_seedS.log)
python -m jaxpg.evaluate run-re05 --gymnasium --episodes 10 --train-seed S
