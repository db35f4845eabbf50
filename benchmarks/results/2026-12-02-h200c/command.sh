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
# How it ran: the machine's wheels installed as in the GPU recipe, then this script started with setsid and
# polled; the code at e86b7d7. It finished (lr3 280 s, lr4 276 s whole process), but the machine was handed
# back before its files were copied off, so only the two in-run tables printed by the polling call survive:
# lr3 in-run mean policy at 1 M, seeds 0-31: 7148, 6497, 5856, 6732, 5305, 6531, 4429, 5795, 6780, 6831, 7126,
#   5016, 6044, 4145, 6802, 4811, 6747, 6390, 5957, 3289, 5028, 7174, 6109, 4098, 5758, 5553, 3737, 5960, 5375,
#   4630, 5445, 5259 (median 5826)
# lr4 in-run mean policy at 1 M, seeds 0-31: 7083, 3785, 5789, 5905, 7060, 5395, 4923, 5125, 3963, 5933, 4869,
#   5466, 5386, 5145, 5501, 5338, 5613, 6055, 4791, 4553, 5133, 6703, 5782, 5295, 5939, 2992, 4064, 5658, 5299,
#   5437, 5388, 4562 (median 5387)
# rerun_lr3.sh then ran lr3 again with its Gymnasium replay on a second freshly started H200; its files are
# the ones kept here (MuJoCo Warp is not bit-reproducible across processes, so its seeds differ from the above).
