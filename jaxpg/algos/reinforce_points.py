"""REINFORCE with returns that restart at every point: Karpathy's "Pong from pixels", MinPy's first
Pong experiment.

``jaxpg.algos.reinforce`` with one change, the returns: in Pong a nonzero reward ends a point, and
the actions of one point do not earn the next point's reward, so ``G_t = sum_k gamma^k r_{t+k}``
runs only up to the end of ``t``'s point (Karpathy's ``discount_rewards`` with its reset at
``r != 0``; ``point_returns``). One iteration:
  1. continue every env for ``horizon`` steps (continuing sampling, automatic resets);
  2. per-point discounted returns, normalised over the batch (``returns.normalize``); the steps
     after the last finished point of each env column have no known return yet and are left out;
  3. one Adam (or AdamW) step on ``-E[G^_t log pi(a_t|s_t)] - entropy_coef * E[H]`` over the
     steps with a known return (``reinforce.policy_step``);
  4. reject non-finite updates, update observation statistics (``core.finish_iteration``).

The state and optimizer are REINFORCE's (``init`` is ``reinforce.init``); ``Config`` is
``reinforce.Config`` with the defaults of ``experiments/pong.py``'s REINFORCE (6400 -> 200 ReLU
network, 256 steps per env per update, Adam 1e-3, gamma 0.99, no evaluation).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import jax
import jax.numpy as jnp

from jaxpg import returns
from jaxpg.algos import core, presets, reinforce
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env

init = reinforce.init


@dataclasses.dataclass(frozen=True)
class Config(reinforce.Config):
    """``reinforce.Config`` with Pong's defaults; returns are always normalised over the batch."""

    num_envs: int = 16
    horizon: int = 256
    sampling: str = "continuing"
    policy_hidden: tuple[int, ...] = (200,)
    policy_activation: str = "relu"
    lr: float = 1e-3
    eval_envs: int = 0

    UNUSED_FIELDS: ClassVar[tuple[str, ...]] = (*reinforce.Config.UNUSED_FIELDS, "return_normalization")

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.sampling != "continuing":
            raise ValueError(f"reinforce_points samples continuing (returns span iterations), got {self.sampling!r}")


# Named Config overrides: a read-only view of this algorithm's rows of ``presets.TABLE``.
PRESETS = presets.by_algorithm("reinforce_points")


def point_returns(
    rewards: jax.Array, terminated: jax.Array, truncated: jax.Array, gamma: float
) -> tuple[jax.Array, jax.Array]:
    """Discounted returns within each point, and where they are known: ``([T, B], [T, B] bool)``.

    A step with a nonzero reward ends a point (as well as the game's end), so
    ``G_t = sum_k gamma^k r_{t+k}`` runs only up to the end of ``t``'s point (Karpathy's
    ``discount_rewards`` with its reset at ``r != 0``). ``complete`` is true where that point
    ended inside the batch with a point scored; steps of a point still running at the end of the
    batch, or cut by the time limit, have an unknown return and come out false.
    """
    point_end = rewards != 0
    ends = point_end | terminated
    g = returns.discounted_returns(rewards, ends, truncated, gamma)
    # The same recursion with gamma 1 on the indicator of a scored point: 1 where the segment
    # ends with a point, 0 where it ends by truncation or runs past the batch.
    scored = returns.discounted_returns(point_end.astype(rewards.dtype), ends, truncated, 1.0)
    return g, scored > 0


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One REINFORCE iteration with per-point returns normalised over the batch (module
    docstring); ``jaxpg.algos.reinforce``'s pieces with ``point_returns`` for its returns."""
    old = ts
    ts, traj, _ = core.phase_sample(ts)
    g, complete = point_returns(traj.rewards, traj.terminated, traj.truncated, core.run_config(ts).gamma)
    weights = traj.valid * complete
    advantages = returns.normalize(g, mask=weights)
    batch = core.flatten_batch(
        core.Batch(
            obs=ts.obs_stats.normalize(traj.obs),
            actions=traj.actions,
            log_probs=traj.log_probs,
            advantages=advantages,
            value_targets=advantages,
            weights=weights,
        )
    )
    ts, diagnostics = reinforce.policy_step(ts, batch)
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    metrics = {**diagnostics, "complete_fraction": jnp.mean(weights)}
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"], kl=kl, metrics=metrics)
