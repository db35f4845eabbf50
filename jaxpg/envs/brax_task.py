"""Brax's and MuJoCo Playground's environments as jaxpg tasks, for every jaxpg algorithm.

    env = jaxpg.envs.make("brax:ant")                 # Brax's own Ant (backend "mjx")
    env = jaxpg.envs.make("playground:CheetahRun")    # a MuJoCo Playground JAX env
    env = jaxpg.envs.make("my_package.my_envs:MyEnv") # any class with Brax's functional API
    task = BraxTask(brax_env, name="my_env")          # an env object you already made

Names with a colon are resolved here (``task_class``), so the command line takes them as it takes
``hopper`` (``python -m jaxpg.cli --env brax:ant``). ``brax:NAME`` needs Brax
(``pip install 'jaxpg[brax]'``), ``playground:NAME`` MuJoCo Playground (``pip install playground``).
An import path ``module:Class`` names a class built with no arguments: a jaxpg ``Env`` subclass is
used as it is, anything else is wrapped in ``BraxTask``.

Brax's and Playground's envs report one ``done`` and leave the time limit to a wrapper; here ``done``
is jaxpg's ``terminated`` and the time limit is the task's ``max_episode_steps`` (1000 by default,
Brax's ``episode_length``), which sets ``truncated``: jaxpg's algorithms then bootstrap a cut
episode from its final observation. Their actions are in ``[-1, 1]``. Resets draw fresh noise each
time (jaxpg's ``AutoReset``); nothing of Brax's wrappers is used. This module imports neither Brax
nor Playground until a name asks for one.
"""

from __future__ import annotations

import functools
import importlib
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from jaxpg.envs.base import Env, State

PREFIXES = ("brax", "playground")


@struct.dataclass
class BraxTaskData:
    """The foreign env's whole state (``state``: a Brax or Playground ``State``) and the return of
    the episode so far (``episode_return []``: jaxpg's ``task_score`` for these tasks)."""

    state: Any
    episode_return: jax.Array


class BraxTask(Env):
    """A Brax-style env (``reset(rng) -> State``, ``step(state, action) -> State``, ``State`` with
    ``obs [observation_size]``, ``reward []``, ``done []``, ``metrics``) as a jaxpg task.

    Args:
      env: the env, one environment (no Brax training wrappers: they batch and reset it).
      name: the task's name in messages and run directories.
      max_episode_steps: the time limit (Brax's ``episode_length``).

    ``metrics`` are the env's own (floats, the same keys at every step) and ``task_score``: the
    episode's return so far. Observations must be one flat array: a dict of observations (some
    Playground envs) raises ``ValueError``.
    """

    task_score_name = "return"

    def __init__(self, env: Any, name: str = "brax_env", max_episode_steps: int = 1000):
        if max_episode_steps < 1:
            raise ValueError(f"max_episode_steps must be >= 1, got {max_episode_steps}")
        self.env = env
        self._name = name
        self.max_episode_steps = int(max_episode_steps)
        # Traced, not run: Brax's own ``observation_size`` runs a reset op by op (seconds on MJX).
        obs = jax.eval_shape(env.reset, jax.random.PRNGKey(0)).obs
        if not isinstance(obs, jax.ShapeDtypeStruct) or len(obs.shape) != 1:
            raise ValueError(f"{name}: observations must be one flat array; this env gives {obs!r}")
        self.observation_size = int(obs.shape[0])
        self.action_size = int(env.action_size)
        self.dt = float(env.dt() if callable(env.dt) else env.dt)

    @property
    def name(self) -> str:
        return self._name

    @property
    def backend(self) -> str:
        """The foreign env's physics backend (Brax's ``backend``; ``"mjx"`` for Playground)."""
        return str(getattr(self.env, "backend", "mjx"))

    def _reset(self, key: jax.Array) -> tuple[BraxTaskData, jax.Array, dict[str, jax.Array]]:
        state = self.env.reset(key)
        zero = jnp.zeros((), jnp.float32)
        data = BraxTaskData(state=state, episode_return=zero)
        return data, state.obs, {**_float_metrics(state.metrics), "task_score": zero}

    def _step(
        self, state: State, action: jax.Array
    ) -> tuple[BraxTaskData, jax.Array, jax.Array, jax.Array, dict[str, jax.Array]]:
        foreign = self.env.step(state.data.state, action)
        reward = jnp.asarray(foreign.reward, jnp.float32)
        episode_return = state.data.episode_return + reward
        data = BraxTaskData(state=foreign, episode_return=episode_return)
        metrics = {**_float_metrics(foreign.metrics), "task_score": episode_return}
        return data, foreign.obs, reward, foreign.done > 0.5, metrics

    def _physics_finite(self, data: BraxTaskData) -> jax.Array:
        """``[]`` bool: the positions and velocities hold no NaN or inf (Brax's ``pipeline_state.q``,
        ``qd``; Playground's ``data.qpos``, ``qvel``), else every float leaf of the state."""
        physics = getattr(data.state, "pipeline_state", None) or getattr(data.state, "data", None)
        named = [getattr(physics, n) for n in ("q", "qd", "qpos", "qvel") if hasattr(physics, n)]
        leaves = [jnp.asarray(x) for x in (named or jax.tree.leaves(data.state))]
        finite = [jnp.all(jnp.isfinite(x)) for x in leaves if jnp.issubdtype(x.dtype, jnp.floating)]
        return jnp.all(jnp.stack(finite)) if finite else jnp.array(True)

    def __repr__(self) -> str:
        return f"BraxTask({self._name!r}, obs={self.observation_size}, act={self.action_size}, dt={self.dt})"


def _float_metrics(metrics: dict[str, Any]) -> dict[str, jax.Array]:
    return {name: jnp.asarray(value, jnp.float32) for name, value in metrics.items()}


def is_external(name: str) -> bool:
    """Whether ``name`` is resolved here: ``brax:NAME``, ``playground:NAME`` or ``module:Class``."""
    return ":" in name


@functools.cache
def task_class(name: str) -> type:
    """The class that ``jaxpg.envs.make_task(name, **options)`` builds for an external ``name``.

    ``brax:NAME`` -> a ``BraxTask`` of ``brax.envs.get_environment(NAME, backend=..., **options)``
    (options ``backend``, default ``"mjx"``, and ``max_episode_steps``; the env's own keyword
    arguments pass through); ``playground:NAME`` -> one of ``mujoco_playground.registry.load(NAME)``
    (option ``max_episode_steps``, default the env's ``episode_length``); ``module:Class`` -> the
    class itself when it subclasses ``Env``, else a ``BraxTask`` of ``Class()``. ``ValueError``
    (one line) for a name that does not resolve or a package that is not installed.
    """
    prefix, _, rest = name.partition(":")
    if not rest:
        raise ValueError(f"unknown environment {name!r}: expected brax:NAME, playground:NAME or module:Class")
    if prefix == "brax":
        return _brax_class(name, rest)
    if prefix == "playground":
        return _playground_class(name, rest)
    try:
        found = getattr(importlib.import_module(prefix), rest)
    except (ImportError, AttributeError) as e:
        raise ValueError(f"unknown environment {name!r}: cannot import {rest} from {prefix} ({e})") from None
    if isinstance(found, type) and issubclass(found, Env):
        return found

    class ImportedTask(BraxTask):
        def __init__(self, max_episode_steps: int = 1000):
            super().__init__(found(), name=name, max_episode_steps=max_episode_steps)

    return ImportedTask


def _import(module: str, extra: str) -> Any:
    try:
        return importlib.import_module(module)
    except ImportError as e:
        raise ValueError(f"{module} is not installed ({e}): pip install {extra}") from None


def _brax_class(name: str, brax_name: str) -> type:
    brax_envs = _import("brax.envs", "'jaxpg[brax]'")
    known = sorted(brax_envs._envs)  # the registry that get_environment reads
    if brax_name not in known:
        raise ValueError(f"unknown environment {name!r}; Brax's environments: {', '.join(known)}")

    class BraxRegistryTask(BraxTask):
        def __init__(self, max_episode_steps: int = 1000, backend: str = "mjx", **brax_kwargs: Any):
            env = brax_envs.get_environment(brax_name, backend=backend, **brax_kwargs)
            super().__init__(env, name=name, max_episode_steps=max_episode_steps)

    return BraxRegistryTask


def _playground_class(name: str, playground_name: str) -> type:
    registry = _import("mujoco_playground", "playground").registry
    if playground_name not in registry.ALL_ENVS:
        raise ValueError(f"unknown environment {name!r}; see mujoco_playground.registry.ALL_ENVS")

    class PlaygroundTask(BraxTask):
        def __init__(self, max_episode_steps: int | None = None, impl: str = "jax"):
            config = registry.get_default_config(playground_name)
            if "impl" in config:
                config.impl = impl
            env = registry.load(playground_name, config=config)
            limit = max_episode_steps or int(config.get("episode_length", 1000))
            super().__init__(env, name=name, max_episode_steps=limit)

    return PlaygroundTask
