"""Pong from pixels (MinPy's experiment): A2C and Karpathy's REINFORCE on jaxpg's pure-JAX Pong.

The task is ``pong`` (``jaxpg.envs.pong.DifferencePong``): a Pong written for jaxpg in pure JAX
(not the Atari ROM) against a scripted opponent, seen through ``FrameDifference``: the
observation is the current 80x80 frame minus the previous one, flattened to 6400. The network is
the seed's: 6400 -> 200 (ReLU) -> action probabilities over {up, down}.

* ``--algo a2c`` (default): synchronous advantage actor-critic, MinPy's second experiment
  (``a2c.PRESETS["pong"]``): ``--num-envs`` games in lock-step, an update every 8 steps (t_max),
  GAE(0.99, 0.95) bootstrapped through the value of the last frame, a value network like the
  policy's, Adam 1e-3, entropy bonus 0.01.
* ``--algo reinforce_points``: Karpathy's policy gradient, MinPy's first experiment
  (``jaxpg.algos.reinforce_points``): every game runs on, and every 256 steps the policy takes
  one Adam step on the log-probabilities weighted by the discounted return *of the point* each
  step belongs to, normalised over the batch.

The run directory is the command line's (``config.json``, ``metrics.jsonl``, Orbax checkpoints,
``curves.png``): ``return`` in the log is the final score (points won minus lost, -21 to 21) of
the games that ended in an iteration, so ``curves.png`` shows the agent catching up with the
opponent. ``--minutes M`` stops after M minutes of training (compilation excluded) with a
checkpoint, and ``--resume RUN`` continues a run exactly. ``--video-every N`` writes videos of
the difference frames the policy sees. ``--size`` changes the frames' resolution (40 for quick
runs on a CPU), not the game. MinPy's comparison of env counts against wall clock is
``benchmarks/pong.py --compare-envs``. Every flag: ``python experiments/pong.py --help``.
"""

from __future__ import annotations

from jaxpg.algos import a2c
from jaxpg.cli import Experiment, exit_process, main

EXPERIMENT = Experiment(
    task="pong",
    tasks=("pong",),
    algo="a2c",
    iterations=20_000,
    log_every=100,
    checkpoint_every=1000,
    config={"a2c": dict(**a2c.PRESETS["pong"], num_envs=16)},  # reinforce_points: its Config's defaults
    env_flags={
        "size": (int, "frames are SIZE x SIZE pixels, >= 8 (default: 80); the game does not change"),
        "stay_action": (bool, "actions {stay, up, down} instead of {up, down} (default: no)"),
    },
    prog="python experiments/pong.py",
    description=__doc__.split("\n\n")[0],
    epilog="""\
examples:
  python experiments/pong.py --num-envs 16 --minutes 10 --run-dir runs/pong-a2c        # a CPU
  python experiments/pong.py --num-envs 1024 --lr 2e-3 --minutes 3 --run-dir runs/pong-a2c   # one GPU
  python experiments/pong.py --algo reinforce_points --minutes 30 --run-dir runs/pong-reinforce
  python experiments/pong.py --resume runs/pong-a2c --minutes 5
  python -m jaxpg.evaluate runs/pong-a2c --episodes 10 --video pong.mp4
  python -m jaxpg.evaluate runs/pong-a2c --ale --episodes 10      # the policy in Atari Pong (80x80 runs)

MinPy's comparison (running reward against wall clock for 1 to 256 envs, into pong_envs.png):
  python benchmarks/pong.py --compare-envs 1 2 4 16 64 256 --seconds 300 --run-dir runs/pong-envs
""",
)

if __name__ == "__main__":
    exit_process(main(experiment=EXPERIMENT, owns_process=True))
