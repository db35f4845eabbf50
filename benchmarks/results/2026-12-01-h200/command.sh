#!/bin/bash
# (1) Humanoid's A2C preset as typed (humanoid_1m: action scaling, 12,500 iterations, 1 M env steps), 32 seeds in
# one program, to its end; (2) beside it, Ant's A2C preset (ant_1m --algo a2c) trained in the "gymnasium" fidelity
# (Gymnasium's RK4 and MuJoCo's default solver in place of Euler and a short Newton solve), 16 seeds in one program,
# stopped by --minutes. Each seed's final policy is then replayed 10 episodes in Gymnasium v5.
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.g?; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; git log -1 --format=%H >> $D/gpu.txt 2>/dev/null; date -u > $D/start.txt
(python3 benchmarks/suite.py run --runs humanoid:a2c:humanoid_1m --seeds $(seq 0 31) --vmap-seeds --episodes 0 \
  --out $D/runs/hum --json $D/hum.json > $D/hum.log 2>&1; date -u > $D/hum.end
 python3 benchmarks/suite.py physics $(ls -d $D/runs/hum/humanoid-*/) --variants gymnasium \
  --actions mode clipped_mean --episodes 10 --workers 8 --json $D/physics_hum.json > $D/physics_hum.log 2>&1
 date -u > $D/physics_hum.end) &
(python3 benchmarks/suite.py run --runs ant:a2c:ant_1m --seeds $(seq 0 15) --vmap-seeds --episodes 0 \
  --out $D/runs/ant --json $D/ant.json --extra --fidelity gymnasium --minutes 11 > $D/ant.log 2>&1; date -u > $D/ant.end
 python3 benchmarks/suite.py physics $(ls -d $D/runs/ant/ant-*/) --variants gymnasium \
  --actions mode clipped_mean --episodes 10 --workers 7 --json $D/physics_ant.json > $D/physics_ant.log 2>&1
 date -u > $D/physics_ant.end) &
wait
touch $D/done
# What happened: both programs ran side by side; the Ant program stopped at 0.504 M env steps by its --minutes 11
# (ant.log, ant_run.log, physics_ant.* replay its policies there). Its run directory was copied and resumed alone
# to 1 M with the same caches (ant_resume.log), then replayed (physics_ant1m.*):
#   C=$D/runs/ant/caches; JAXPG_COMPILATION_CACHE=$C/xla WARP_CACHE_PATH=$C/warp CUDA_CACHE_PATH=$C/cuda \
#     python3 -m jaxpg.cli --resume $D/runs/ant1m/ant-a2c-ant_1m-seeds0to15 --iterations 12500 --minutes 9
#   python3 benchmarks/suite.py physics RUN --variants gymnasium --actions mode clipped_mean --episodes 10 --workers 8
# Then the control, alone on the GPU: the same preset in the fast physics, the same seeds (antfast*.log/json,
# physics_antfast.*):
#   python3 benchmarks/suite.py run --runs ant:a2c:ant_1m --seeds $(seq 0 15) --vmap-seeds --episodes 0 \
#     --out $D/runs/antfast --json antfast.json --extra --minutes 4.5
#   python3 benchmarks/suite.py physics RUN --variants gymnasium --actions mode clipped_mean --episodes 10 --workers 15
# runs/ holds each run's config.json and curves.png (ant_gymnasium_fidelity_1m: the resumed run at 1 M).
