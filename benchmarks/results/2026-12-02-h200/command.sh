#!/bin/bash
# Second batch of seeds for Ant's A2C preset as typed (ant_1m --algo a2c: Tianshou's A2C settings, trained in the
# "gymnasium" fidelity), seeds 16-31 in one program alone on a freshly started H200, in two device calls of at most
# 600 s each: the first trains for 6 minutes (counted after its first compiled block) and checkpoints, the second
# resumes the same run directory with the same caches to its 12,500 iterations (1 M env steps). Each seed's final
# policy is then replayed 10 episodes in Gymnasium v5.
# Call 1 (after the payload is installed to /tmp/site):
D=/tmp/out; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.g?; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; git log -1 --format=%H >> $D/gpu.txt 2>/dev/null; date -u > $D/start.txt
python3 benchmarks/suite.py run --runs ant:a2c:ant_1m --seeds $(seq 16 31) --vmap-seeds --episodes 0 \
  --out $D/runs/ant --json $D/ant.json --extra --minutes 6 > $D/ant.log 2>&1; date -u > $D/ant.end
