"""Hopper (Gymnasium ``Hopper-v5`` semantics on MJX) with any jaxpg algorithm.

The defaults (NPG's ``hopper_1m`` preset: 256 envs x 32 steps, 120 iterations = 0.98 M env steps,
normalised step 0.07, observation normalisation, the policy's noise held at log-std 1, a 128x128
value function fitted for 10 epochs per iteration to standardised targets, the mean policy
evaluated as its clipped mean) train a hopping Hopper on one GPU in well under a minute: see
BENCHMARKS.md, "The card command", for the time and what each seed reached in Gymnasium's CPU
Hopper-v5. On a CPU the same command runs to its end too, far slower. ``--preset hopper`` is the earlier
default (initial log-std 0, learned; 64 steps per env, 1.97 M env steps); ``--preset lyceum``
reproduces LyceumAI's NPG (policy 32x32, 10240 samples per iteration from episodes of up to 1000
steps).

Every flag: ``python experiments/hopper.py --help`` (``--algo ppo --help`` for PPO's).
"""

from __future__ import annotations

from jaxpg.algos import npg
from jaxpg.cli import Experiment, exit_process, main

EXPERIMENT = Experiment(
    task="hopper",
    tasks=("hopper",),
    algo="npg",
    iterations=120,
    log_every=10,
    checkpoint_every=60,
    config={"npg": npg.PRESETS["hopper"]},
    default_presets={"npg": "hopper_1m"},
    prog="python experiments/hopper.py",
    description=__doc__.split("\n\n")[0],
    epilog="""\
examples:
  python experiments/hopper.py --num-envs 256               # NPG, 0.98 M env steps (BENCHMARKS.md)
  python experiments/hopper.py --num-envs 256 --profile     # phase timings of one iteration first
  python experiments/hopper.py --preset lyceum --iterations 5 --profile   # LyceumAI's NPG

the earlier default (1.97 M env steps, the policy's noise learned from log-std 0):
  python experiments/hopper.py --num-envs 256 --preset hopper

larger batches on a GPU (more env steps, fewer seconds per env step):
  python experiments/hopper.py --algo ppo --preset hopper_gpu --iterations 150 --run-dir runs/hopper-ppo
  python experiments/hopper.py --algo npg --preset hopper_gpu --iterations 150 --run-dir runs/hopper-npg

LyceumAI's NPG on Hopper, 200 iterations, 5 seeds in one program:
  python experiments/hopper.py --preset lyceum --seeds 1 2 3 5 8 --iterations 200 \\
      --checkpoint-every 50 --video-every 100 --run-dir runs/hopper-npg-lyceum

then: python -m jaxpg.evaluate RUN_DIR --episodes 10 --gymnasium --video hopper.mp4
""",
)

if __name__ == "__main__":
    exit_process(main(experiment=EXPERIMENT, owns_process=True))
