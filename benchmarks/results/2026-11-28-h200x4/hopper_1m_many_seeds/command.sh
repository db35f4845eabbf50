# One host of 4 H200 GPUs (64 host cores), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp;
# 2026-11-28. Each GPU trained one setting, in blocks of 32 seeds, each block one vmapped program (a
# fresh process; the setting's XLA, Warp and CUDA caches filled by its first block), each seed's final
# mean policy replayed 10 episodes in Gymnasium's Hopper-v5. Every setting saw the same seeds (1000-1159
# and 2000-2063; the preset alone also 2064-2095). Files are named SETTING-seedsFIRST.json.
block() {  # block GPU NAME FIRST_SEED FLAGS...
  gpu=$1; name=$2; first=$3; shift 3
  CUDA_VISIBLE_DEVICES=$gpu python benchmarks/suite.py run --runs hopper:npg:hopper_1m \
    --seeds $(seq $first $((first + 31))) --vmap-seeds --out runs/$name --json $name-seeds$first.json \
    ${1:+--extra "$@"}
}
for first in 1000 1032 1064 1096 1128 2000 2032 2064; do block 0 base $first; done &
for first in 1000 1032 1064 1096 1128 2000 2032; do block 1 kl10a160 $first --kl-delta 0.1 --anneal-kl-iterations 160; done &
for first in 1000 1032 1064 1096 1128 2000 2032; do block 2 orthhead $first --network-init orthogonal --policy-head-scale 0.01; done &
for first in 1000 1032 1064 1096 1128 2000 2032; do
  block 3 orthkl $first --network-init orthogonal --policy-head-scale 0.01 --kl-delta 0.1 --anneal-kl-iterations 160
done &
wait
python benchmarks/suite.py count *.json --bar 3000
