#!/bin/bash
# (1) The card's command, new default (hopper_1m) against the earlier hopper_1m (learned noise, clip(mean)) on one
# host: seed 0 bare then warm for each, then warm seeds 1 and 2 alternating. (2) Humanoid within 1 M env steps with
# the policy acting in [-1, 1] (--rescale-actions, Tianshou's action scaling), PPO and A2C, 32 seeds each, replayed
# in Gymnasium with the mode and the clipped mean.
D=/tmp/out8; mkdir -p $D; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt
OLD="--log-std-min -20 --anneal-log-std-iterations 0 --eval-action mode"
card() {  # name seeds modes [extra...]
  n=$1; s=$2; m=$3; shift 3
  python3 benchmarks/card_command.py card --seeds $s --modes $m --out $D/card-$n --json $D/card-$n-$s-$m.json ${@:+--extra "$@"} >> $D/card-$n.log 2>&1
}
card new 0 "cold warm"
card old 0 "cold warm" $OLD
for s in 1 2; do card new $s warm; card old $s warm $OLD; done
cp $D/card-*/*-gymnasium.log $D/ 2>/dev/null
date -u > $D/card.end
train() {  # name run extra...
  n=$1; r=$2; shift 2
  python3 benchmarks/suite.py run --runs $r --seeds $(seq 0 31) --vmap-seeds --episodes 0 --out $D/runs/$n \
    --json $D/$n.json --extra --minutes 14 "$@" > $D/$n.log 2>&1
  date -u > $D/$n.end
}
train ppo humanoid:ppo:humanoid_1m --rescale-actions --log-std-init -0.5 &
train a2c humanoid:a2c:humanoid_1m --rescale-actions --log-std-init -0.5 &
wait
python3 benchmarks/suite.py physics $(ls -d $D/runs/*/humanoid-*/) --variants gymnasium \
  --actions mode clipped_mean --episodes 10 --workers 15 --json $D/physics.json > $D/physics.log 2>&1
date -u > $D/physics.end
touch $D/done
# What happened: the first `card` step (seed 0, "cold warm") stopped at an argument error (the --json name held a
# space) and ran nothing, so seed 1's run in each folder was the first with its caches (bare) and seed 2's warm.
# The A2C program stopped at 0.6 M env steps by its --minutes 14; it was resumed to 0.8 M (stopped again by time):
#   JAXPG_COMPILATION_CACHE=$C/xla WARP_CACHE_PATH=$C/warp CUDA_CACHE_PATH=$C/cuda \
#     python3 -m jaxpg.cli --resume $D/runs/a2c/humanoid-a2c-humanoid_1m-seeds0to31 --iterations 12500 --minutes 7
# (a2c_resume.log). Its checkpoint at iteration 10000 (0.8 M env steps) was replayed on 2 CPU cores, here:
#   python benchmarks/suite.py physics RUN --variants gymnasium --actions mode clipped_mean --episodes 10 --workers 2 \
#     --json physics_a2c_0.8M.json
# The flag was then called --rescale-actions (the env keyword rescale_actions, as the runs' config.json files
# hold it); it was renamed --action-scaling (action_scaling) before it was committed with this record's docs.
