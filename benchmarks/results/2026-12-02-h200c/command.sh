#!/bin/bash
# HalfCheetah's PPO preset within 1 M env steps (half_cheetah_1m --algo ppo: SB3 RL Zoo's settings, 16 envs x
# 32 steps an update) with only the learning rate changed: (a) 3e-5, (b) 4e-5, in place of the Zoo's 2.0633e-5.
# Seeds 0-31 in one vmapped program each; (a) runs alone, then (b) runs while (a)'s final mean policies are
# replayed 10 episodes each in Gymnasium's HalfCheetah-v5; then (b)'s replay.
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.g?; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt; git log -1 --format=%h >> $D/start.txt 2>/dev/null
replay() {
  python3 benchmarks/suite.py physics $(ls -d $D/runs/$1/half_cheetah-*/) --variants gymnasium \
   --episodes 10 --workers 14 --json $D/physics_$1.json > $D/physics_$1.log 2>&1; date -u > $D/physics_$1.end
}
train() {
  python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
   --out $D/runs/$1 --json $D/$1.json --extra --lr $2 --minutes 9 > $D/$1.log 2>&1; date -u > $D/$1.end
}
train lr3 3e-5
replay lr3 &
train lr4 4e-5
wait
replay lr4
touch $D/done
