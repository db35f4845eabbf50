"""Trained policies out of a run directory, for callers who know nothing about JAX.

policy = jaxpg.load_policy("runs/hopper-npg")      # latest checkpoint, first seed
action = policy(obs)                                 # NumPy [obs_dim] -> NumPy [act_dim]
actions = policy(obs_batch)                          # [B, obs_dim] -> [B, act_dim]
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import train
from jaxpg.algos import core
from jaxpg.envs import wrappers
from jaxpg.run.checkpoints import checkpoint_format, checkpointer
from jaxpg.run.rundir import config_io, layout


def abstract_train_state(run: config_io.RunConfig, env: Any = None) -> Any:
    """The ``jax.eval_shape`` of the run's initial ``TrainState`` (seed-stacked for several
    seeds): the restore target, built by the algorithm's ``init`` with the saved config."""
    module = run.algo_module()
    config = run.algo_config()
    env = run.make_env() if env is None else env
    if run.vmap_seeds:
        return jax.eval_shape(lambda: train.init_seeds(module.init, run.seeds, env, config))
    return jax.eval_shape(lambda: module.init(jax.random.PRNGKey(run.seeds[0]), env, config))


def checkpoint_expectations(run: config_io.RunConfig) -> dict[str, Any]:
    """The ``meta`` values a checkpoint of ``run`` must have."""
    return {"task": run.task, "algo": run.algo}


def load_run_config(run_dir: str | os.PathLike) -> config_io.RunConfig:
    """The ``RunConfig`` of ``run_dir``; ``RunDirError`` (one line) for a path that is a file,
    missing, too long to exist or not a run directory, or a ``config.json`` with a value of the
    wrong type."""
    layout.check_path(run_dir, "run directory")
    path = Path(run_dir)
    if path.exists() and not path.is_dir():
        raise layout.RunDirError(f"{str(run_dir)!r} is a file, not a run directory (give the directory a run wrote)")
    return config_io.RunConfig.load(run_dir)


def restore_train_state(run_dir: str | os.PathLike, step: int | str | None = None) -> tuple[Any, int]:
    """The whole ``TrainState`` of a run's checkpoint and its step (``CheckpointError`` /
    ``RunDirError``, one line, when it cannot be had). ``"latest"``/``"best"`` skip damaged
    checkpoints with a warning line."""
    run = load_run_config(run_dir)
    target = abstract_train_state(run)
    checkpoints = checkpointer.Checkpointer(Path(run_dir) / layout.CHECKPOINT_DIR, keep=None)
    step = checkpoints.resolve_step(step)
    return checkpoints.restore(target, step, expect=checkpoint_expectations(run)), step


def check_finite(obs: np.ndarray) -> None:
    """``ValueError`` (one line, naming the first bad entry) unless every entry of ``obs`` is finite."""
    bad = ~np.isfinite(obs)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        where = f"[{', '.join(map(str, index))}]"
        raise ValueError(
            f"observation contains NaN or inf (obs{where} = {obs[index]}); "
            "the policy needs finite observations (check the env or the simulator state)"
        )


class LoadedPolicy:
    """A trained policy as a NumPy function: ``policy(obs) -> action``.

    ``obs``: ``[obs_dim]`` or ``[B, obs_dim]``; the action is ``[act_dim]`` / ``[B, act_dim]``
    float32 (continuous, clipped to the env's action bounds when ``clip``) or int (discrete), in
    the task's own units: a run that trained with ``action_scaling`` acts in ``[-1, 1]``, mapped
    here onto the task's range, so that the action goes to the task (or Gymnasium's env) as it is.
    Observation normalisation of the run is applied. ``deterministic`` (default) takes the mode
    of the policy, or with ``clipped_mean`` the mean of the clipped actions,
    ``E[clip(a, low, high)]`` (``distributions.gaussian_clipped_mean``), which differs from
    ``clip(mean)`` for a wide Gaussian; otherwise actions are sampled with an internal key (``seed``).

    Attributes: ``run`` (the ``RunConfig``), ``step`` (the checkpoint), ``seed`` (which of the
    run's training seeds), ``observation_size``, ``action_size``, ``discrete``,
    ``action_low``/``action_high`` (the task's bounds, which the actions lie in).
    """

    def __init__(
        self,
        run: config_io.RunConfig,
        policy: Any,
        params: Any,
        obs_stats: Any,
        step: int,
        seed: int,
        env: Any,
        deterministic: bool = True,
        clip: bool = True,
        sample_seed: int = 0,
        clipped_mean: bool = False,
    ):
        if clipped_mean and (env.discrete or not deterministic or not clip):
            raise ValueError(
                "the clipped mean is a deterministic action of a Gaussian policy on a clipped continuous task"
            )
        self.run, self.policy, self.params, self.obs_stats = run, policy, params, obs_stats
        self.step, self.seed = step, seed
        self.observation_size = env.observation_size
        self.action_size = env.action_size
        self.discrete = bool(env.discrete)
        # The policy's own bounds (the run's env: [-1, 1] when it rescaled actions), then the task's.
        self._policy_low, self._policy_high = float(env.action_low), float(env.action_high)
        task = env.unwrapped
        self.action_low, self.action_high = float(task.action_low), float(task.action_high)
        self.deterministic, self.clip, self.clipped_mean = deterministic, clip, clipped_mean
        self._key = jax.random.PRNGKey(sample_seed)
        self._act = jax.jit(self._act_impl, static_argnames="deterministic")

    def _act_impl(self, params: Any, obs_stats: Any, obs: jax.Array, key: jax.Array, deterministic: bool) -> jax.Array:
        low, high = self._policy_low, self._policy_high
        bounds = (low, high) if self.clipped_mean else None
        action, _ = core.make_act(self.policy, obs_stats, deterministic, clipped_mean_bounds=bounds)(params, obs, key)
        if self.discrete:
            return action
        if self.clip:
            action = jnp.clip(action, low, high)
        if (low, high) != (self.action_low, self.action_high):  # the run's RescaleAction: [-1, 1] onto the task's
            action = wrappers.unit_to_range(action, self.action_low, self.action_high)
        return action

    def __call__(self, obs: Any) -> np.ndarray:
        """The action(s) for ``obs``; ``ValueError`` for a wrong shape or a NaN/inf entry."""
        obs = np.asarray(obs, np.float32)
        if obs.shape[-1:] != (self.observation_size,) or obs.ndim not in (1, 2):
            raise ValueError(
                f"expected an observation [{self.observation_size}] or a batch [B, {self.observation_size}], "
                f"got shape {obs.shape}"
            )
        check_finite(obs)
        key = self._key
        if not self.deterministic:
            self._key, key = jax.random.split(self._key)
        return np.asarray(self._act(self.params, self.obs_stats, obs, key, deterministic=self.deterministic))

    def __repr__(self) -> str:
        mode = ("clipped mean" if self.clipped_mean else "deterministic") if self.deterministic else "stochastic"
        return (
            f"LoadedPolicy({self.run.algo} on {self.run.task}, step {self.step}, seed {self.seed}, {mode}, "
            f"obs {self.observation_size} -> act {self.action_size}{' (discrete)' if self.discrete else ''})"
        )


def load_policy(
    run_dir: str | os.PathLike,
    step: int | str | None = None,
    *,
    seed: int | None = None,
    deterministic: bool = True,
    clip: bool = True,
    sample_seed: int = 0,
    clipped_mean: bool | None = None,
) -> LoadedPolicy:
    """The policy of a training run as a NumPy callable ``obs -> action``.

    Args:
      run_dir: a run directory written by ``jaxpg.cli`` (``experiments/*.py``).
      step: checkpoint step; ``None``/``"latest"`` (default) or ``"best"`` (highest score: the
        mean-policy return of the checkpoint's iteration, or the stochastic return in a run without
        evaluations, ``metrics_log.checkpoint_score``) or an iteration number.
      seed: which of the run's training seeds (default: the first).
      deterministic: act with the mode of the policy (the "mean policy"); ``False`` samples.
      clip: clip continuous actions to the env's bounds, as the training env does.
      sample_seed: PRNG seed of the sampled actions when not deterministic.
      clipped_mean: act with ``E[clip(a)]`` under the Gaussian policy, the mean of the actions the
        clipped task executes, in place of ``clip(mean)`` (deterministic, continuous tasks);
        ``None`` (default): as the run's evaluations did (its ``eval_action``) when deterministic
        and clipped.
    Returns a ``LoadedPolicy`` (its ``step`` says which checkpoint). ``"latest"`` and ``"best"`` take
    the newest (best) checkpoint that reads back completely and matches its checksums; a damaged one
    is skipped with one ``warning:`` line on stderr.
    Raises ``ValueError`` (``RunDirError``/``CheckpointError``) with one line when the run or
    checkpoint is missing, foreign, damaged or does not fit, or ``run_dir`` is a file.
    """
    run = load_run_config(run_dir)
    env = run.make_env()
    config = run.algo_config()
    policy, _ = core.make_networks(env, config)
    if clipped_mean is None:
        clipped_mean = deterministic and clip and config.eval_action == "clipped_mean"
    if seed is None:
        seed = run.seeds[0]
    if seed not in run.seeds:
        raise ValueError(f"seed {seed} is not one of the run's seeds {run.seeds}")
    seed_index = run.seeds.index(seed)
    target = checkpoint_format.policy_part(abstract_train_state(run, env))
    checkpoints = checkpointer.Checkpointer(Path(run_dir) / layout.CHECKPOINT_DIR, keep=None)
    step = checkpoints.resolve_step(step)
    part = checkpoints.restore_policy(target, step, expect=checkpoint_expectations(run))
    if run.vmap_seeds:
        part = jax.tree.map(lambda x: x[seed_index], part)
    return LoadedPolicy(
        run,
        policy,
        part["params"],
        part["obs_stats"],
        step,
        seed,
        env,
        deterministic=deterministic,
        clip=clip,
        sample_seed=sample_seed,
        clipped_mean=clipped_mean,
    )
