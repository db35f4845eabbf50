#!/bin/bash
# Written 2026-12-05 for a later GPU lease, not yet run: the suite's rows that have no H100 figure yet.
#   PART=1m (default): every 1 M-step preset measured elsewhere (H200 or CPU), 5 seeds in one vmapped
#     program each, all six programs side by side on one H100 (the 1 M figures are scores at a step
#     budget, not times), then each seed's final mean policy replayed 10 episodes in Gymnasium v5:
#     half_cheetah ppo, ant a2c, humanoid a2c, swimmer trpo, reacher trpo, pusher npg.
#   PART=swimmer_fast: TRPO's swimmer_fast as typed, seed 0 bare, then seeds 0-2 warm, one process each.
# Start with setsid and poll for $D/done:
#   setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/suite_h100.sh > /tmp/suite.log 2>&1 < /dev/null &
D=${D:-/tmp/out}; R=/tmp/repo-suite; mkdir -p $D; rm -rf $R; cp -r "$PWD" $R; rm -rf $R/.w?? $R/.wc? $R/.whl; cd $R
export PYTHONPATH=$R:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
git log -1 --format=%h >> $D/start.txt 2>/dev/null
replay() {  # name, task
  python3 benchmarks/suite.py physics $(ls -d $D/runs/$1/$2-*/) --variants gymnasium \
    --episodes 10 --workers 4 --json $D/physics_$1.json > $D/physics_$1.log 2>&1
}
one_m() {  # task, algo
  python3 benchmarks/suite.py run --runs $1:$2:$1_1m --seeds 0 1 2 3 4 --vmap-seeds --episodes 0 \
    --out $D/runs/$1 --json $D/$1.json > $D/$1.log 2>&1
  date -u > $D/$1.end; replay $1 $1
}
if [ "${PART:-1m}" = 1m ]; then
  one_m half_cheetah ppo & one_m ant a2c & one_m humanoid a2c &
  one_m swimmer trpo & one_m reacher trpo & one_m pusher npg &
  wait
else
  python3 benchmarks/suite.py run --runs swimmer:trpo:swimmer_fast --seeds 0 1 2 --bare-first --episodes 10 \
    --out $D/runs/swimmer_fast --json $D/swimmer_fast.json > $D/swimmer_fast.log 2>&1
fi
touch $D/done
