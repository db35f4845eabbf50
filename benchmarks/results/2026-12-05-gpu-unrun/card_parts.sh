#!/bin/bash
# Written 2026-12-05 for the next GPU lease, not yet run (about 4 minutes). Where a warm run of the card's
# command spends its "programs loaded" (2.9-3.3 s on one H100) and how much of its training is MuJoCo Warp's
# Python FFI callbacks (about 19,000 calls a run: one per physics step): a bare run fills the caches, then
# three warm runs of `card_command.py parts`, each a process, as typed. On 2 CPU cores
# (benchmarks/results/2026-12-05-cpu-card-parts/) the first block's two programs traced in 0.7-1.2 s each.
# Start with setsid and poll for $D/done:
#   setsid nohup bash benchmarks/results/2026-12-05-gpu-unrun/card_parts.sh > /tmp/parts.log 2>&1 < /dev/null &
D=${D:-/tmp/outp}; R=/tmp/repo-parts; mkdir -p $D; rm -rf $R; cp -r "$PWD" $R; rm -rf $R/.w?? $R/.wc? $R/.whl; cd $R
export PYTHONPATH=$R:/tmp/site PYTHONUNBUFFERED=1
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
python3 -m compileall -q -j 0 /tmp/site > $D/compileall.log 2>&1  # the bytecode a user's pip install writes
python3 benchmarks/card_command.py card --out $D/card --seeds 0 --modes cold --json $D/card_bare0.json \
  > $D/card_bare0.log 2>&1
export JAXPG_COMPILATION_CACHE=$D/card/caches-cold-0/xla WARP_CACHE_PATH=$D/card/caches-cold-0/warp \
  CUDA_CACHE_PATH=$D/card/caches-cold-0/cuda
for s in 1 2 3; do
  python3 benchmarks/card_command.py parts --json $D/parts$s.json -- --seed $s > $D/parts$s.log 2>&1
  # the evaluation with the training's 256 envs: on 2 CPU cores it traced 0.4-0.5 s faster; its GPU time?
  python3 benchmarks/card_command.py parts --json $D/parts_e256_$s.json -- --seed $s --eval-envs 256 \
    > $D/parts_e256_$s.log 2>&1
done
touch $D/done
