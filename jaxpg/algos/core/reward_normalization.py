"""Rewards divided by a running standard deviation of the discounted return.

This is the reward normalisation that PPO's usual MuJoCo settings rely on (Stable-Baselines3's
``VecNormalize(norm_reward=True)``, Gymnasium's ``NormalizeReward`` wrapper that CleanRL uses):
each env keeps the discounted sum of its episode's rewards so far, ``g_t = gamma g_{t-1} + r_t``,
reset to 0 after the step that ends the episode; the running variance of every ``g_t`` seen over
all envs is updated with each step's batch, and that step's reward is divided by its standard
deviation and clipped to ``[-clip, clip]``. The mean is not subtracted. The scale adapts as the
policy improves, where a fixed ``reward_scaling`` has to be chosen per task.

The state (``RewardNormalizer``) lives in ``TrainState.reward_normalizer`` and carries over
iterations, so that episodes continue across samples in continuing sampling.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from jaxpg.algos.core.state import RunningStats
from jaxpg.rollout import Trajectory

REWARD_CLIP = 10.0
"""Normalised rewards are clipped to ``[-REWARD_CLIP, REWARD_CLIP]`` (SB3's and Gymnasium's default)."""


@struct.dataclass
class RewardNormalizer:
    """What reward normalisation carries from one step to the next.

    Attributes:
      returns: ``[num_envs]`` discounted return of each env's current episode, ``g_t``.
      stats: ``[1]`` running mean and variance of every ``g_t`` so far (only the variance is used).
    """

    returns: jax.Array
    stats: RunningStats

    @classmethod
    def create(cls, num_envs: int) -> RewardNormalizer:
        """Zero returns and empty statistics for ``num_envs`` envs."""
        return cls(returns=jnp.zeros(num_envs), stats=RunningStats.create(1))


def normalize_rewards(
    normalizer: RewardNormalizer,
    rewards: jax.Array,
    ended: jax.Array,
    valid: jax.Array,
    gamma: float,
    clip: float = REWARD_CLIP,
) -> tuple[jax.Array, RewardNormalizer]:
    """Rewards ``[T, B]`` divided by the running std of the discounted return, step by step.

    At each step ``t``: ``g = gamma * g + r_t`` for every env, the statistics take the ``B`` new
    ``g`` (weighted by ``valid [T, B]``), ``r_t / sqrt(var + 1e-8)`` is clipped to ``[-clip,
    clip]``, and ``g`` is reset to 0 where ``ended [T, B]`` (terminated or truncated) says the
    episode ended at that step. Returns the normalised rewards ``[T, B]`` and the normalizer after
    the last step.
    """

    def step(carry: RewardNormalizer, xs: tuple[jax.Array, jax.Array, jax.Array]) -> tuple[RewardNormalizer, jax.Array]:
        reward, end, weight = xs
        returns = gamma * carry.returns + reward
        stats = carry.stats.update(returns[:, None], weight)
        scaled = jnp.clip(reward / stats.std[0], -clip, clip)
        return RewardNormalizer(returns=jnp.where(end, 0.0, returns), stats=stats), scaled

    normalizer, scaled = jax.lax.scan(step, normalizer, (rewards, ended, valid))
    return scaled, normalizer


def normalize_trajectory_rewards(
    normalizer: RewardNormalizer, traj: Trajectory, gamma: float
) -> tuple[Trajectory, RewardNormalizer]:
    """``traj`` with its rewards normalised (``normalize_rewards``; an episode ends where the
    trajectory says ``terminated`` or ``truncated``), and the normalizer after it."""
    ended = jnp.logical_or(traj.terminated, traj.truncated)
    rewards, normalizer = normalize_rewards(normalizer, traj.rewards, ended, traj.valid, gamma)
    return traj.replace(rewards=rewards), normalizer
