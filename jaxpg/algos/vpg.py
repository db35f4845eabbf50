"""Vanilla policy gradient with a learned state-value baseline, as in the PyTorch Lightning VPG.

VPG is REINFORCE (``jaxpg.algos.reinforce``) with a baseline: it builds on REINFORCE's returns,
loss and policy step and on the core's value fit. One iteration:
  1. sample ``num_envs x horizon`` transitions (``core.phase_sample``);
  2. Monte-Carlo discounted returns, normalised (``return_normalization``, by default over the
     batch) into ``G^_t`` (``reinforce.normalized_returns``);
  3. advantages ``A_t = G^_t - b(s_t)``: the normalised return minus the baseline's prediction
     of it (the baseline learns normalised returns, step 5);
  4. one optimizer step on ``-E[A log pi(a|s)] - entropy_coef * E[H]`` (``reinforce.policy_step``);
  5. fit the baseline to the normalised returns ``G^_t`` by ``value_epochs`` passes of minibatch
     Adam on the mean squared error (``core.phase_value_fit``; by default one full-batch step,
     our reading of the seed's one Lightning step per epoch on the whole data set);
  6. reject non-finite updates, update observation statistics (``core.finish_iteration``).

Fitting the baseline to *normalised* returns keeps its targets on one scale while the policy
improves and the raw returns grow by orders of magnitude (1 to 1000 on the inverted pendulum), so
that one fixed learning rate suits it throughout; with ``return_normalization="none"`` it is the
textbook baseline on raw returns.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import jax

from jaxpg.algos import core, presets, reinforce
from jaxpg.algos.core import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(reinforce.Config, core.ValueFitConfig):
    """VPG hyperparameters: those of ``reinforce.Config`` plus the baseline's fit
    (``core.ValueFitConfig``).

    The baseline takes ``value_epochs`` passes of minibatches of ``value_batch_size`` samples (0:
    the whole batch) with Adam at ``value_lr`` (0: the policy's ``lr``). Defaults: a quick
    continuing-sampling CPU setting for ``inverted_pendulum``.
    """

    num_envs: int = 16
    horizon: int = 128
    sampling: str = "continuing"
    gamma: float = 0.99
    lr: float = 3.9e-3
    return_normalization: str = "batch"
    value_lr: float = 0.0
    value_epochs: int = 1
    value_batch_size: int = 0

    # The baseline is a value network: every value field is VPG's.
    UNUSED_FIELDS: ClassVar[tuple[str, ...]] = ()

    @property
    def value_fit_lr_field(self) -> str:
        """The field that holds the baseline fit's learning rate: ``value_lr``, or ``lr`` when that is 0."""
        return "value_lr" if self.value_lr else "lr"

    @property
    def value_fit_lr(self) -> float:
        """The baseline fit's Adam learning rate: ``value_lr``, or the policy's ``lr`` when 0."""
        return self.value_lr or self.lr

    def validate(self, env: Env) -> None:
        if self.value_lr < 0:
            raise ValueError(f"value_lr must be >= 0 (0: the policy's lr), got {self.value_lr}")
        super().validate(env)


# Named Config overrides: a read-only view of this algorithm's rows of ``presets.TABLE``.
PRESETS = presets.by_algorithm("vpg")


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: policy and baseline with their Adam states, env batch."""
    return core.init_state(
        key, env, config, optimizer=reinforce.optimizer(config), value_optimizer=core.value_optimizer(config)
    )


def phase_advantages(ts: TrainState, batch: core.Batch) -> core.Batch:
    """``advantages = G^ - b(s)`` from the batch of ``reinforce.phase_returns``; the baseline
    keeps ``G^`` as its target."""
    baseline = core.value_predictions(ts, batch.obs)
    return batch.replace(advantages=(batch.value_targets - baseline) * batch.weights)


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One VPG iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, key = core.phase_sample(ts)
    value_key, _ = jax.random.split(key)
    batch = phase_advantages(ts, reinforce.phase_returns(ts, traj))
    ts, diagnostics = reinforce.policy_step(ts, batch)
    ts, value_loss = core.phase_value_fit(ts, batch, value_key)
    kl = core.mean_kl(ts, old.params, ts.params, batch)
    metrics = {**diagnostics, "value_loss": value_loss}
    return core.finish_iteration(old, ts, traj, loss=diagnostics["loss"] + value_loss, kl=kl, metrics=metrics)
