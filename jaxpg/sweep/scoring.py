"""Scores of a sweep's runs: each run's final mean policy played in Gymnasium's own env of the task
(``jaxpg.run.evaluation.replay.evaluate_gymnasium``, as ``python -m jaxpg.evaluate RUN --gymnasium`` plays it),
by a pool of CPU worker processes, while the devices train the next chunk.

A task without a Gymnasium counterpart is scored in jaxpg's env instead
(``jaxpg.run.evaluation.policy_episodes.play_episodes``), in the same workers. A run's score is the mean
return of ``episodes`` episodes from the seeds ``seed, seed + 1, ...``, acting as the config's
``eval_action`` says (the mode, or the clipped mean).
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
from typing import Any

import numpy as np


@dataclasses.dataclass(frozen=True)
class ScoreJob:
    """One run to score: its task, algorithm, config fields, the final policy's parameter and
    observation-statistics leaves (``[...]`` NumPy, the order ``jax.tree.leaves`` gives), how many
    episodes from which seed."""

    run: int
    task: str
    algo: str
    env_kwargs: dict[str, Any]
    config: dict[str, Any]
    params: list[np.ndarray]
    obs_stats: list[np.ndarray]
    episodes: int
    seed: int


def _cpu_only() -> None:
    """Worker initialiser: JAX on the CPU only (the devices belong to the training process)."""
    os.environ["JAX_PLATFORMS"] = "cpu"
    import jax

    jax.config.update("jax_platforms", "cpu")


def score_job(job: ScoreJob) -> tuple[int, float]:
    """``(run, mean return)`` of ``job``'s policy (module docstring)."""
    import jax

    from jaxpg import envs
    from jaxpg.algos import core
    from jaxpg.run.checkpoints import policy_io
    from jaxpg.run.evaluation import policy_episodes, replay
    from jaxpg.run.rundir import config_io

    env = envs.make_shared(job.task, **job.env_kwargs)
    run = config_io.RunConfig(
        task=job.task, algo=job.algo, config=job.config, seeds=[job.seed], iterations=1, env_kwargs=job.env_kwargs
    )
    config = run.algo_config()
    policy, _ = core.make_networks(env, config)
    template = policy.init(jax.random.PRNGKey(0), env.observation_size)
    params = jax.tree.unflatten(jax.tree.structure(template), job.params)
    obs_stats = jax.tree.unflatten(jax.tree.structure(core.RunningStats.create(env.observation_size)), job.obs_stats)
    clipped_mean = config.eval_action == "clipped_mean" and not env.discrete
    if replay.gymnasium_counterpart(job.task) is not None and replay.gymnasium_installed():
        loaded = policy_io.LoadedPolicy(run, policy, params, obs_stats, 0, job.seed, env, clipped_mean=clipped_mean)
        returns, _, _ = replay.evaluate_gymnasium(loaded, job.task, job.env_kwargs, job.episodes, job.seed)
    else:
        episodes = policy_episodes.play_episodes(
            env, policy, params, obs_stats, job.seed, job.episodes, deterministic=True, clipped_mean=clipped_mean
        )
        returns = episodes.returns
    return job.run, float(np.mean(returns))


class Scorer:
    """A pool of ``workers`` CPU processes that score jobs in the background (``submit``), or the
    calling process itself when ``workers`` is 0."""

    def __init__(self, workers: int):
        self.workers = workers
        self._pool = None
        if workers > 0:
            self._pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_cpu_only)
        self._pending: list[tuple[Any, Any]] = []

    def submit(self, jobs: list[ScoreJob], done: Any) -> None:
        """Score ``jobs``; ``done({run: score})`` is called (in this process, by ``wait``) once all are."""
        if self._pool is None:
            done(dict(score_job(job) for job in jobs))
            return
        self._pending.append((self._pool.map_async(score_job, jobs), done))

    def wait(self) -> None:
        """Finish every submitted batch, calling each one's ``done``."""
        for result, done in self._pending:
            done(dict(result.get()))
        self._pending = []

    def close(self) -> None:
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None
