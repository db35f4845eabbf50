# 2 CPU cores ("AMD EPYC"), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics, 2026-11-28.
# Swimmer with TRPO at SB3 RL Zoo's tuned Swimmer settings (2 envs x 1024 steps, 488 iterations =
# 999,424 env steps), 4 seeds in one vmapped program each; zoo = the Zoo's initial log-std 0, ls05 and
# ls05b = log-std 0.5 (now --algo trpo --preset swimmer_1m; the two ls05 programs ran side by side).
ZOO="--algo trpo --num-envs 2 --horizon 1024 --iterations 488 --gamma 0.9999 --gae-lambda 0.95 --max-kl 0.01 \
  --cg-iters 25 --cg-damping 0.1 --backtracks 10 --backtrack-ratio 0.8 --normalize-advantages \
  --normalize-observations --normalize-value-targets --value-lr 1e-3 --value-epochs 20 --value-batch-size 128 \
  --policy-hidden 64 64 --value-hidden 64 64 --policy-activation tanh --value-activation tanh \
  --network-init orthogonal --policy-head-scale 0.01 --eval-envs 8 --eval-every 61 --log-every 20"
python -m jaxpg.cli --env swimmer $ZOO --log-std-init 0 --seeds 0 1 2 3 --run-dir run-zoo
python -m jaxpg.cli --env swimmer $ZOO --log-std-init 0.5 --seeds 0 1 2 3 --run-dir run-ls05
python -m jaxpg.cli --env swimmer $ZOO --log-std-init 0.5 --seeds 4 5 6 7 --run-dir run-ls05b
# each seed's final mean policy, 10 episodes in Gymnasium's Swimmer-v5 (gymnasium_*_seedS.log)
python -m jaxpg.evaluate run-ls05 --gymnasium --episodes 10 --train-seed S
# The preset with the same samples an update from 16 envs x 128 steps (sw16; run alone):
python -m jaxpg.cli --env swimmer --algo trpo --preset swimmer_1m --num-envs 16 --horizon 128 --seeds 0 1 2 3 \
  --log-every 61 --no-progress --run-dir run-sw16
