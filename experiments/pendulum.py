"""Inverted pendulum (``--task inverted_double_pendulum`` for the double one) with any jaxpg algorithm.

The defaults (NPG, 64 envs x 128 steps per iteration, 40 iterations) balance the pendulum for the
full 1000 steps in about a minute on a laptop CPU. The reference systems on this task:

    python experiments/pendulum.py --algo vpg --preset lightning --iterations 100          # Lightning VPG
    python experiments/pendulum.py --algo reinforce --preset gymnasium_tutorial --seeds 1 2 3 5 8

Every flag: ``python experiments/pendulum.py --help`` (``--algo ppo --help`` for PPO's).
"""

from __future__ import annotations

from jaxpg.cli import Experiment, exit_process, main

EXPERIMENT = Experiment(
    task="inverted_pendulum",
    tasks=("inverted_pendulum", "inverted_double_pendulum"),
    algo="npg",
    iterations=40,
    log_every=5,
    checkpoint_every=20,
    prog="python experiments/pendulum.py",
    description=__doc__.split("\n\n")[0],
    epilog="""\
examples:
  python experiments/pendulum.py                                    # NPG, ~1 min on a laptop CPU
  python experiments/pendulum.py --seeds 1 2 3 5 8 --video-every 20 # five seeds in one program
  python experiments/pendulum.py --task inverted_double_pendulum --iterations 150
  python experiments/pendulum.py --algo vpg --preset lightning --iterations 100
  python experiments/pendulum.py --algo reinforce --preset gymnasium_tutorial --seeds 1 2 3 5 8

on a GPU (headline: both pendulums solved by 5 seeds at once, in seconds after compilation):
  python experiments/pendulum.py --num-envs 1024 --seeds 1 2 3 5 8 --iterations 40
  python experiments/pendulum.py --task inverted_double_pendulum --num-envs 2048 --seeds 1 2 3 5 8 --iterations 200

then: python -m jaxpg.evaluate RUN_DIR --episodes 20 --gymnasium --video pendulum.mp4
""",
)

if __name__ == "__main__":
    exit_process(main(experiment=EXPERIMENT, owns_process=True))
