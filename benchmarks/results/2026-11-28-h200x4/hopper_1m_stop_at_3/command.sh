# One host of 4 H200 GPUs (64 host cores), JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0, MuJoCo Warp;
# 2026-11-28, two rounds of four settings. Each GPU trained one setting in blocks of 32 seeds (1000 on, the
# seeds of ../hopper_1m_many_seeds/), each block one vmapped program, each seed's final mean policy replayed
# 10 episodes in Gymnasium's Hopper-v5. A setting stopped after the block that brought its third seed under
# 3000 (hopper_1m itself had 6 under 3000 in its first 96 seeds), or after 7 blocks.
# progress.txt: seeds done and seeds under 3000 after each block. Files: SETTING-seedsFIRST.json.
misses() {  # seeds of setting $1 under 3000 so far
  python3 -c "import json,glob; print(sum(r.get('gymnasium_return', 0) < 3000 for f in glob.glob('$1-seeds*.json') for r in json.load(open(f))['rows']))"
}
loop() {  # loop GPU NAME FLAGS...
  gpu=$1; name=$2; shift 2
  for b in 0 1 2 3 4 5 6; do
    first=$((1000 + 32 * b))
    CUDA_VISIBLE_DEVICES=$gpu python benchmarks/suite.py run --runs hopper:npg:hopper_1m \
      --seeds $(seq $first $((first + 31))) --vmap-seeds --out runs/$name --json $name-seeds$first.json \
      --extra "$@" || break
    echo "$name seeds $((32 * (b + 1))) misses $(misses $name)" >> progress.txt
    [ "$(misses $name)" -ge 3 ] && break
  done
}
# round 1
loop 0 p128 --policy-hidden 128 128 & loop 1 p32 --policy-hidden 32 32 &
loop 2 v256 --value-hidden 256 256 & loop 3 damp01 --cg-damping 0.1 & wait
# round 2
loop 0 g998 --gamma 0.998 & loop 1 g999 --gamma 0.999 &
loop 2 g998l95 --gamma 0.998 --gae-lambda 0.95 & loop 3 g997 --gamma 0.997 & wait
python benchmarks/suite.py count *.json --bar 3000
