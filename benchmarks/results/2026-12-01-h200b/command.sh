#!/bin/bash
# Second batches of seeds for two 1 M-step presets, side by side on one GPU:
# (1) Ant's A2C preset as typed (ant_1m --algo a2c: trained in the "gymnasium" fidelity), seeds 16-31 in one program;
# (2) HalfCheetah's PPO preset as typed (half_cheetah_1m --algo ppo), seeds 16-31 in one program.
# Each seed's final policy is then replayed 10 episodes in Gymnasium v5.
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.g?; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; date -u > $D/start.txt
(python3 benchmarks/suite.py run --runs ant:a2c:ant_1m --seeds $(seq 16 31) --vmap-seeds --episodes 0 \
  --out $D/runs/ant --json $D/ant.json --extra --minutes 16 > $D/ant.log 2>&1; date -u > $D/ant.end
 python3 benchmarks/suite.py physics $(ls -d $D/runs/ant/ant-*/) --variants gymnasium \
  --actions mode clipped_mean --episodes 10 --workers 8 --json $D/physics_ant.json > $D/physics_ant.log 2>&1
 date -u > $D/physics_ant.end) &
(python3 benchmarks/suite.py run --runs half_cheetah:ppo:half_cheetah_1m --seeds $(seq 16 31) --vmap-seeds --episodes 0 \
  --out $D/runs/hc --json $D/hc.json > $D/hc.log 2>&1; date -u > $D/hc.end
 python3 benchmarks/suite.py physics $(ls -d $D/runs/hc/half_cheetah-*/) --variants gymnasium \
  --episodes 10 --workers 7 --json $D/physics_hc.json > $D/physics_hc.log 2>&1
 date -u > $D/physics_hc.end) &
wait
touch $D/done
# What happened: the first machine ran both programs; HalfCheetah's finished, Ant's reached 0.31 M env steps, and the
# machine was released (idle) before anything came back. On a second freshly started machine, only HalfCheetah's
# program ran, alone, with --extra --minutes 7 as a guard (it finished its 1953 iterations in 261 s), then the replay
# with --workers 15: hc.log, hc.json, hc_run.log, hc_config.json, hc_curves.png; the replay's table in
# physics_hc_table.md.
