# One H200 (16 host cores), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp; 2026-11-29.
# Three processes side by side, each training 16 seeds in one vmapped program, each seed's final mean
# policy replayed 10 episodes in Gymnasium v5 (Ant-v5 and Humanoid-v5 without contact forces, as the presets).
S="0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15"
export XLA_PYTHON_CLIENT_MEM_FRACTION=0.3
python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $S --vmap-seeds --out hc \
    --json hc_nr.json --extra --normalize-rewards --reward-scaling 1 > hc.log 2>&1 &
python3 benchmarks/suite.py run --runs ant:ppo:ant_1m --seeds $S --vmap-seeds --out ant --json ant_nr.json \
    --extra --normalize-rewards > ant.log 2>&1 &
python3 benchmarks/suite.py run --runs humanoid:ppo:humanoid_1m --seeds $S --vmap-seeds --out hum --json hum_nr.json \
    --extra --normalize-rewards > hum.log 2>&1 &
wait
