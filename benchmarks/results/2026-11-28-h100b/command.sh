# One H100 (16 host cores), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp; 2026-11-28.
# Two processes side by side on the GPU (XLA_PYTHON_CLIENT_MEM_FRACTION=0.4), each training 16 seeds in
# one vmapped program; each seed's final mean policy replayed 10 episodes in Gymnasium v5 (Ant-v5 given
# the run's include_cfrc_ext_in_observation=False).
S="0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15"
python benchmarks/suite.py run --runs walker2d:trpo:walker2d_1m --seeds $S --vmap-seeds --json walker_trpo.json
# started 20 s later; --minutes 19 is a training limit set so that the machine's session holds the replays
python benchmarks/suite.py run --runs ant:a2c:ant_1m --seeds $S --vmap-seeds --json ant_a2c.json --extra --minutes 19
# Then Hopper, three programs side by side (XLA_PYTHON_CLIENT_MEM_FRACTION=0.3), seeds 0-15, each program
# started 15 s after the one before: the preset; orthogonal initialisation with the policy's last layer
# scaled by 0.01; the last layer scaled by 0.01 alone (glorot initialisation)
S="0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15"
python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $S --vmap-seeds --json base.json
python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $S --vmap-seeds --json orth_head.json \
  --extra --network-init orthogonal --policy-head-scale 0.01
python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $S --vmap-seeds --json head.json \
  --extra --policy-head-scale 0.01
# and the first two again for seeds 16-31, two programs side by side (MEM_FRACTION 0.4)
S="16 17 18 19 20 21 22 23 24 25 26 27 28 29 30 31"
python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $S --vmap-seeds --json base2.json
python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $S --vmap-seeds --json orth_head2.json \
  --extra --network-init orthogonal --policy-head-scale 0.01
