#!/bin/bash
# (1) Humanoid's A2C preset as typed (humanoid_1m: action scaling, 1 M env steps), 32 seeds in one program;
# (2) beside it, HalfCheetah PPO within 1 M with PyTorch's default initialisation, 16 seeds in one program.
# Then each seed's final policy replayed 10 episodes in Gymnasium v5.
D=/tmp/out10; mkdir -p $D; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1 XLA_PYTHON_CLIENT_MEM_FRACTION=0.45
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt
(python3 benchmarks/suite.py run --runs humanoid:a2c:humanoid_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
  --out $D/runs/a2c --json $D/a2c.json > $D/a2c.log 2>&1; date -u > $D/a2c.end
 python3 benchmarks/suite.py physics $(ls -d $D/runs/a2c/humanoid-*/) --variants gymnasium \
  --actions mode clipped_mean --episodes 10 --workers 8 --json $D/physics_a2c.json > $D/physics_a2c.log 2>&1
 date -u > $D/physics_a2c.end) &
(python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 0 15) --vmap-seeds --episodes 0 \
  --out $D/runs/hc --json $D/hc.json --extra --network-init pytorch > $D/hc.log 2>&1; date -u > $D/hc.end
 python3 benchmarks/suite.py physics $(ls -d $D/runs/hc/half_cheetah-*/) --variants gymnasium \
  --episodes 10 --workers 7 --json $D/physics_hc.json > $D/physics_hc.log 2>&1
 date -u > $D/physics_hc.end) &
wait
touch $D/done
