# One H200 (16 host cores), a freshly started machine, JAX 0.11.2, MuJoCo/MJX 3.17.0, warp-lang 1.18.0,
# 2026-11-28, with jaxpg's deferred trimesh import (jaxpg/envs/mjx_import.py). In one call:
python benchmarks/card_command.py startup --repeats 5 --json startup.json > startup.log 2>&1
# seed 0 is the machine's first run: it fills the XLA, MuJoCo Warp kernel and CUDA driver caches
python benchmarks/card_command.py card --seeds 0 1 2 3 --modes warm --out card --json card.json \
  --extra --preset hopper_1m > card.log 2>&1
