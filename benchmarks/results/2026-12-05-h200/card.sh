#!/bin/bash
# The card's command as typed, `python experiments/hopper.py --num-envs 256`, on a freshly started machine,
# each run a fresh process: a bare-machine run (card_command.py empties the XLA, Warp-kernel and CUDA-driver
# caches itself), three warm runs from the caches it filled, then two more bare-machine runs; each run's final
# policy scored in Gymnasium as it goes. Ordered so that a short lease still gets one bare and three warm runs.
D=/tmp/out3; mkdir -p $D; rm -rf /tmp/repo; cp -r "$PWD" /tmp/repo; rm -rf /tmp/repo/.w?? /tmp/repo/.whl; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
C="python3 benchmarks/card_command.py card --out $D/card"
$C --seeds 0 --modes cold warm --json $D/card_a.json > $D/card_a.log 2>&1
$C --seeds 1 2 --modes warm --json $D/card_b.json > $D/card_b.log 2>&1
$C --seeds 1 2 --modes cold --json $D/card_c.json > $D/card_c.log 2>&1
date -u > $D/card.end; cp $D/card/*.log $D/ 2>/dev/null
touch $D/done
