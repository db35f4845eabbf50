#!/bin/bash
# The card's command as typed, `python experiments/hopper.py --num-envs 256`, on a freshly started machine:
# three bare-machine runs (card_command.py empties the XLA, Warp-kernel and CUDA-driver caches itself),
# then three warm runs (seeds 0-2), each a fresh process; each run's final policy scored in Gymnasium.
D=/tmp/out3; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.w?? /tmp/repo/.whl; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
python3 benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --out $D/card --json $D/card.json > $D/card.log 2>&1
date -u > $D/card.end; cp $D/card/*.log $D/ 2>/dev/null
touch $D/done
