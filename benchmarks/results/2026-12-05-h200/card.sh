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
# How it ran: on a freshly started H200 (card/gpu.txt, card/start.txt) with 220 s of the session's device time
# left, the code at 998f390, started with setsid and polled by poll.sh 130; the first try of the same call
# failed at `from mujoco import mjx` (mujoco and mujoco-mjx installed by two pip calls into one --target: the
# second left MJX out); the second installed MJX's wheels into another folder and copied them over. The lease
# ended after the bare run of seed 0 and the warm runs of seeds 0 and 1 (seed 2's log is cut off).
