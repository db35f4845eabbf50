"""``benchmarks/pong.py atari-fps``: frames per second of each way to play Atari Pong (ALE, the device)."""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

import harness
import jax
import numpy as np

from jaxpg.envs import atari

# atari-fps: the Atari ROM's paths, frames per second

ATARI_FPS_DOC = """Frames per second of each way to play Atari Pong on the host's CPU cores and the device.

Rows (``B`` games stepped together, each path timed for ``--seconds`` after a warm-up call,
compilation excluded):

* ``ALE vector env``: ALE's games with ``atari_pong``'s settings (RGB 210x160 frames, four frames
  per step), stepped from Python with random actions.
* ``atari_pong scan``: the task (``jaxpg.envs.atari``) in a jitted ``lax.scan``: ALE through the
  batched ``io_callback``, Karpathy's preprocessing and frame difference, and the 6400 -> 200 -> 2
  policy sampling each action: what the learner's sampling phase costs.
* ``a2c training``: ``experiments/atari_pong.py``'s A2C (horizon 8) end to end, learning included.

``frames/s`` counts emulator frames (four per agent step).

    python benchmarks/pong.py atari-fps                   # B = 1 4 16, about a minute on 2 cores
    python benchmarks/pong.py atari-fps --envs 16 64 256 1024 --seconds 5
"""


def ale_vector(num_envs: int, seconds: float) -> float:
    """Agent steps per second of ALE's vector env with ``atari_pong``'s settings."""
    pool = atari.AlePool(num_envs, sticky=True, frameskip=atari.FRAMESKIP, max_frames=10**7, seed=0)
    rng = np.random.default_rng(0)
    zeros = np.ones(num_envs, np.int64)

    def run() -> None:
        pool.step(rng.integers(2, 4, size=num_envs), zeros)

    elapsed, calls = harness.time_for(run, seconds)
    return calls * num_envs / elapsed


def a2c_state(num_envs: int) -> Any:
    """A fresh A2C ``TrainState`` with ``experiments/atari_pong.py``'s settings on ``atari_pong``."""
    from jaxpg.algos import a2c
    from jaxpg.envs import EpisodeStats

    env = EpisodeStats(atari.AtariPong())
    network = dict(policy_hidden=(200,), policy_activation="relu", value_hidden=(200,), value_activation="relu")
    config = a2c.Config(**network, num_envs=num_envs, horizon=8, lr=1e-3, gae_lambda=0.95, eval_envs=0)
    return jax.jit(lambda k: a2c.init(k, env, config))(jax.random.PRNGKey(0))


def atari_pong_scan(num_envs: int, seconds: float, blocks: int = 8) -> float:
    """Agent steps per second of sampling alone (the task and the policy in a jitted scan)."""
    from jaxpg.algos import core

    box = [a2c_state(num_envs)]

    @jax.jit
    def run(ts: Any) -> Any:
        def body(ts: Any, key: jax.Array) -> tuple[Any, None]:
            env_state, _ = core.sample(ts, key)
            return ts.replace(env_state=env_state), None

        return jax.lax.scan(body, ts, jax.random.split(jax.random.PRNGKey(1), blocks))[0]

    def step() -> Any:
        box[0] = run(box[0])
        return box[0].env_state.obs

    elapsed, calls = harness.time_for(step, seconds)
    return calls * blocks * box[0].config.samples_per_iteration / elapsed


def a2c_training(num_envs: int, seconds: float, iterations: int = 8) -> float:
    """Agent steps per second of A2C training (``experiments/atari_pong.py``'s settings)."""
    from jaxpg import train as train_lib
    from jaxpg.algos import a2c

    box = [a2c_state(num_envs)]
    block = train_lib.compiled_block(a2c.update, iterations, False)

    def run() -> Any:
        box[0], metrics = block(box[0])
        return metrics

    elapsed, calls = harness.time_for(run, seconds)
    return calls * iterations * box[0].config.samples_per_iteration / elapsed


def atari_fps_main(argv: Sequence[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="python benchmarks/pong.py atari-fps",
        description=ATARI_FPS_DOC,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--envs", type=int, nargs="+", default=[1, 4, 16], help="games stepped together")
    parser.add_argument("--seconds", type=float, default=3.0, help="timing of each row")
    args = parser.parse_args(argv)
    atari.require_ale()
    print(f"{harness.describe()}; frames/s = emulator frames per second")
    print(f"{'path':18s} {'B':>5s} {'agent steps/s':>14s} {'frames/s':>12s}")
    paths = (
        ("ALE vector env", ale_vector, atari.FRAMESKIP),
        ("atari_pong scan", atari_pong_scan, atari.FRAMESKIP),
        ("a2c training", a2c_training, atari.FRAMESKIP),
    )
    for name, measure, frames_per_step in paths:
        for num_envs in args.envs:
            steps = measure(num_envs, args.seconds)
            print(f"{name:18s} {num_envs:5d} {steps:14,.0f} {steps * frames_per_step:12,.0f}", flush=True)
    return 0
