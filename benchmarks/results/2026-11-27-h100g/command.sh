# One H100 (nvidia-h100-x1), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp; 2026-11-27.
# Each line is one process training 16 seeds in one vmapped program (its wall clock is the batch's, shared
# with the processes beside it), each seed's final mean policy replayed 10 episodes in Gymnasium v5.
S="0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15"
# Hopper within 1 M: the preset as it is (256 envs x 32 steps) against 512 envs x 16 steps (same 120 iterations)
python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $S --vmap-seeds --json hopper_1m-256x32.json
XLA_PYTHON_CLIENT_MEM_FRACTION=0.45 python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $S --vmap-seeds \
    --json hopper_1m-512x16.json --extra --num-envs 512 --horizon 16
# Ant within 1 M (beside the 512x16 run): the new PPO preset, contact forces left out of the observation
XLA_PYTHON_CLIENT_MEM_FRACTION=0.45 python benchmarks/suite.py run --runs ant:ppo:ant_1m --seeds $S --vmap-seeds --json ant_1m.json
# Three side by side (XLA_PYTHON_CLIENT_MEM_FRACTION=0.3):
#  ant_1m with Tianshou's value-target normalisation and value weight 0.25
python benchmarks/suite.py run --runs ant:ppo:ant_1m --seeds $S --vmap-seeds --json ant_1m-nvt-vcoef025.json \
    --extra --normalize-value-targets --value-coef 0.25
#  the same without advantage normalisation (Tianshou's norm_adv=0): stopped at iteration 272 of 488 to free the GPU;
#  its mean-policy returns at iteration 244 (500 k env steps): median 945 (against 1236 above, 1074 for ant_1m)
#  A2C, Tianshou's Ant settings (16 envs x 5 steps, RMSprop 7e-4, 12500 iterations): stopped after its checkpoint
#  at 400 k env steps (5000 iterations), whose mean policies the table replays (median 780)
python benchmarks/suite.py run --runs ant:a2c:minpy --seeds $S --vmap-seeds --json ant-a2c-stopped-400k.json \
    --extra --env-kwargs include_cfrc_ext_in_observation=false --gae-lambda 0.95 --normalize-observations \
    --log-std-init -0.5 --normalize-value-targets --iterations 12500 --eval-envs 16 --eval-every 1250 --log-every 250 \
    --checkpoint-every 2500
