"""Vanilla policy gradient with a learned state-value baseline, as in the PyTorch Lightning VPG.

One iteration:
  1. sample ``num_envs x horizon`` transitions (``npg.phase_sample``);
  2. Monte-Carlo discounted returns, normalised (``return_normalization``, by default over the
     batch) into ``G^_t`` (``reinforce.normalized_returns``);
  3. advantages ``A_t = G^_t - b(s_t)``: the normalised return minus the baseline's prediction,
     the prediction taken as it is (it is not un-normalised: the baseline learns normalised
     returns, step 5);
  4. one optimizer step on ``-E[A log pi(a|s)] - entropy_coef * E[H]`` (``reinforce.policy_step``);
  5. fit the baseline to the normalised returns ``G^_t`` by ``value_epochs`` passes of minibatch
     Adam on the mean squared error (by default one full-batch step, our reading of the seed's
     one Lightning step per epoch on the whole data set);
  6. reject non-finite updates, update observation statistics (``npg.finish_iteration``).

Fitting the baseline to *normalised* returns keeps its targets on one scale while the policy
improves and the raw returns grow by orders of magnitude (1 to 1000 on the inverted pendulum), so
that one fixed learning rate suits it throughout; with ``return_normalization="none"`` it is the
textbook baseline on raw returns.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import optax

from jaxpg import value as value_lib
from jaxpg.algos import common, npg, reinforce
from jaxpg.algos.common import TrainState
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class Config(reinforce.Config):
    """VPG hyperparameters: those of ``reinforce.Config`` plus the baseline's fit.

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

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.value_lr < 0 or self.value_epochs < 1 or self.value_batch_size < 0:
            raise ValueError("value_lr must be >= 0, value_epochs >= 1 and value_batch_size >= 0")
        if self.value_batch_size > self.samples_per_iteration:
            raise ValueError(
                f"value_batch_size {self.value_batch_size} exceeds the {self.samples_per_iteration} samples "
                f"of an iteration (num_envs {self.num_envs} x horizon {self.horizon})"
            )


PRESETS: dict[str, dict[str, Any]] = {
    # On inverted_pendulum: the PyTorch Lightning VPG. Policy 64 -> 64 tanh
    # with a global log-std, baseline of the same shape, Adam lr 3.9e-3, discount 0.9, 2500
    # samples per epoch (here 10 envs x 250 steps of continuing sampling, the data set carried
    # across episode ends), advantages = normalised returns - baseline, baseline fitted to the
    # normalised returns with one full-batch step per epoch; 100 epochs in the seed.
    "lightning": dict(
        sampling="continuing",
        num_envs=10,
        horizon=250,
        gamma=0.9,
        policy="gaussian",
        policy_hidden=(64, 64),
        policy_activation="tanh",
        policy_init="pytorch",
        log_std_init=0.0,
        value_hidden=(64, 64),
        value_activation="tanh",
        optimizer="adam",
        lr=3.9e-3,
        value_lr=3.9e-3,
        value_epochs=1,
        value_batch_size=0,
        return_normalization="batch",
    ),
}


def value_optimizer(config: Config) -> optax.GradientTransformation:
    return optax.adam(config.value_lr or config.lr)


def init(key: jax.Array, env: Env, config: Config) -> TrainState:
    """A fresh ``TrainState``: policy and baseline with their Adam states, env batch."""
    return common.init_common(
        key,
        env,
        config,
        opt_init=reinforce.optimizer(config).init,
        value_opt_init=value_optimizer(config).init,
    )


def phase_advantages(ts: TrainState, batch: npg.Batch) -> npg.Batch:
    """``advantages = G^ - b(s)`` from the batch of ``reinforce.phase_returns``; the baseline
    keeps ``G^`` as its target."""
    baseline = ts.value_fn.apply(ts.value_params, batch.obs)
    return batch.replace(advantages=(batch.value_targets - baseline) * batch.weights)


def phase_value_fit(ts: TrainState, batch: npg.Batch, key: jax.Array) -> tuple[TrainState, jax.Array]:
    """Minibatch Adam on ``(b(s) - G^)^2``; returns the state with the new baseline and the loss."""
    config = ts.config
    value_params, value_opt_state, loss = value_lib.fit_value(
        ts.value_fn,
        ts.value_params,
        ts.value_opt_state,
        value_optimizer(config),
        batch.obs,
        batch.value_targets,
        key,
        epochs=config.value_epochs,
        batch_size=config.value_batch_size or config.samples_per_iteration,
        weights=batch.weights,
    )
    return ts.replace(value_params=value_params, value_opt_state=value_opt_state), loss


def update(ts: TrainState) -> tuple[TrainState, dict[str, jax.Array]]:
    """One VPG iteration (module docstring); pure, jittable, vmappable over seeds."""
    old = ts
    ts, traj, key = npg.phase_sample(ts)
    value_key, _ = jax.random.split(key)
    batch = phase_advantages(ts, reinforce.phase_returns(ts, traj))
    ts, diagnostics = reinforce.policy_step(ts, batch)
    ts, value_loss = phase_value_fit(ts, batch, value_key)
    metrics = {
        **diagnostics,
        "value_loss": value_loss,
        "kl": npg.mean_kl(ts, old.params, ts.params, batch),
    }
    return npg.finish_iteration(old, ts, traj, diagnostics["loss"] + value_loss, metrics)
