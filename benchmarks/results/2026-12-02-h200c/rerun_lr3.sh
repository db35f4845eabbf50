#!/bin/bash
# The lr 3e-5 half of command.sh again, with its Gymnasium replay, on a fresh machine (the first machine was
# handed back before command.sh's files were copied off it). Same seeds, same device kind: same runs.
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.g?; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt
python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
 --out $D/runs/lr3 --json $D/lr3.json --extra --lr 3e-5 --minutes 9 > $D/lr3.log 2>&1; date -u > $D/lr3.end
cp $D/runs/lr3/half_cheetah-*/config.json $D/lr3_config.json 2>/dev/null
python3 benchmarks/suite.py physics $(ls -d $D/runs/lr3/half_cheetah-*/) --variants gymnasium \
 --episodes 10 --workers 14 --json $D/physics_lr3.json > $D/physics_lr3.log 2>&1; date -u > $D/physics_lr3.end
touch $D/done
