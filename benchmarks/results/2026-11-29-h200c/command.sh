# One H200 (16 host cores), a freshly started machine, 2026-11-29, JAX 0.11.2, MuJoCo/MJX 3.17.0,
# warp-lang 1.18.0, MuJoCo Warp; the code at a88042f (MjxEnv.substep) unless said otherwise. In order:

# card/: the card's command at hopper_1m, three bare-machine runs then three warm runs.
python benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --out card --json card/card.json --extra --preset hopper_1m

# hopper_1m_physics/: 64 new seeds of hopper_1m in two vmapped blocks of 32 (each a fresh process, each
# with its own caches), trained in jaxpg's fast physics (base-*) and in Gymnasium's (gymfid-*: --fidelity
# gymnasium, RK4 and MuJoCo's default solver), each seed's final mean policy scored in Gymnasium (10 episodes).
for first in 3000 3032; do
  python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
    --out runs/base$first --json hopper_1m_physics/base-seeds$first.json
done
for first in 3000 3032; do
  python benchmarks/suite.py run --runs hopper:npg:hopper_1m --seeds $(seq $first $((first + 31))) --vmap-seeds \
    --out runs/gymfid$first --json hopper_1m_physics/gymfid-seeds$first.json --extra --fidelity gymnasium
done
# Then on a 2-core CPU, the base blocks' latest checkpoints (iteration 120) replayed 20 episodes per seed
# in Gymnasium's Hopper-v5 under its own physics and under jaxpg's fast physics (phys*.json):
python benchmarks/suite.py physics runs/base3000/hopper-npg-hopper_1m-seeds3000to3031 --episodes 20 --json hopper_1m_physics/phys3000.json
python benchmarks/suite.py physics runs/base3032/hopper-npg-hopper_1m-seeds3032to3063 --episodes 20 --json hopper_1m_physics/phys3032.json
# (phys3000/3032 came from the mode at 2e6bbb8, which stepped the 20 episodes in lockstep with one batched policy
# call; the mode now plays them through jaxpg.evaluate's own loop, one observation per call. The same block again
# with it, phys3000_evaluate_loop.json: 30 of 32 seeds >= 3000 under each physics, medians 3333 / 3362, 24 / 24
# falls of 640 episodes; single seeds differ by up to 226, since float-level action differences part trajectories.)
python benchmarks/suite.py physics runs/base3000/hopper-npg-hopper_1m-seeds3000to3031 --episodes 20 --json hopper_1m_physics/phys3000_evaluate_loop.json

# gpu_memory/: JAX's GPU memory reserved at the first buffer (its default) or taken on demand.
# prealloc.jsonl: the probe prealloc_probe.py.txt (the steps `card_command.py memory` now runs), 3 fresh processes
# each way, alternating:
for i in 1 2 3; do
  python prealloc_probe.py jaxpg/envs/assets/hopper.xml >> prealloc.jsonl
  XLA_PYTHON_CLIENT_PREALLOCATE=false python prealloc_probe.py jaxpg/envs/assets/hopper.xml >> prealloc.jsonl
done
# default*/noprealloc*: the card's warm command both ways (caches filled by card/ above), alternating.
# jaxpg now sets the variable itself (3a3fe06); to repeat the "default" runs: XLA_PYTHON_CLIENT_PREALLOCATE=true.
for s in 0 1 2; do
  python benchmarks/card_command.py card --seeds $s --modes warm --out card --json gpu_memory/default$s.json --extra --preset hopper_1m
  XLA_PYTHON_CLIENT_PREALLOCATE=false python benchmarks/card_command.py card --seeds $s --modes warm --out card \
    --json gpu_memory/noprealloc$s.json --extra --preset hopper_1m
done
# Humanoid's PPO at a large batch both ways (30 iterations; output in gpu_memory/humanoid_ppo.txt):
for v in true false; do
  XLA_PYTHON_CLIENT_PREALLOCATE=$v python -m jaxpg.cli --env humanoid --algo ppo --preset humanoid_fast --iterations 30 --run-dir h$v
done
