#!/bin/bash
# Ran on the code at 7e1aa10 (the device copy's .git was older: gpu.txt names 789744c; the logs show the new default, "mean policy, clipped mean").
# The card's command as typed, now hopper_1m by default: three bare-machine runs, three warm runs (seeds 0-2),
# then five more warm runs (seeds 3-7) with the same caches; each run's final policy in Gymnasium (its clipped mean).
D=/tmp/out7; mkdir -p $D; cd /tmp/repo
export PYTHONPATH=/tmp/repo:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; git log -1 --format=%H >> $D/gpu.txt 2>/dev/null; date -u > $D/start.txt
python3 benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --out $D/card --json $D/card.json > $D/card.log 2>&1
date -u > $D/card.end
python3 benchmarks/card_command.py card --seeds 3 4 5 6 7 --modes warm --out $D/card --json $D/card_warm3-7.json > $D/card_warm3-7.log 2>&1
cp $D/card/*-gymnasium.log $D/ 2>/dev/null
touch $D/done
