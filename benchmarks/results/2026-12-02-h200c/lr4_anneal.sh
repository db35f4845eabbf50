#!/bin/bash
# HalfCheetah's 1 M PPO preset with its learning rate starting at 4e-5 and annealed linearly to 0 over the
# 1953 updates (the same mean rate as the Zoo's constant 2.06e-5, twice it at the start), seeds 0-31 in one
# program alone on the GPU, then each seed's final mean policy replayed 10 episodes in HalfCheetah-v5.
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.g?; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt
python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
 --out $D/runs/lr4a --json $D/lr4a.json --extra --lr 4e-5 --anneal-lr-iterations 1953 --minutes 5.5 > $D/lr4a.log 2>&1
date -u > $D/lr4a.end; cp $D/runs/lr4a/half_cheetah-*/config.json $D/lr4a_config.json 2>/dev/null
python3 benchmarks/suite.py physics $(ls -d $D/runs/lr4a/half_cheetah-*/) --variants gymnasium \
 --episodes 10 --workers 14 --json $D/physics_lr4a.json > $D/physics_lr4a.log 2>&1; date -u > $D/physics_lr4a.end
touch $D/done
# How it ran: on a third freshly started H200 (lr4a_gpu.txt, lr4a_start.txt), the code at c5ba11f, started
# with setsid and polled, its files copied off in the same call; 279 s whole process.
