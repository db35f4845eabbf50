"""The clipped mean of a Gaussian policy, ``E[clip(a, low, high)]`` (``distributions.gaussian_clipped_mean``),
against numerical integration in SciPy, and as the deterministic action of ``jaxpg.load_policy``
and ``python -m jaxpg.evaluate --mean-action`` on a continuous run directory written from NPG's
``init`` (nothing trained, log-std 1: a wide policy, whose clipped mean and ``clip(mean)`` differ),
and as the in-run evaluation's action (``eval_action="clipped_mean"``), which such a run's policy
then plays by default."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from run_writer import write_pendulum_run
from scipy import integrate, stats
from script_loader import load_script

import jaxpg
from jaxpg import distributions as D
from jaxpg.algos import npg
from jaxpg.run.evaluation import evaluate_cli
from jaxpg.run.rundir import config_io


def integrated_clipped_mean(mu: float, sigma: float, low: float, high: float) -> float:
    """``E[clip(x, low, high)]``, ``x ~ N(mu, sigma^2)``, by SciPy's adaptive quadrature over the
    three pieces of the clip (each smooth), independent of the closed form."""
    pdf = lambda x: stats.norm.pdf(x, mu, sigma)  # noqa: E731
    below = low * stats.norm.cdf(low, mu, sigma)
    above = high * stats.norm.sf(high, mu, sigma)
    inside, _ = integrate.quad(lambda x: x * pdf(x), low, high, epsabs=1e-12, epsrel=1e-10)
    return below + inside + above


@pytest.mark.parametrize(
    "mu, log_std, low, high",
    [
        (0.5, 1.0, -1.0, 1.0),  # hopper_1m's initial width: std 2.7
        (-2.0, 0.0, -1.0, 1.0),  # the mean beyond the bound
        (3.0, 0.5, -1.0, 1.0),
        (0.1, -0.5, -0.4, 0.4),  # Humanoid's action range
        (0.0, 2.0, -1.0, 1.0),  # symmetric: 0
        (0.3, -6.0, -1.0, 1.0),  # a narrow policy: clip(mean) itself
        (1.7, -6.0, -1.0, 1.0),
    ],
)
def test_the_closed_form_matches_numerical_integration(mu, log_std, low, high):
    """float32 evaluation of a sum of a few O(1) terms: agreement to 1e-6 absolute."""
    dist = {"mean": jnp.float32([mu]), "log_std": jnp.float32([log_std])}
    got = float(D.gaussian_clipped_mean(dist, low, high)[0])
    np.testing.assert_allclose(got, integrated_clipped_mean(mu, math.exp(log_std), low, high), rtol=0, atol=1e-6)


PENDULUM_CONFIG = npg.Config(
    num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8, log_std_init=1.0
)


@pytest.fixture(scope="module")
def pendulum_run(tmp_path_factory):
    """An inverted_pendulum NPG run directory holding one checkpoint of ``init``'s state."""
    return write_pendulum_run(tmp_path_factory.mktemp("runs") / "pendulum", PENDULUM_CONFIG)


@pytest.fixture(scope="module")
def clipped_mean_run(tmp_path_factory):
    """The same run directory, saved with ``eval_action="clipped_mean"``."""
    config = dataclasses.replace(PENDULUM_CONFIG, eval_action="clipped_mean")
    return write_pendulum_run(tmp_path_factory.mktemp("runs") / "pendulum_cm", config)


def test_load_policy_acts_with_the_clipped_mean(pendulum_run):
    mode = jaxpg.load_policy(pendulum_run)
    clipped = jaxpg.load_policy(pendulum_run, clipped_mean=True)
    obs = np.random.default_rng(0).normal(size=(64, mode.observation_size)).astype(np.float32) * 3.0
    dist = mode.policy.dist(mode.params, mode.obs_stats.normalize(jnp.asarray(obs)))
    expected = np.asarray(D.gaussian_clipped_mean(dist, mode.action_low, mode.action_high))
    # The jitted policy and this eager computation may round float32 differently: pre-activations
    # reach about 10 here (weights x 4), so 1e-6 relative of them is 1e-5 of the action.
    np.testing.assert_allclose(clipped(obs), expected, rtol=0, atol=1e-5)
    assert np.all(np.abs(clipped(obs)) <= mode.action_high)
    assert np.max(np.abs(clipped(obs) - mode(obs))) > 0.1  # a wide policy: the two differ
    assert "clipped mean" in repr(clipped)


def test_the_clipped_mean_needs_a_deterministic_continuous_policy(pendulum_run, pristine_run):
    with pytest.raises(ValueError, match="clipped mean"):
        jaxpg.load_policy(pendulum_run, clipped_mean=True, deterministic=False)
    with pytest.raises(ValueError, match="clipped mean"):
        jaxpg.load_policy(pristine_run.path, clipped_mean=True)  # cartpole: discrete


def test_evaluate_plays_the_clipped_mean_in_jaxpgs_env(pendulum_run, capsys):
    assert evaluate_cli.main([str(pendulum_run), "--episodes", "2", "--mean-action", "clipped_mean"]) == 0
    out = capsys.readouterr().out
    assert "mean policy, clipped mean, 2 episodes in jaxpg inverted_pendulum" in out
    assert evaluate_cli.main([str(pendulum_run), "--mean-action", "clipped_mean", "--sample"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --mean-action")


def test_a_run_evaluated_with_the_clipped_mean_plays_it_by_default(pendulum_run, clipped_mean_run, capsys):
    """``load_policy`` and ``jaxpg.evaluate`` act as the run's own evaluations did
    (``eval_action``); an explicit choice wins, and sampled actions stay sampled."""
    obs = np.random.default_rng(1).normal(size=(16, 4)).astype(np.float32) * 3.0
    by_default = jaxpg.load_policy(clipped_mean_run)
    assert by_default.clipped_mean and not jaxpg.load_policy(pendulum_run).clipped_mean
    np.testing.assert_array_equal(by_default(obs), jaxpg.load_policy(pendulum_run, clipped_mean=True)(obs))
    assert not jaxpg.load_policy(clipped_mean_run, clipped_mean=False).clipped_mean
    assert not jaxpg.load_policy(clipped_mean_run, deterministic=False).clipped_mean
    assert not jaxpg.load_policy(clipped_mean_run, clip=False).clipped_mean
    assert evaluate_cli.main([str(clipped_mean_run), "--episodes", "2"]) == 0
    assert "mean policy, clipped mean, 2 episodes" in capsys.readouterr().out
    assert evaluate_cli.main([str(clipped_mean_run), "--episodes", "2", "--mean-action", "mode"]) == 0
    out = capsys.readouterr().out
    assert "mean policy, 2 episodes" in out and "clipped mean" not in out


def test_the_in_run_evaluation_plays_the_configured_mean_action(clipped_mean_run):
    """``core.evaluate`` with ``eval_action="clipped_mean"``: the episodes of an act written here
    from ``gaussian_clipped_mean`` with the same keys; with ``"mode"``, those of ``clip(mean)``.
    The two differ for this wide policy."""
    from jaxpg import rollout
    from jaxpg.algos import core

    run = config_io.RunConfig.load(clipped_mean_run)
    env = run.make_env()
    config = dataclasses.replace(run.algo_config(), eval_envs=3, eval_horizon=20)
    loaded = jaxpg.load_policy(clipped_mean_run)
    state = npg.init(jax.random.PRNGKey(0), env, config).replace(params=loaded.params)
    key = jax.random.PRNGKey(7)
    reset_key, steps_key = jax.random.split(key)

    def expected_return(act_mean):
        def act(params, obs, key):
            dist = loaded.policy.dist(params, state.obs_stats.normalize(obs))
            return act_mean(dist), jnp.zeros(obs.shape[:-1])

        starts = jax.vmap(env.reset)(jax.random.split(reset_key, 3))
        totals = rollout.episode_totals_from(env, act, state.params, starts, steps_key, 20)
        return float(jnp.mean(totals["return"]))

    clipped = float(core.evaluate(state, key)["episode_return"])
    mode = float(
        core.evaluate(state.replace(config=dataclasses.replace(config, eval_action="mode")), key)["episode_return"]
    )
    np.testing.assert_allclose(clipped, expected_return(lambda d: D.gaussian_clipped_mean(d, -3.0, 3.0)), rtol=1e-6)
    np.testing.assert_allclose(mode, expected_return(lambda d: jnp.clip(D.gaussian_mode(d), -3.0, 3.0)), rtol=1e-6)
    assert clipped != mode


def test_eval_action_is_checked():
    env = config_io.RunConfig(task="inverted_pendulum", algo="npg", config={}, seeds=[0], iterations=1).make_env()
    with pytest.raises(ValueError, match="eval_action must be one of mode, clipped_mean, got 'median'"):
        dataclasses.replace(PENDULUM_CONFIG, eval_action="median").validate(env)
    cartpole = config_io.RunConfig(task="cartpole", algo="npg", config={}, seeds=[0], iterations=1).make_env()
    with pytest.raises(ValueError, match="eval_action clipped_mean needs a task with continuous actions"):
        npg.Config(eval_action="clipped_mean").validate(cartpole)


def test_suite_physics_replays_either_action(pendulum_run, clipped_mean_run):
    """``benchmarks/suite.py physics --actions``: each job plays the policy acting as asked (``run``:
    as the run's evaluations did), the same episodes as ``replay.evaluate_gymnasium`` of
    ``load_policy`` with that action."""
    from jaxpg.run.evaluation import replay

    suite = load_script("benchmarks/suite.py")
    for run_dir, action, clipped_mean in (
        (pendulum_run, "mode", False),
        (pendulum_run, "clipped_mean", True),
        (clipped_mean_run, "run", True),
        (clipped_mean_run, "mode", False),
    ):
        played = suite.physics.play_physics((str(run_dir), 0, "gymnasium", action, 2))
        policy = jaxpg.load_policy(run_dir, clipped_mean=clipped_mean)
        returns, _, _ = replay.evaluate_gymnasium(policy, "inverted_pendulum", {}, 2)
        assert played["action"] == action and played["returns"] == returns.tolist()
    # The progress line printed as each job finishes names the job and its result.
    job = f"{Path(clipped_mean_run).name} seed 0, gymnasium, mode"
    mean = suite.verdicts.score_text(played["mean"])  # two decimals under 100 (tests/test_harness.py)
    assert suite.physics.played_line(played, 3, 4) == f"[3/4] {job}: {mean} ({played['early']} early)"
