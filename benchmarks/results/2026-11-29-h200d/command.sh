# One H200 (16 host cores), a freshly started machine, 2026-11-29, JAX 0.11.2, MuJoCo/MJX 3.17.0,
# warp-lang 1.18.0, MuJoCo Warp; the code at 168fdb3 (GPU memory taken on demand). In order, one script:

# startup/memory.*: JAX's GPU backend start and first buffers, 3 fresh processes each way, alternating.
python benchmarks/card_command.py memory --repeats 3 --json startup/memory.json

# card/: the card's command at hopper_1m, three bare-machine runs then three warm runs.
python benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --out card --json card/card.json --extra --preset hopper_1m

# startup/importtime.txt, imp.log: one more warm run (seed 0) under Python's import profiler, with the warm caches.
JAXPG_COMPILATION_CACHE=card/caches-warm/xla WARP_CACHE_PATH=card/caches-warm/warp CUDA_CACHE_PATH=card/caches-warm/cuda \
  python -X importtime experiments/hopper.py --num-envs 256 --preset hopper_1m --seed 0 --run-dir imp 2> startup/importtime.txt

# hopper_1m_seeds/: 64 more seeds of hopper_1m, two vmapped blocks of 32, both processes on the GPU at once
# (started together; each training process took 146-147 s, 182 s in all with the Gymnasium replays; one
# block alone took 110 s on the 2026-11-29 machine before, a slower one: warm card runs 23.8 s against 19.3 s here).
for first in 3064 3096; do
  python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
    --out runs/base$first --json hopper_1m_seeds/base-seeds$first.json &
done; wait

# hopper_1m_h16/: a second call on a freshly started machine: hopper_1m with horizon 16 and 240 iterations (the same
# 0.98 M env steps and physics steps in a row, twice the updates), seeds 3000-3095 in three vmapped blocks of 32,
# the three processes on the GPU at once (334-349 s each, Gymnasium replays included).
for first in 3000 3032 3064; do
  python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
    --out runs/h16-$first --json hopper_1m_h16/h16-seeds$first.json --extra --horizon 16 --iterations 240 &
done; wait

# matplotlib_ab/: a third freshly started H200 (a slower one). matplotlib imported on a thread beside the first
# block's compilation (new: 7954642, since reverted) or at the first drawing of curves.png (old: the code before).
# One bare then one warm run of the new code (first.*) filled the caches; then warm runs alternating old/new,
# seeds 1-3, each from a copy of those caches (.scratch script x3.sh, in short):
python benchmarks/card_command.py card --seeds 0 --modes cold warm --out first --json first.json --extra --preset hopper_1m
for i in 1 2 3; do for arm in old new; do
  (cd repo_$arm && python benchmarks/card_command.py card --seeds $i --modes warm --out $arm$i --json $arm$i.json --extra --preset hopper_1m)
done; done

# card_as_typed/: a fourth freshly started H200, the code at eb49950: the card's command as typed (the hopper
# preset, 1.97 M env steps), one bare run, then warm runs of seeds 0-2 from the caches it filled.
python benchmarks/card_command.py card --seeds 0 --modes cold warm --out card --json card_as_typed/card_a.json
python benchmarks/card_command.py card --seeds 1 2 --modes warm --out card --json card_as_typed/card_b.json
