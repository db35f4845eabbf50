# One H200 (16 host cores), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp; 2026-11-29.
# The second batch of 16 seeds of PPO's humanoid_1m with --normalize-rewards (the first, seeds 0-15:
# ../../2026-11-29-h200/normalize_rewards/); one program (400 s), the test suite running on the CPU
# cores beside it from its 60th second. Each seed's final mean policy replayed 10 episodes in Gymnasium's
# Humanoid-v5 without contact forces (as the preset).
S="16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31"
python3 benchmarks/suite.py run --runs humanoid:ppo:humanoid_1m --seeds $S --vmap-seeds --out hum --json hum_nr2.json \
    --extra --normalize-rewards > hum.log 2>&1
