#!/bin/bash
# Call 2: resume the run of command.sh to 1 M env steps with the first call's caches, then the Gymnasium replay.
D=/tmp/out; cd /tmp/repo; export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
C=$D/runs/ant/caches; R=$(ls -d $D/runs/ant/ant-*/ | head -1); date -u > $D/ant_resume.start
JAXPG_COMPILATION_CACHE=$C/xla WARP_CACHE_PATH=$C/warp CUDA_CACHE_PATH=$C/cuda \
  python3 -m jaxpg.cli --resume $R --iterations 12500 --minutes 8 > $D/ant_resume.log 2>&1; date -u > $D/ant_resume.end
python3 benchmarks/suite.py physics $R --variants gymnasium --actions mode clipped_mean --episodes 10 --workers 15 \
  --json $D/physics_ant.json > $D/physics_ant.log 2>&1; date -u > $D/physics_ant.end
