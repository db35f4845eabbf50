#!/bin/bash
# HalfCheetah's PPO preset within 1 M env steps (half_cheetah_1m --algo ppo: SB3 RL Zoo's settings,
# 16 envs x 32 steps an update) with longer sampling windows at the same 512 samples an update and the
# same 1953 updates: (a) 8 envs x 64 steps, (b) 4 envs x 128 steps (the Zoo steps 1 env x 512).
# Seeds 0-31 in one vmapped program each, both programs side by side on one GPU, each seed's final
# mean policy then replayed 10 episodes in Gymnasium's HalfCheetah-v5.
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.g?; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt
for v in "w64 8 64" "w128 4 128"; do set -- $v
 (python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
   --out $D/runs/$1 --json $D/$1.json --extra --num-envs $2 --horizon $3 --minutes 12 > $D/$1.log 2>&1; date -u > $D/$1.end
  python3 benchmarks/suite.py physics $(ls -d $D/runs/$1/half_cheetah-*/) --variants gymnasium \
   --episodes 10 --workers 7 --json $D/physics_$1.json > $D/physics_$1.log 2>&1
  date -u > $D/physics_$1.end) &
done
wait
touch $D/done
# How it ran: the machine's wheels installed as in the GPU recipe, then this script started with setsid
# (so that it outlived the call that started it) and polled from two calls; the code at 6324847.
# 4 x 128 stopped at its 12-minute guard (1180 of 1953 updates, 0.60 M env steps). Kept here: the logs,
# the two JSON files of each program and its config.json (metrics.jsonl, 29-48 MB each, left out).
