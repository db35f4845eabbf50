"""Pong from pixels on the real Atari game: PPO, A2C or REINFORCE on ALE's Pong ROM, evaluated in ALE/Pong-v5.

The task is ``atari_pong`` (``jaxpg.envs.atari``): ``--num-envs`` games of the Arcade Learning
Environment's Pong with ``ALE/Pong-v5``'s settings (four frames per step, sticky actions 0.25),
stepped by ALE's C++ thread pool on the host's CPU cores and fed to the jitted learner through a
batched ``io_callback``; observations are Karpathy's 80x80 difference frames, actions {up, down}.

* ``--algo ppo`` (default): PPO's Atari settings (``ppo.PRESETS["atari"]``: 16 games x 128
  steps, 4 epochs of 4 minibatches, Adam 2.5e-4 annealed over 2500 iterations, clip 0.1) with the
  Nature network (``--conv-torso nature``: three convolutions, then 512 ReLU units) in front of
  the policy and of the value function. On one GPU and its host's cores it wins ALE/Pong-v5
  (BENCHMARKS.md, "Atari Pong on the ROM").
* ``--algo a2c``: MinPy's setting, the seed's network (6400 -> 200 ReLU -> action
  probabilities, a value network of the same shape), GAE(0.99, 0.95), t_max 8, Adam 1e-3, entropy
  bonus 0.01 (``a2c.PRESETS["pong"]``, also used on jaxpg's own Pong). ``--preset atari`` gives the
  A2C of the Atari literature instead: the Nature network, 16 games, t_max 5, RMSprop 7e-4; on
  one GPU and its host's cores it won ALE/Pong-v5 with sticky actions (BENCHMARKS.md, "Atari Pong
  on the ROM").
* ``--algo reinforce_points``: MinPy's first experiment, Karpathy's REINFORCE: returns that
  restart at every point, normalised over the batch, one Adam step per 256 steps of every game.

The run directory is ``jaxpg.cli``'s (``config.json``, ``metrics.jsonl`` with ``env_steps`` and
``wall_time_s`` per iteration, Orbax checkpoints), so the trained policy plays the real game with

    python -m jaxpg.evaluate RUN --ale --episodes 10              # ALE/Pong-v5, sticky actions
    python -m jaxpg.evaluate RUN --ale --episodes 10 --no-sticky  # repeat_action_probability=0

``return`` in the log is the score of the games that ended (points won minus lost). The games are
not part of a checkpoint: ``--resume`` continues the networks on new games. Several seeds train
in separate processes (each batch size has one pool of host games). Needs ``pip install
'jaxpg[atari]'``. Every flag: ``python experiments/atari_pong.py --help``.
"""

from __future__ import annotations

from typing import Any

from jaxpg.algos import a2c, ppo
from jaxpg.cli import Experiment, exit_process, main

# The seed's network: one hidden layer of 200 ReLU units.
SEED_NETWORK: dict[str, Any] = dict(policy_hidden=(200,), policy_activation="relu")

EXPERIMENT = Experiment(
    task="atari_pong",
    tasks=("atari_pong",),
    algo="ppo",
    iterations=2500,  # PPO anneals its learning rate over these; MinPy's A2C wants --iterations 40000
    log_every=50,
    checkpoint_every=250,
    config={
        "a2c": dict(**a2c.PRESETS["pong"], num_envs=64),
        "ppo": ppo.PRESETS["atari"],
        "reinforce_points": dict(**SEED_NETWORK, num_envs=64, horizon=256, lr=1e-3, gamma=0.99, eval_envs=0),
        "reinforce": dict(
            **SEED_NETWORK, num_envs=64, horizon=256, sampling="continuing", return_normalization="batch", eval_envs=0
        ),
    },
    prog="python experiments/atari_pong.py",
    description=__doc__.split("\n\n")[0],
    epilog="""\
one GPU and its host's cores (PPO; BENCHMARKS.md, "Atari Pong on the ROM", has its score):
  python experiments/atari_pong.py --run-dir runs/atari-ppo
  python -m jaxpg.evaluate runs/atari-ppo --ale --episodes 10 && \\
      python -m jaxpg.evaluate runs/atari-ppo --ale --episodes 10 --no-sticky

A2C of the Atari literature (130,500 iterations, 10.4 M agent steps):
  python experiments/atari_pong.py --algo a2c --preset atari --iterations 130500 --checkpoint-every 2000 \\
      --log-every 500 --run-dir runs/atari-a2c

MinPy's settings (the 6400-200 network; slower to learn, see BENCHMARKS.md):
  python experiments/atari_pong.py --algo a2c --num-envs 64 --iterations 40000 --run-dir runs/atari-a2c-minpy
  python experiments/atari_pong.py --algo reinforce_points --num-envs 32 --conv-torso nature \\
      --policy-hidden 512 --network-init orthogonal --lr 3e-4 --iterations 2000 --run-dir runs/atari-reinforce

a CPU with a few cores (thousands of steps per second; the convolutions are slow there):
  python experiments/atari_pong.py --algo a2c --num-envs 16 --iterations 2000 --run-dir runs/atari-a2c-cpu

MinPy's comparison on the real game (running reward against wall-clock time, 1 to 64 envs):
  python benchmarks/pong.py --task atari_pong --compare-envs 1 2 4 16 64 --seconds 1200 --run-dir runs/atari-envs
""",
)

if __name__ == "__main__":
    exit_process(main(experiment=EXPERIMENT, owns_process=True))
