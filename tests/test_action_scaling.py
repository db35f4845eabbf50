"""Actions in [-1, 1] mapped onto the task's range (``jaxpg.envs.RescaleAction``,
``make(..., action_scaling=True)``, ``--action-scaling``): the affine map against NumPy on a task
with asymmetric bounds, the clip around it, the flag and the presets that set it, and the trained
policy acting in the task's own units through ``jaxpg.load_policy`` and the Gymnasium replay
(against a loop over Gymnasium's env written here)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from run_writer import write_pendulum_run

import jaxpg
from jaxpg import distributions as D
from jaxpg import envs
from jaxpg.algos import npg
from jaxpg.envs.base import Env
from jaxpg.run.command import task_options
from jaxpg.run.evaluation import evaluate_cli


class EchoAction(Env):
    """A continuous task whose observation is the action it was given (bounds [-0.5, 2.0])."""

    observation_size = 2
    action_size = 2
    dt = 0.01
    max_episode_steps = 10
    action_low = -0.5
    action_high = 2.0

    def _reset(self, key):
        return jnp.zeros(()), jnp.zeros(2), {}

    def _step(self, state, action):
        return state.data, action, jnp.zeros(()), jnp.zeros((), bool), {}


def test_the_map_matches_numpy_and_clips_to_the_unit_box():
    """``-1`` -> ``action_low``, ``1`` -> ``action_high``, affine between (NumPy's
    ``low + (a + 1) / 2 * (high - low)``; float32 rounding of a few operations on O(1) numbers:
    1e-6); ``ClipAction`` above clips to [-1, 1] first."""
    task = EchoAction()
    env = envs.ClipAction(envs.RescaleAction(task))
    assert (env.action_low, env.action_high) == (-1.0, 1.0)
    assert (env.unwrapped.action_low, env.unwrapped.action_high) == (-0.5, 2.0)
    given = np.float32([[-1.0, 1.0], [0.0, 0.25], [-0.3, 0.9], [-3.0, 7.0]])
    step = jax.jit(jax.vmap(env.step, in_axes=(None, 0)))
    out = np.asarray(step(env.reset(jax.random.key(0)), jnp.asarray(given)).obs)
    clipped = np.clip(given.astype(np.float64), -1.0, 1.0)
    np.testing.assert_allclose(out, -0.5 + (clipped + 1.0) / 2.0 * 2.5, rtol=0, atol=1e-6)
    np.testing.assert_array_equal(out[0], [-0.5, 2.0])
    np.testing.assert_array_equal(out[3], [-0.5, 2.0])


def test_make_rescales_on_request_and_refuses_a_discrete_task():
    env = envs.make("inverted_pendulum", impl="jax", action_scaling=True)
    assert "ClipAction(RescaleAction(InvertedPendulum" in repr(env)
    assert (env.action_low, env.action_high) == (-1.0, 1.0)
    assert "RescaleAction" not in repr(envs.make("inverted_pendulum", impl="jax"))
    with pytest.raises(ValueError, match="RescaleAction needs continuous actions; 'cartpole' has discrete ones"):
        envs.make("cartpole", action_scaling=True)


def test_the_flag_and_the_preset_reach_the_env_and_the_run(tmp_path, monkeypatch):
    """``--action-scaling`` (or a preset that sets it) wraps the planned env and is saved in the
    run's ``env_kwargs``; ``--no-action-scaling`` turns a preset's off (and leaves no key)."""
    from jaxpg.run.command import command_line, planning

    monkeypatch.chdir(tmp_path)
    experiment = command_line.Experiment()
    pendulum = ["--env", "inverted_pendulum", "--impl", "jax", "--run-dir", "planned"]
    plan = planning.plan([*pendulum, "--action-scaling"], experiment)
    assert plan.run.env_kwargs["action_scaling"] is True and plan.env.action_high == 1.0
    assert "action_scaling" not in planning.plan(pendulum, experiment).run.env_kwargs
    humanoid = ["--env", "humanoid", "--impl", "jax", "--algo", "ppo", "--preset", "humanoid_1m", "--run-dir", "x"]
    plan = planning.plan(humanoid, experiment)
    assert (
        plan.run.env_kwargs["action_scaling"] is True
        and plan.run.env_kwargs["include_cfrc_ext_in_observation"] is False
    )
    assert (plan.env.action_low, plan.env.unwrapped.action_low) == (-1.0, -0.4)
    plan = planning.plan([*humanoid, "--no-action-scaling"], experiment)
    assert "action_scaling" not in plan.run.env_kwargs and plan.env.action_low == -0.4
    assert not (tmp_path / "planned").exists()


def test_bad_uses_of_the_flag_get_one_error_line(tmp_path, capsys):
    """``--env-kwargs action_scaling=...`` and ``--action-scaling`` on a discrete task: one
    ``error:`` line, exit 2, no run directory."""
    from jaxpg import cli

    for argv, message in (
        (["--env", "inverted_pendulum", "--env-kwargs", "action_scaling=true"], "use --action-scaling"),
        (["--env", "cartpole", "--action-scaling"], "RescaleAction needs continuous actions"),
    ):
        bad_dir = tmp_path / "bad"
        assert cli.main([*argv, "--algo", "npg", "--iterations", "1", "--run-dir", str(bad_dir)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error:") and message in err[0], err
        assert not bad_dir.exists()


def test_humanoids_1m_presets_act_in_the_unit_box():
    """Humanoid's 1 M-step presets act in [-1, 1] (Tianshou's action scaling) with its initial
    log-std -0.5; the contact forces stay out of the observation, and no task option is lost."""
    for algo in ("ppo", "a2c"):
        options = jaxpg.algos.preset_env_kwargs(algo, "humanoid_1m")
        assert options == {"include_cfrc_ext_in_observation": False, "action_scaling": True}
        assert jaxpg.algos.preset(algo, "humanoid_1m", "humanoid")["log_std_init"] == -0.5
        task_only = {k: v for k, v in options.items() if k not in task_options.PRESET_ENV_SETTINGS}
        assert task_options.check_options("humanoid", task_only) == {"include_cfrc_ext_in_observation": False}


CONFIG = npg.Config(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8, log_std_init=0.0)


@pytest.fixture(scope="module")
def rescaled_run(tmp_path_factory):
    """An inverted_pendulum NPG run directory (actions in [-3, 3]) trained with ``action_scaling``,
    holding one checkpoint of ``init``'s state with its parameters scaled up, so that some mean
    actions lie outside [-1, 1]."""
    return write_pendulum_run(tmp_path_factory.mktemp("runs") / "rescaled", CONFIG, {"action_scaling": True})


def test_load_policy_acts_in_the_tasks_units(rescaled_run):
    """The policy's mode (or clipped mean) in [-1, 1], times the pendulum's half-range 3: what the
    training env executed. Float32 rounding of pre-activations near 10 (weights x 4): 1e-5."""
    policy = jaxpg.load_policy(rescaled_run)
    assert (policy.action_low, policy.action_high) == (-3.0, 3.0)
    obs = np.random.default_rng(0).normal(size=(64, 4)).astype(np.float32) * 3.0
    dist = policy.policy.dist(policy.params, policy.obs_stats.normalize(jnp.asarray(obs)))
    mode = np.clip(np.asarray(D.gaussian_mode(dist)), -1.0, 1.0)
    np.testing.assert_allclose(policy(obs), 3.0 * mode, rtol=0, atol=1e-5)
    assert np.mean(np.abs(mode) == 1.0) > 0.1  # some actions sit on the bounds
    clipped_mean = np.asarray(D.gaussian_clipped_mean(dist, -1.0, 1.0))
    np.testing.assert_allclose(jaxpg.load_policy(rescaled_run, clipped_mean=True)(obs), 3.0 * clipped_mean, atol=1e-5)
    unclipped = jaxpg.load_policy(rescaled_run, clip=False)(obs)
    np.testing.assert_allclose(unclipped, 3.0 * np.asarray(D.gaussian_mode(dist)), rtol=1e-5, atol=1e-5)


def test_the_gymnasium_replay_plays_the_tasks_units(rescaled_run, capsys):
    """``python -m jaxpg.evaluate RUN --gymnasium`` on a rescaled run: the returns of a loop over
    Gymnasium's InvertedPendulum-v5 written here, acting ``3 * clip(mode, -1, 1)`` (episode i reset
    with seed i, as the replay does)."""
    gym = pytest.importorskip("gymnasium")
    policy = jaxpg.load_policy(rescaled_run)
    env = gym.make("InvertedPendulum-v5")
    expected = []
    for i in range(3):
        obs, _ = env.reset(seed=i)
        total, done = 0.0, False
        while not done:
            dist = policy.policy.dist(policy.params, policy.obs_stats.normalize(jnp.asarray(obs, jnp.float32)))
            action = 3.0 * np.clip(np.asarray(D.gaussian_mode(dist)), -1.0, 1.0)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += float(reward)
            done = terminated or truncated
        expected.append(total)
    assert evaluate_cli.main([str(rescaled_run), "--gymnasium", "--episodes", "3"]) == 0
    out = capsys.readouterr().out
    assert f"return: {np.mean(expected):.2f}" in out, (out, expected)
