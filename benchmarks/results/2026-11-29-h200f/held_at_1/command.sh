#!/bin/bash
# hopper_1m with its noise held at log-std 1, seeds 3000-3191 in six vmapped blocks of 32 (two waves of three at once); every seed's
# final policy replayed in Gymnasium Hopper-v5 (10 episodes) with clip(mean) and with the clipped mean.
D=/tmp/out6; mkdir -p $D; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; git log -1 --format=%H >> $D/gpu.txt 2>/dev/null; date -u > $D/start.txt
train() {  # wave name, first seeds...
  w=$1; shift
  for first in "$@"; do
    (python3 benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
      --out $D/runs/$w-$first --json $D/$w-seeds$first.json --extra --log-std-min 1 --log-std-final 1 --anneal-log-std-iterations 120 > $D/$w-$first.log 2>&1; date -u > $D/$w-$first.end) &
  done
  wait
}
physics() {  # wave name, workers
  python3 benchmarks/suite.py physics $(ls -d $D/runs/$1-*/hopper-npg-hopper_1m-*/) --variants gymnasium \
    --actions mode clipped_mean --episodes 10 --workers $2 --json $D/physics-$1.json > $D/physics-$1.log 2>&1
  date -u > $D/physics-$1.end
}
train a 3000 3032 3064
date -u > $D/a.end
(physics a 10) &
train b 3096 3128 3160
date -u > $D/b.end
wait
physics b 15
touch $D/done
