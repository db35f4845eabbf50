"""A run directory written without training, for the tests that load, evaluate or replay a policy."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jax

from jaxpg.algos import npg
from jaxpg.run.checkpoints.checkpointer import Checkpointer
from jaxpg.run.rundir import config_io, layout


def write_pendulum_run(path: Path, config: npg.Config, env_kwargs: dict[str, Any] | None = None) -> Path:
    """``path``: an inverted_pendulum NPG run directory of ``config`` (and the task's
    ``env_kwargs``) with one checkpoint of ``init``'s state, its parameters scaled by 4 so that
    some mean actions lie outside the action bounds (the first layer's bias pushes the output out)."""
    run = config_io.RunConfig(
        task="inverted_pendulum",
        algo="npg",
        config=config_io.config_to_dict(config),
        seeds=[0],
        iterations=1,
        env_kwargs=dict(env_kwargs or {}),
    )
    path.mkdir()
    run.save(path)
    row = {"iteration": 1, "seed": 0, "env_steps": 32.0, "wall_time_s": 1.0}
    (path / layout.METRICS_FILE).write_text(json.dumps(row) + "\n")
    state = npg.init(jax.random.PRNGKey(0), run.make_env(), config)
    state = state.replace(params=jax.tree.map(lambda x: x * 4.0, state.params))
    ckpt = Checkpointer(path / layout.CHECKPOINT_DIR, keep=None, create=True)
    ckpt.save(1, state, score=1.0, info={"task": run.task, "algo": run.algo, "seeds": [0]})
    ckpt.close()
    return path
