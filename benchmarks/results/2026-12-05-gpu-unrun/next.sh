#!/bin/bash
# Written 2026-12-05 for the next GPU lease, not yet run (the day's device time was spent). On one H100,
# freshly started, from a copy of the repository, everything installed into /tmp/site with --no-compile:
#   1. the card's command (`python experiments/hopper.py --num-envs 256`) since curves.png is drawn once in
#      a short run: a bare run (seed 0), three warm runs each alone on the machine (seeds 1-3, one process
#      of card_command.py each, so that no Gymnasium replay runs beside a timed run), two more bare runs
#      (seeds 4, 5). Against 2026-12-05-h100/card/: warm 19.3-20.3 s alone, host work 1.5-1.8 s.
#   2. TRPO's `reacher_fast` exactly as committed (evaluated every 50 iterations, in blocks of 10):
#      seed 0 bare, then seeds 0-2 warm, each a process, each replayed 10 episodes in Gymnasium.
# Start with setsid and poll for $D/done:
#   setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/next.sh > /tmp/next.log 2>&1 < /dev/null &
D=${D:-/tmp/out}; R=/tmp/repo-next; mkdir -p $D; rm -rf $R; cp -r "$PWD" $R; rm -rf $R/.w?? $R/.wc? $R/.whl; cd $R
export PYTHONPATH=$R:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
git log -1 --format=%h >> $D/start.txt 2>/dev/null
python3 -m compileall -q -j 0 /tmp/site > $D/compileall.log 2>&1  # the bytecode a user's pip install writes
C="python3 benchmarks/card_command.py card --out $D/card"
$C --seeds 0 --modes cold --json $D/card_bare0.json > $D/card_bare0.log 2>&1
cp -r $D/card/caches-cold-0 $D/card/caches-warm  # what card_command.py does when one call has both modes
for s in 1 2 3; do $C --seeds $s --modes warm --json $D/card_warm$s.json > $D/card_warm$s.log 2>&1; done
$C --seeds 4 5 --modes cold --json $D/card_bare45.json > $D/card_bare45.log 2>&1
date -u > $D/card.end
python3 benchmarks/suite.py run --runs reacher:trpo:reacher_fast --seeds 0 1 2 --bare-first --episodes 10 \
  --out $D/runs --json $D/reacher_fast.json > $D/reacher_fast.log 2>&1
date -u > $D/reacher.end
mkdir -p $D/card_logs && cp $D/card/*.log $D/card_logs/ 2>/dev/null
touch $D/done
