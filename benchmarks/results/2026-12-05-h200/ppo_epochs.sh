#!/bin/bash
# HalfCheetah's 1 M PPO preset (half_cheetah_1m, SB3 RL Zoo's settings) with PPO's two new options,
# seeds 0-31 in one vmapped program per arm, both arms at once on one GPU:
#   mb:   --normalize-minibatch-advantages (each minibatch of 64 standardised on its own, as SB3 does)
#   mbre: the same plus --recompute-advantages (Tianshou's recompute_advantage)
# then each seed's final mean policy replayed 10 episodes in Gymnasium's HalfCheetah-v5.
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.w?? /tmp/repo/.whl; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt; git log -1 --format=%h >> $D/start.txt 2>/dev/null
arm() {
  name=$1; shift
  python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
   --out $D/runs/$name --json $D/$name.json --extra "$@" --minutes 9 > $D/$name.log 2>&1; date -u > $D/$name.end
  python3 benchmarks/suite.py physics $(ls -d $D/runs/$name/half_cheetah-*/) --variants gymnasium \
   --episodes 10 --workers 7 --json $D/physics_$name.json > $D/physics_$name.log 2>&1; date -u > $D/physics_$name.end
}
arm mb --normalize-minibatch-advantages &
arm mbre --normalize-minibatch-advantages --recompute-advantages &
wait
touch $D/done
# How it ran: on a freshly started H200 (gpu.txt, start.txt), the code at 3d0e838 (the device copy's .git
# named 83ecd2d; the configs show both options), started with setsid and polled by poll.sh 560, its small
# files packed in the same call; each program 494-497 s whole process beside the other (279 s alone before).
# The runs' metrics.jsonl (46 MB each) are not kept.
