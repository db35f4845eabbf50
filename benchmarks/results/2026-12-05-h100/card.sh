#!/bin/bash
# The card's command as typed, `python experiments/hopper.py --num-envs 256`, on one GPU: a bare-machine
# run (card_command.py empties the XLA, Warp-kernel and CUDA-driver caches itself), three warm runs from the
# caches it filled, two more bare-machine runs, then two bare-machine runs with XLA's GPU autotuning off
# (XLA_FLAGS=--xla_gpu_autotune_level=0) to see what autotuning costs in compilation and gains in training;
# each run's final policy scored in Gymnasium as it goes. The XLA cache is listed after each step.
# MuJoCo, MJX and warp-lang are installed with --no-compile and then compiled to bytecode with compileall,
# as a user's `pip install` leaves them. SHORT=1 (a short lease): no second and third bare runs, one run without autotuning.
D=${D:-/tmp/out}; R=/tmp/repo-$(basename $0 .sh); mkdir -p $D; rm -rf $R; cp -r "$PWD" $R; rm -rf $R/.w?? $R/.wc? $R/.whl; cd $R
export PYTHONPATH=$R:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
git log -1 --format=%h >> $D/start.txt 2>/dev/null; env | grep ^PYTHON > $D/python_env.txt
python3 -m compileall -q -j 0 /tmp/site > $D/compileall.log 2>&1  # the bytecode a user's pip install writes
C="python3 benchmarks/card_command.py card --out $D/card"
lsc() { echo "== after $1: $(date -u +%T)"; ls -la $D/card/caches-warm/xla 2>/dev/null | tail -n +2; }
$C --seeds 0 --modes cold warm --json $D/card_a.json > $D/card_a.log 2>&1; lsc "cold 0, warm 0" >> $D/xla_cache.txt
$C --seeds 1 --modes warm --json $D/card_b.json > $D/card_b.log 2>&1; lsc "warm 1" >> $D/xla_cache.txt
$C --seeds 2 --modes warm --json $D/card_c.json > $D/card_c.log 2>&1; lsc "warm 2" >> $D/xla_cache.txt
[ "${SHORT:-0}" = 1 ] || { $C --seeds 1 2 --modes cold --json $D/card_d.json > $D/card_d.log 2>&1; lsc "cold 1 2" >> $D/xla_cache.txt; }
date -u > $D/card.end
XLA_FLAGS=--xla_gpu_autotune_level=0 python3 benchmarks/card_command.py card --out $D/noautotune --seeds 3 $([ "${SHORT:-0}" = 1 ] || echo 4) --modes cold \
 --json $D/card_noautotune.json > $D/card_noautotune.log 2>&1
date -u > $D/noautotune.end
touch $D/done
