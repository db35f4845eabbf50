# One H200 (kind nvidia-h200, 16 host cores), JAX 0.11.2, MJX 3.17.0, warp-lang 1.18.0, 2026-11-28, one session.
# 1. hopper_1m with Tianshou's initialisation on the card's path, 8 single-seed processes, seed 0 the machine's first run
python benchmarks/card_command.py card --seeds 0 1 2 3 4 5 6 7 --modes warm --json card_orth.json \
  --extra --preset hopper_1m --network-init orthogonal --policy-head-scale 0.01
# 2. TRPO from more envs, 8 seeds per program, three programs side by side (XLA_PYTHON_CLIENT_MEM_FRACTION=0.3)
S="0 1 2 3 4 5 6 7"
python benchmarks/suite.py run --runs swimmer:trpo:swimmer_1m --seeds $S --vmap-seeds --json sw16.json --extra --num-envs 16 --horizon 128
python benchmarks/suite.py run --runs swimmer:trpo:swimmer_1m --seeds $S --vmap-seeds --json sw32.json --extra --num-envs 32 --horizon 64
python benchmarks/suite.py run --runs reacher:trpo:reacher_1m --seeds $S --vmap-seeds --json re16.json --extra --num-envs 16 --horizon 128
# 3. training in Gymnasium's RK4: one seed alone, then two programs side by side (XLA_PYTHON_CLIENT_MEM_FRACTION=0.4) (the third, 1 M
#    steps, was cut off when the device time ran out)
X="--num-envs 16 --horizon 128 --fidelity gymnasium"
python benchmarks/suite.py run --runs swimmer:trpo:swimmer_1m --seeds 0 --json one.json --extra $X --iterations 244
python benchmarks/suite.py run --runs swimmer:trpo:swimmer_1m --seeds $S --vmap-seeds --json half.json --extra $X --iterations 244
python benchmarks/suite.py run --runs swimmer:trpo:swimmer_1m --seeds $S --vmap-seeds --json full.json --extra $X
