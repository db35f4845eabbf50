# One H100 (nvidia-h100-x1), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp; 2026-11-28.
# Three processes side by side on the GPU (XLA_PYTHON_CLIENT_MEM_FRACTION=0.3), each training 16 seeds in
# one vmapped program; each seed's final mean policy replayed 10 episodes in Gymnasium v5 (given the run's
# include_cfrc_ext_in_observation=False).
S="0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15"
NOCF="--env-kwargs include_cfrc_ext_in_observation=false"
# A2C at Tianshou's MuJoCo settings (now the a2c presets ant_1m and humanoid_1m); the --minutes 21 training
# limit stopped them at 11,050 (Ant, 0.884 M env steps) and 11,350 (Humanoid, 0.908 M) of 12,500 iterations.
TS_A2C="--gae-lambda 0.95 --normalize-observations --normalize-value-targets --iterations 12500 --eval-envs 16 \
  --eval-every 2500 --log-every 250 --network-init orthogonal --policy-head-scale 0.01 --no-rmsprop-eps-in-sqrt \
  --anneal-lr-iterations 37500 --minutes 21"
# Humanoid PPO: humanoid_1m as it was plus Tianshou's initialisation and initial std in Humanoid's action
# units (now the ppo preset humanoid_1m)
python benchmarks/suite.py run --runs humanoid:ppo:humanoid_1m --seeds $S --vmap-seeds --json hum_ppo_ts.json \
  --extra $NOCF --log-std-init -1.42 --network-init orthogonal --policy-head-scale 0.01
python benchmarks/suite.py run --runs humanoid:a2c:minpy --seeds $S --vmap-seeds --json hum_a2c_ts.json \
  --extra $NOCF --log-std-init -1.42 $TS_A2C
python benchmarks/suite.py run --runs ant:a2c:minpy --seeds $S --vmap-seeds --json ant_a2c_ts.json \
  --extra $NOCF --log-std-init -0.5 $TS_A2C
