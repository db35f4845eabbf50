"""CartPole (Gymnasium ``CartPole-v1`` semantics, pure JAX: no MuJoCo) with any jaxpg algorithm.

Discrete actions: the policy is categorical. The defaults (NPG, 64 envs x 128 steps, 30
iterations) reach the 500-step limit in about a minute on a laptop CPU. Kokoyi's policy gradient
(categorical MLP, normalised returns) is ``--algo reinforce --preset kokoyi``; MinPy's A2C is
``--algo a2c --preset minpy`` (``--preset cartpole`` for settings tuned to this task).

Every flag: ``python experiments/cartpole.py --help``.
"""

from __future__ import annotations

from jaxpg.cli import Experiment, exit_process, main

EXPERIMENT = Experiment(
    task="cartpole",
    tasks=("cartpole",),
    algo="npg",
    iterations=30,
    log_every=5,
    checkpoint_every=10,
    prog="python experiments/cartpole.py",
    description=__doc__.split("\n\n")[0],
    epilog="""\
examples:
  python experiments/cartpole.py                                     # NPG, ~1 min on a laptop CPU
  python experiments/cartpole.py --algo a2c --preset cartpole --iterations 300
  python experiments/cartpole.py --algo reinforce --preset kokoyi --iterations 500 --seeds 1 2 3 5 8

on a GPU (headline: MinPy's comparison, A2C with more envs learns faster in wall-clock time):
  for n in 1 2 4 16 256; do python experiments/cartpole.py --algo a2c --preset minpy --num-envs $n \\
      --iterations 2000 --seeds 1 2 3 5 8 --run-dir runs/cartpole-a2c-$n; done
  python -m jaxpg.run.outputs.plotting runs/cartpole-a2c-* --out cartpole-a2c.png

videos: CartPole is drawn with NumPy (--video-every N, or python -m jaxpg.evaluate RUN --video out.mp4)
""",
)

if __name__ == "__main__":
    exit_process(main(experiment=EXPERIMENT, owns_process=True))
