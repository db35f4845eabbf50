# 2 CPU cores (this program on one: taskset -c 0), JAX 0.10.2, MJX 3.17.0 (its JAX implementation), fast physics,
# 2026-12-05, the code at acab5c1, seeds 0-3 in one vmapped program (training 1312 s).
# HalfCheetah with PPO at Tianshou's own MuJoCo PPO settings (mujoco_ppo.py; 64 envs x 32 steps = 2048
# samples, where its current script uses 8 envs x 256; its recompute_advantage is not reproduced),
# 10 epochs x 32 minibatches, lr 3e-4 decaying linearly over its 3 M-step run (1500 updates;
# two thirds left at 1 M), clip 0.2, value weight 0.25, no entropy bonus, gradient norm 0.5, no
# advantage normalisation, returns normalised, 64x64 tanh networks with orthogonal init and the
# policy head x 0.01, initial log-std -0.5, observation normalisation), 488 updates (0.999 M env steps).
python -m jaxpg.cli --env half_cheetah --algo ppo --num-envs 64 --horizon 32 --iterations 488 \
  --gamma 0.99 --gae-lambda 0.95 --normalize-observations --policy-hidden 64 64 --value-hidden 64 64 \
  --policy-activation tanh --value-activation tanh --network-init orthogonal --policy-head-scale 0.01 \
  --log-std-init -0.5 --normalize-value-targets --no-normalize-advantages --value-coef 0.25 --entropy-coef 0 \
  --max-grad-norm 0.5 --clip-eps 0.2 --num-epochs 10 --num-minibatches 32 --lr 3e-4 --anneal-lr-iterations 1500 \
  --eval-envs 16 --eval-every 122 --log-every 20 --no-progress --seeds 0 1 2 3 --run-dir run > train.log
# each seed's final mean policy, 10 episodes in Gymnasium's HalfCheetah-v5 (gymnasium_seedS.log)
for S in 0 1 2 3; do python -m jaxpg.evaluate run --gymnasium --episodes 10 --train-seed $S > gymnasium_seed$S.log; done
# Ran as above. In-run mean policy at 1 M: 3895, 5022, 4070, 3436. Gymnasium: 3853, 5914 +- 2577 (one episode
# of 10 at 15), 4051, 3449: median 3952, against 5697 for the same seeds with half_cheetah_1m --algo ppo on
# a CPU (2026-11-29). A second program (seeds 4-7) was stopped at 0.41 M env steps once these were in.
