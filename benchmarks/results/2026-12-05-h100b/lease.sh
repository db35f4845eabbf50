#!/bin/bash
# One H100 lease, in order of what each step decides (written 2026-12-05, session six):
#   1. the card's command since curves.png is drawn once in a short run (next.sh's first part): seed 0
#      bare, seeds 1-3 warm, each alone in its own process of card_command.py;       -> /tmp/out/card*
#   2. the six 1 M presets side by side, 5 seeds each (suite_h100.sh PART=1m);          -> /tmp/out1m
#   3. TRPO's reacher_fast as committed, seeds 0-2, the first bare (next.sh's second part);
#   4. two more bare runs of the card (seeds 4, 5);
#   5. Swimmer's fast preset as typed (suite_h100.sh PART=swimmer_fast).               -> /tmp/outsw
# Each step touches its own marker in /tmp/out: card.end, 1m.end, reacher.end, bare45.end, then done.
#   setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/lease.sh > /tmp/lease.log 2>&1 < /dev/null &
# As run, this file lived in benchmarks/results/2026-12-05-gpu-unrun/ beside suite_h100.sh, whose PART=1m (the six
# 1 M presets side by side) has since been replaced by parts that each fit a lease.
HERE=$(cd "$(dirname "$0")" && pwd); SRC=$PWD
D=/tmp/out; R=/tmp/repo-next; mkdir -p $D; rm -rf $R; cp -r "$SRC" $R; rm -rf $R/.w?? $R/.wc? $R/.whl; cd $R
export PYTHONPATH=$R:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
git log -1 --format=%h >> $D/start.txt 2>/dev/null
python3 -m compileall -q -j 0 /tmp/site > $D/compileall.log 2>&1  # the bytecode a user's pip install writes
C="python3 benchmarks/card_command.py card --out $D/card"
$C --seeds 0 --modes cold --json $D/card_bare0.json > $D/card_bare0.log 2>&1
cp -r $D/card/caches-cold-0 $D/card/caches-warm  # what card_command.py does when one call has both modes
for s in 1 2 3; do $C --seeds $s --modes warm --json $D/card_warm$s.json > $D/card_warm$s.log 2>&1; done
mkdir -p $D/card_logs && cp $D/card/*.log $D/card_logs/ 2>/dev/null
date -u > $D/card.end
(cd $SRC && D=/tmp/out1m PART=1m bash $HERE/suite_h100.sh); date -u > $D/1m.end
python3 benchmarks/suite.py run --runs reacher:trpo:reacher_fast --seeds 0 1 2 --bare-first --episodes 10 \
  --out $D/runs --json $D/reacher_fast.json > $D/reacher_fast.log 2>&1
date -u > $D/reacher.end
$C --seeds 4 5 --modes cold --json $D/card_bare45.json > $D/card_bare45.log 2>&1
cp $D/card/*.log $D/card_logs/ 2>/dev/null; date -u > $D/bare45.end
(cd $SRC && D=/tmp/outsw PART=swimmer_fast bash $HERE/suite_h100.sh)
touch $D/done
