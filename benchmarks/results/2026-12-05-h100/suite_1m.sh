#!/bin/bash
# Two 1 M / fast experiments side by side on one GPU, each seed's final mean policy replayed 10 episodes in
# Gymnasium's v5 env:
#   hc:  HalfCheetah's 1 M PPO preset (half_cheetah_1m, SB3 RL Zoo's settings) with the two levers that came
#        nearest 5784 alone, together: lr 4e-5 annealed to 0 over the 1953 updates, and advantages
#        standardised per minibatch; seeds 0-31 in one vmapped program.
#   r64k / r128: Reacher's TRPO (reacher_1m) with updates 16 times as large (32768 samples) from 512 envs x
#        64 steps, the value fit in minibatches of 1024 (r64k) or of the preset's 128 (r128); seeds 0-3 in
#        one vmapped program each, one after the other beside hc.
D=${D:-/tmp/out}; R=/tmp/repo-$(basename $0 .sh); mkdir -p $D; rm -rf $R; cp -r "$PWD" $R; rm -rf $R/.w?? $R/.wc? $R/.whl; cd $R
export PYTHONPATH=$R:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
git log -1 --format=%h >> $D/start.txt 2>/dev/null
replay() {  # run name, task
  python3 benchmarks/suite.py physics $(ls -d $D/runs/$1/$2-*/) --variants gymnasium \
   --episodes 10 --workers 6 --json $D/physics_$1.json > $D/physics_$1.log 2>&1; date -u > $D/physics_$1.end
}
hc() {
  python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
   --out $D/runs/hc --json $D/hc.json --extra --lr 4e-5 --anneal-lr-iterations 1953 --normalize-minibatch-advantages \
   --minutes 12 > $D/hc.log 2>&1; date -u > $D/hc.end; replay hc half_cheetah
}
reacher() {  # run name, value batch size
  python3 benchmarks/suite.py run --runs reacher:trpo:reacher_1m --seeds 0 1 2 3 --vmap-seeds --episodes 0 \
   --out $D/runs/$1 --json $D/$1.json --extra --num-envs 512 --horizon 64 --value-batch-size $2 \
   --minutes 6 > $D/$1.log 2>&1; date -u > $D/$1.end; replay $1 reacher
}
hc &
(reacher r64k 1024; reacher r128 128) &
wait
touch $D/done
