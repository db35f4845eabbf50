"""Hopper (Gymnasium ``Hopper-v5`` semantics on MJX) with any jaxpg algorithm.

The headline run is LyceumAI's NPG (SEEDS.md, seed 1): ``--preset lyceum`` (policy 32x32 tanh,
value 128x128 ReLU, GAE 0.995/0.97, normalised step 0.05, 10240 samples per iteration from
episodes of up to 1000 steps), 200 iterations, here for five seeds in one vmapped program on a
GPU. The defaults (NPG, 64 envs x 128 steps, 20 iterations) only show that everything runs on a
CPU: hopping takes a GPU.

Every flag: ``python experiments/hopper.py --help`` (``--algo ppo --help`` for PPO's).
"""

from __future__ import annotations

import sys

from jaxpg.cli import Experiment, main

EXPERIMENT = Experiment(
    task="hopper",
    tasks=("hopper",),
    algo="npg",
    iterations=20,
    log_every=5,
    checkpoint_every=10,
    prog="python experiments/hopper.py",
    description=__doc__.split("\n\n")[0],
    epilog="""\
examples:
  python experiments/hopper.py                         # a short NPG run on the CPU (minutes)
  python experiments/hopper.py --preset lyceum --iterations 5 --profile   # phase timings of LyceumAI's NPG

on a GPU (headline: mean-policy return 3000 in under a minute on one H100, see BENCHMARKS.md):
  python experiments/hopper.py --algo ppo --preset hopper_gpu --iterations 150 --run-dir runs/hopper-ppo
  python experiments/hopper.py --algo npg --preset hopper_gpu --iterations 150 --run-dir runs/hopper-npg

LyceumAI's NPG on Hopper, 200 iterations, 5 seeds in one program:
  python experiments/hopper.py --preset lyceum --seeds 1 2 3 5 8 --iterations 200 \\
      --checkpoint-every 50 --video-every 100 --run-dir runs/hopper-npg-lyceum
  python experiments/hopper.py --algo trpo --preset lyceum --seeds 1 2 3 5 8 --iterations 200

then: python -m jaxpg.evaluate runs/hopper-npg-lyceum --episodes 20 --gymnasium --video hopper.mp4
""",
)

if __name__ == "__main__":
    sys.exit(main(experiment=EXPERIMENT))
