#!/bin/bash
# One H100 lease (session seven, 2026-12-05): the card's command since curves.png is drawn by a helper
# process and scipy.spatial is left unimported (the package code at this file's commit), against the code
# before (9dd5a49's jaxpg/, carried in .wold/), each run a fresh process of card_command.py alone on the
# machine. In order, each touching its marker in $D:
#   1. seed 0 bare (new code): fills the caches the warm runs use;                         card.end
#   2. warm, alternating old and new, seeds 1-3;                                           ab.end
#   3. card_command.py parts (new code), seeds 1-3, each with the preset's 16 evaluation episodes and with
#      --eval-envs 256 (the first 256 run also compiles that evaluation: a cache fill);      parts.end
#   4. two more bare runs of the new code (seeds 4, 5), then three more warm (6-8);        done
# Then, if the lease has time left, Ant's and Humanoid's A2C 1 M (suite_h100.sh PART=a2c) -> /tmp/out_a2c.
#   setsid nohup bash benchmarks/results/2026-12-05-h100c/lease.sh > /tmp/lease.log 2>&1 < /dev/null &
D=/tmp/outc; R=/tmp/repo-new; O=/tmp/repo-old; mkdir -p $D
rm -rf $R $O; cp -r "$PWD" $R; rm -rf $R/.w?? $R/.wc? $R/.whl $R/.wold
cp -r $R $O; rm -rf $O/jaxpg; cp -r "$PWD/.wold/jaxpg" $O/jaxpg
nvidia-smi -L > $D/gpu.txt 2>&1; nproc >> $D/gpu.txt; lscpu | grep 'Model name' >> $D/gpu.txt; date -u > $D/start.txt
python3 -m compileall -q -j 0 /tmp/site > $D/compileall.log 2>&1  # the bytecode a user's pip install writes
export PYTHONUNBUFFERED=1
new() { (cd $R && PYTHONPATH=$R:/tmp/site python3 benchmarks/card_command.py "$@"); }
old() { (cd $O && PYTHONPATH=$O:/tmp/site python3 benchmarks/card_command.py "$@"); }
new card --out $D/card --seeds 0 --modes cold --json $D/card_bare0.json > $D/card_bare0.log 2>&1
cp -r $D/card/caches-cold-0 $D/card/caches-warm  # what card_command.py does when one call has both modes
mkdir -p $D/card_old && cp -r $D/card/caches-cold-0 $D/card_old/caches-warm  # the same programs and kernels
date -u > $D/card.end
for s in 1 2 3; do
  old card --out $D/card_old --seeds $s --modes warm --json $D/old_warm$s.json > $D/old_warm$s.log 2>&1
  new card --out $D/card --seeds $s --modes warm --json $D/new_warm$s.json > $D/new_warm$s.log 2>&1
done
date -u > $D/ab.end
C=$D/card/caches-warm
for s in 1 2 3; do
  for e in 16 256; do
    (export JAXPG_COMPILATION_CACHE=$C/xla WARP_CACHE_PATH=$C/warp CUDA_CACHE_PATH=$C/cuda
     new parts --json $D/parts_e${e}_$s.json -- --seed $s --eval-envs $e > $D/parts_e${e}_$s.log 2>&1)
  done
done
date -u > $D/parts.end
new card --out $D/card --seeds 4 5 --modes cold --json $D/card_bare45.json > $D/card_bare45.log 2>&1
for s in 6 7 8; do
  new card --out $D/card --seeds $s --modes warm --json $D/new_warm$s.json > $D/new_warm$s.log 2>&1
done
mkdir -p $D/card_logs && cp $D/card/*.log $D/card_logs/ 2>/dev/null
touch $D/done
if [ "${A2C:-0}" = 1 ]; then
  (cd "$PWD" && D=/tmp/out_a2c PART=a2c bash benchmarks/results/2026-12-05-gpu-unrun/suite_h100.sh)
fi
