"""Hyperparameters as data (``core.hparams``): an update that reads its numbers from
``TrainState.hparams`` computes bit for bit what the update of a static config with those numbers
computes, on the same device.

Each case trains two iterations of one algorithm twice, both as one ``jit`` of a ``lax.scan``:
once with the config ``REFERENCE`` static in the state (the path every run took before hparams
existed), once with a state built from ``OTHER`` (the same structure, every traced number moved)
given ``REFERENCE``'s numbers as arrays. Parameters, value parameters, optimizer states, RNG keys
and metrics must be equal bit for bit: the two programs differ only in where the numbers come from,
and ``core.hparams`` rounds every host-side computation and constant division as the static path
does. Starting from ``OTHER``'s state also catches a number read from the static config by mistake.
The configs turn every switch on (clipping, annealing, log-std bounds, the KL guard), so that each
traced field is read.
"""

from __future__ import annotations

import dataclasses

import jax
import numpy as np
import pytest

import jaxpg.envs as envs
from jaxpg.algos import a2c, core, npg, ppo, reinforce, trpo, vpg

ITERATIONS = 2
SMALL = dict(num_envs=4, horizon=16, policy_hidden=(8,), value_hidden=(8,))
CONTINUOUS_BOUNDS = dict(log_std_init=-0.5, log_std_final=-1.0, log_std_min=-1.6, anneal_log_std_iterations=7)

CASES = {
    "npg": (
        npg,
        "inverted_pendulum",
        npg.Config(
            **SMALL,
            **CONTINUOUS_BOUNDS,
            value_batch_size=16,
            kl_delta=0.03,
            anneal_kl_iterations=9,
            cg_damping=0.07,
            gamma=0.97,
            gae_lambda=0.93,
            value_lr=2e-3,
            max_update_kl=0.3,
        ),
    ),
    "trpo": (
        trpo,
        "cartpole",
        trpo.Config(
            **SMALL,
            value_batch_size=16,
            max_kl=0.02,
            backtrack_ratio=0.7,
            accept_ratio=0.2,
            cg_damping=0.05,
            gamma=0.98,
            gae_lambda=0.9,
            value_lr=3e-3,
        ),
    ),
    "ppo": (
        ppo,
        "cartpole",
        ppo.Config(
            **SMALL,
            num_epochs=2,
            num_minibatches=2,
            lr=7e-4,
            adam_eps=3e-5,
            clip_eps=0.3,
            value_clip_eps=0.4,
            value_coef=0.7,
            entropy_coef=0.02,
            max_grad_norm=0.6,
            reward_scaling=0.3,
            anneal_lr_iterations=11,
            gamma=0.97,
            gae_lambda=0.91,
            normalize_rewards=True,
        ),
    ),
    # Every switch off (no clipping, annealing, value clipping or KL guard): the traced numbers
    # must not switch them on.
    "ppo_switches_off": (
        ppo,
        "cartpole",
        ppo.Config(
            **SMALL,
            num_epochs=2,
            num_minibatches=2,
            lr=7e-4,
            clip_eps=0.3,
            value_coef=0.7,
            entropy_coef=0.02,
            max_grad_norm=0.0,
            max_update_kl=0.0,
            gamma=0.97,
        ),
    ),
    "a2c": (
        a2c,
        "cartpole",
        a2c.Config(
            **SMALL,
            lr=2e-3,
            eps=3e-5,
            value_coef=0.6,
            entropy_coef=0.03,
            max_grad_norm=0.7,
            reward_scaling=0.2,
            anneal_lr_iterations=13,
            gamma=0.96,
            gae_lambda=0.9,
        ),
    ),
    "reinforce": (
        reinforce,
        "cartpole",
        reinforce.Config(
            num_envs=4,
            horizon=16,
            policy_hidden=(8,),
            optimizer="adamw",
            lr=3e-3,
            weight_decay=0.02,
            entropy_coef=0.01,
            max_grad_norm=0.9,
            gamma=0.97,
        ),
    ),
    "vpg": (
        vpg,
        "cartpole",
        vpg.Config(**SMALL, lr=2e-3, value_lr=4e-3, entropy_coef=0.01, max_grad_norm=0.8, gamma=0.98),
    ),
}


def moved(config):
    """``config`` with every traced number moved (floats scaled by 0.9 or 0 made 0.05, counts + 1), its switches
    and validity kept."""
    changes = {}
    off = {name for name, on in core.hparams.switch_states(config) if not on}
    for name in core.traced_fields(config):
        if name in off:
            continue
        value = getattr(config, name)
        changes[name] = value + 1 if isinstance(value, int) else (value * 0.9 if value else 0.05)
    return dataclasses.replace(config, **changes)


def two_iterations(module, ts):
    return jax.lax.scan(lambda s, _: module.update(s), ts, None, length=ITERATIONS)


def learned(ts):
    return (ts.params, ts.value_params, ts.opt_state, ts.value_opt_state, ts.key, ts.obs_stats, ts.value_stats)


@pytest.mark.parametrize("name", list(CASES))
def test_traced_hyperparameters_are_bit_exact(name):
    module, task, reference = CASES[name]
    env = envs.make(task)
    other = moved(reference)
    assert core.program_key(other) == core.program_key(reference)
    off = {f for f, on in core.hparams.switch_states(reference) if not on}
    assert all(getattr(other, f) != getattr(reference, f) for f in core.traced_fields(reference) if f not in off)
    key = jax.random.PRNGKey(3)

    static_state, static_metrics = jax.jit(lambda k: two_iterations(module, module.init(k, env, reference)))(key)

    def traced_run(k, hparams):
        ts = core.with_hyperparameters(module.init(k, env, other), hparams)
        return two_iterations(module, ts)

    traced_state, traced_metrics = jax.jit(traced_run)(key, core.hyperparameters(reference))
    for a, b in zip(jax.tree.leaves(learned(static_state)), jax.tree.leaves(learned(traced_state)), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    for metric, values in static_metrics.items():
        np.testing.assert_array_equal(np.asarray(values), np.asarray(traced_metrics[metric]), err_msg=metric)
    # The moved numbers do change the run: the comparison is not vacuous.
    moved_state, _ = jax.jit(traced_run)(key, core.hyperparameters(other))
    assert not all(
        np.array_equal(np.asarray(a), np.asarray(b))
        for a, b in zip(jax.tree.leaves(static_state.params), jax.tree.leaves(moved_state.params), strict=True)
    )
