"""The command jaxpg is known by, ``python experiments/hopper.py --num-envs 256``, run as a user
runs it: each run a fresh process, timed as a whole.

Seven modes (``python benchmarks/card_command.py MODE --help`` for each):

  card         time the command per seed with empty caches (cold) and with caches a first run
               filled (warm), then score each run's policy in Gymnasium's CPU Hopper-v5;
  determinism  run the same seed several times per setting (MuJoCo Warp, XLA's deterministic
               ops, MJX's JAX implementation) and find where two runs' metrics first differ;
  kernels      time MuJoCo Warp's kernel build for the card's Hopper on a bare machine, serial
               at first execution against all host cores while XLA compiles;
  capture      step MuJoCo Warp's physics with and without an XLA compilation on another
               thread: does Warp's CUDA-graph capture survive it?
  startup      in fresh processes, JAX's backend start and `import mujoco.mjx` one after the
               other, and the import on a thread while the backend starts: does overlapping help?
               With --sample: the card's command itself, its main thread's stack sampled every
               50 ms up to the `training:` line, summed by what jaxpg was doing.
  memory       in fresh processes, JAX's GPU backend start and its first buffers, with JAX's
               default (75 % of the GPU's memory reserved at the first buffer) and with memory
               taken on demand (XLA_PYTHON_CLIENT_PREALLOCATE=false, what jaxpg's commands set).
  parts        the card's command inside this process, with JAX's tracing, lowering and compilation
               (or cache load) of each program, and the Python time of MuJoCo Warp's FFI callbacks.

This script only dispatches: each mode lives in ``benchmarks/card_modes/``.

    python benchmarks/card_command.py card --seeds 0 1 2 --modes cold warm --json card.json
    python benchmarks/card_command.py determinism --settings default deterministic jax --runs 3
    python benchmarks/card_command.py kernels --builds serial parallel
    python benchmarks/card_command.py capture --seconds 60
    python benchmarks/card_command.py startup --repeats 3
    python benchmarks/card_command.py startup --sample 2 --extra --preset hopper_1m
    python benchmarks/card_command.py memory --repeats 3
    python benchmarks/card_command.py parts --json parts.json
"""

from __future__ import annotations

import harness
from card_modes import capture, card, determinism, kernels, memory, parts, startup

MODES = {
    "card": card.card_main,
    "determinism": determinism.determinism_main,
    "kernels": kernels.kernels_main,
    "capture": capture.capture_main,
    "startup": startup.startup_main,
    "memory": memory.memory_main,
    "parts": parts.parts_main,
}


if __name__ == "__main__":
    harness.run_modes(__file__, MODES, __doc__)
