"""Brax interop both ways: jaxpg's tasks under Brax's wrappers and trainers (``jaxpg.envs.brax_env``),
Brax's envs as jaxpg tasks (``jaxpg.envs.brax_task``), and the shim that lets Brax 0.14.2's trainers
run on JAX >= 0.10 (``jaxpg.envs.brax_compat``). The references are Brax's own env and wrappers,
and jaxpg's task stepped alone."""

from __future__ import annotations

import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

pytest.importorskip("brax")

from brax.envs.wrappers import training as brax_training  # noqa: E402

from jaxpg import envs  # noqa: E402
from jaxpg.envs import brax_compat, brax_env  # noqa: E402
from jaxpg.envs.wrappers import ClipAction, RescaleAction  # noqa: E402

LIMIT = 5  # a short time limit, so that a dozen steps see truncations
STEPS = 12
# Env 0 holds the pole with no force (it stays up past the limit); env 1 pushes at full force (the
# pole tips over, a termination, before the limit).
ACTIONS = jnp.array([[0.0], [1.0]])


@pytest.fixture(scope="module")
def pendulum():
    return envs.make_task("inverted_pendulum", max_episode_steps=LIMIT)


def rollout(wrapped, keys):
    """``STEPS`` steps of a Brax-wrapped batch from ``reset(keys)``: the first state and every step's
    ``done``, ``info`` flags, reward and observation, ``[STEPS, 2]`` (obs ``[STEPS, 2, 4]``)."""

    def run(keys):
        first = wrapped.reset(keys)

        def one(state, _):
            state = wrapped.step(state, ACTIONS)
            info = {k: state.info[k] for k in ("time_out", "truncation")}
            return state, (state.done, info, state.reward, state.obs)

        return first.obs, jax.lax.scan(one, first, None, length=STEPS)[1]

    return jax.jit(run)(keys)


def reference_episode(task, key, action):
    """The jaxpg task itself (actions rescaled from [-1, 1], as the adapter does), from ``reset(key)``
    to its first episode end: per step ``(terminated, truncated, reward)``."""
    env = ClipAction(RescaleAction(task))
    state, out = env.reset(key), []
    step = jax.jit(env.step)
    while not out or not (out[-1][0] or out[-1][1]):
        state = step(state, action)
        out.append((bool(state.terminated), bool(state.truncated), float(state.reward)))
    return out


@pytest.mark.parametrize("time_limit", [True, False])
def test_brax_wrappers_end_episodes_where_gymnasium_does(pendulum, time_limit):
    """Under Brax's ``wrap`` (vmap, ``EpisodeWrapper``, ``AutoResetWrapper``) the first episode of
    each env ends at the step the task's own ``terminated``/``truncated`` end it, with the same
    rewards; ``time_out`` (what ``bootstrap_on_timeout`` reads) is set exactly at the truncation when
    the env keeps the time limit, and Brax's ``truncation`` is set there when ``EpisodeWrapper``
    keeps it. The next episode starts from Brax's cached first observation, as Brax's envs do."""
    keys = jax.random.split(jax.random.PRNGKey(3), 2)
    adapter = brax_env.as_brax_env(pendulum, time_limit=time_limit)
    first_obs, (done, info, reward, obs) = rollout(brax_training.wrap(adapter, episode_length=LIMIT), keys)
    ends = []
    for i in range(2):
        expected = reference_episode(pendulum, keys[i], ACTIONS[i])
        n = len(expected)
        terminated, truncated = expected[-1][:2]
        ends.append((n, terminated, truncated))
        np.testing.assert_array_equal(np.asarray(done[:n, i]), [0.0] * (n - 1) + [1.0])
        np.testing.assert_allclose(np.asarray(reward[:n, i]), [r for *_, r in expected], rtol=1e-6)
        flag = "time_out" if time_limit else "truncation"
        other = "truncation" if time_limit else "time_out"
        assert float(info[flag][n - 1, i]) == float(truncated)
        assert not np.any(np.asarray(info[other][:n, i]))
        assert not np.any(np.asarray(info[flag][: n - 1, i]))
        np.testing.assert_array_equal(np.asarray(obs[n - 1, i]), np.asarray(first_obs[i]))  # cached reset
    assert ends[0] == (LIMIT, False, True)  # held: cut by the time limit
    assert ends[1][1] and ends[1][0] < LIMIT  # pushed: fell before it


def test_fresh_reset_wrapper_draws_new_reset_noise(pendulum):
    """``wrap_for_training`` (Brax's stack with ``FreshResetWrapper``): the same episode ends, but
    each new episode starts from a new state within the task's reset noise, not the first one."""
    keys = jax.random.split(jax.random.PRNGKey(3), 2)
    adapter = brax_env.as_brax_env(pendulum)
    first_obs, (done, info, _, obs) = rollout(brax_env.wrap_for_training(adapter, episode_length=LIMIT), keys)
    assert float(done[LIMIT - 1, 0]) == 1.0 and float(info["time_out"][LIMIT - 1, 0]) == 1.0
    new_start = np.asarray(obs[LIMIT - 1, 0])
    assert not np.array_equal(new_start, np.asarray(first_obs[0]))
    # Gymnasium's InvertedPendulum resets qpos and qvel uniformly within 0.01 of rest.
    assert np.all(np.abs(new_start) <= pendulum.reset_noise_scale + 1e-7)
    ends = np.flatnonzero(np.asarray(done[:, 0]))
    starts = [np.asarray(obs[t, 0]) for t in ends]
    assert len(ends) == 2 and not np.array_equal(starts[0], starts[1])


def test_brax_ppo_trains_a_jaxpg_task(pendulum):
    """Brax's own PPO, unchanged, trains a jaxpg task for a few iterations (with the shim and
    Gymnasium's resets and time-out bootstrapping) and reports finite evaluations; outside the
    shim's block JAX has no ``device_put_replicated`` again."""
    from brax.training.agents.ppo import train as brax_ppo

    progress = []
    with brax_compat.brax_jax_shim():
        make_policy, params, metrics = brax_ppo.train(
            environment=brax_env.as_brax_env(pendulum),
            num_timesteps=2 * 8 * 8 * 2,
            episode_length=LIMIT,
            num_envs=8,
            unroll_length=8,
            batch_size=8,
            num_minibatches=2,
            num_updates_per_batch=1,
            num_evals=2,
            num_eval_envs=4,
            bootstrap_on_timeout=True,
            wrap_env_fn=brax_env.wrap_for_training,
            network_factory=_tiny_ppo_networks(),
            progress_fn=lambda step, m: progress.append((step, float(m["eval/episode_reward"]))),
            seed=0,
        )
    assert not hasattr(jax, brax_compat.REMOVED_NAME)
    assert len(progress) == 2 and progress[-1][0] >= 2 * 8 * 8 * 2
    # Each evaluation episode earns 1 per upright step and is cut at LIMIT steps.
    assert all(0.0 < r <= LIMIT for _, r in progress)
    actions, _ = make_policy(params, deterministic=True)(jnp.zeros((3, 4)), jax.random.PRNGKey(0))
    assert actions.shape == (3, 1) and np.all(np.abs(np.asarray(actions)) <= 1.0)


def test_brax_sac_trains_a_jaxpg_task(pendulum):
    """Brax's SAC, unchanged, on the same adapter: a few steps from a replay buffer, finite
    evaluations within what a LIMIT-step episode can earn."""
    import functools

    from brax.training.agents.sac import networks as sac_networks
    from brax.training.agents.sac import train as brax_sac

    progress = []
    with brax_compat.brax_jax_shim():
        brax_sac.train(
            environment=brax_env.as_brax_env(pendulum),
            num_timesteps=256,
            episode_length=LIMIT,
            num_envs=4,
            num_eval_envs=4,
            batch_size=8,
            num_evals=2,
            min_replay_size=32,
            max_replay_size=256,
            wrap_env_fn=brax_env.wrap_for_training,
            network_factory=functools.partial(sac_networks.make_sac_networks, hidden_layer_sizes=(8,)),
            progress_fn=lambda step, m: progress.append((step, float(m["eval/episode_reward"]))),
            seed=0,
        )
    assert len(progress) == 2 and progress[-1][0] >= 256
    assert all(0.0 < r <= LIMIT for _, r in progress)


def _tiny_ppo_networks():
    import functools

    from brax.training.agents.ppo import networks as ppo_networks

    return functools.partial(
        ppo_networks.make_ppo_networks, policy_hidden_layer_sizes=(8,), value_hidden_layer_sizes=(8,)
    )


def test_replicated_on_devices_is_what_pmap_takes():
    """The shim's replacement stacks one copy per device, which ``jax.pmap`` maps over."""
    tree = {"w": jnp.arange(3.0), "n": jnp.array(2)}
    devices = jax.local_devices()[:1]
    out = brax_compat.replicated_on_devices(tree, devices)
    assert out["w"].shape == (1, 3) and out["n"].shape == (1,)
    summed = jax.pmap(lambda t: t["w"].sum() * t["n"])(out)
    np.testing.assert_allclose(np.asarray(summed), [6.0])


@pytest.fixture(scope="module")
def brax_pendulum():
    return envs.make_task("brax:inverted_pendulum", max_episode_steps=LIMIT)


def test_brax_env_as_jaxpg_task_steps_as_brax(brax_pendulum):
    """``brax:inverted_pendulum`` gives Brax's own observations and rewards step for step (the
    reference: Brax's env stepped directly from the same key); Brax's ``done`` is jaxpg's
    ``terminated``, and the task's time limit sets ``truncated``."""
    from brax import envs as brax_envs

    reference = brax_envs.get_environment("inverted_pendulum", backend="mjx")
    key = jax.random.PRNGKey(5)
    state = jax.jit(brax_pendulum.reset)(key)
    expected = jax.jit(reference.reset)(jax.random.split(key)[1])  # jaxpg's reset splits its key first
    np.testing.assert_array_equal(np.asarray(state.obs), np.asarray(expected.obs))
    step, ref_step = jax.jit(brax_pendulum.step), jax.jit(reference.step)
    total = 0.0
    for t in range(LIMIT):
        state, expected = step(state, jnp.array([0.1])), ref_step(expected, jnp.array([0.1]))
        np.testing.assert_allclose(np.asarray(state.obs), np.asarray(expected.obs), rtol=1e-6, atol=1e-7)
        # Two programs compute it (the task's step and the env's own): float32 rounding may differ.
        assert float(state.reward) == pytest.approx(float(expected.reward), rel=1e-6)
        assert bool(state.terminated) == bool(expected.done)
        total += float(expected.reward)
        assert bool(state.truncated) == (t == LIMIT - 1 and not bool(expected.done))
    assert float(state.metrics["task_score"]) == pytest.approx(total)


def test_jaxpg_ppo_trains_a_brax_env():
    """jaxpg's PPO takes ``brax:inverted_pendulum`` (any of Brax's backends) as any task: a few updates, finite metrics,
    parameters that moved, no non-finite step."""
    from jaxpg.algos import ppo

    env = envs.make("brax:inverted_pendulum", max_episode_steps=LIMIT, backend="spring")  # Brax's cheapest to compile
    config = ppo.Config(
        num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), eval_envs=2, eval_horizon=8, num_minibatches=2
    )
    ts = ppo.init(jax.random.PRNGKey(0), env, config)
    update = jax.jit(ppo.update)
    new, metrics = update(ts)
    new, metrics = update(new)
    assert all(np.all(np.isfinite(np.asarray(v))) for v in jax.tree.leaves(metrics))
    moved = [
        not np.array_equal(a, b) for a, b in zip(jax.tree.leaves(ts.params), jax.tree.leaves(new.params), strict=True)
    ]
    assert any(moved)
    assert int(new.iteration) == 2


def test_unknown_external_names_are_one_line_errors():
    """``brax:`` with a name Brax lacks, a module that does not import: ``ValueError`` from
    ``make``, and from the command line one ``error:`` line with exit code 2."""
    with pytest.raises(ValueError, match="Brax's environments: ant"):
        envs.make("brax:no_such_env")
    with pytest.raises(ValueError, match="cannot import"):
        envs.make("no_such_module_xyz:Env")
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "jaxpg.cli",
            "--env",
            "brax:no_such_env",
            "--iterations",
            "1",
            "--run-dir",
            "/nonexistent/x",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1].startswith("error: ")
    assert "no_such_env" in done.stderr


@pytest.mark.optional
def test_playground_env_as_jaxpg_task_steps_as_playground():
    """``playground:CartpoleBalance`` (needs ``pip install -e '.[playground]'``; optional: Playground
    is not in the test extra) gives Playground's own observations and rewards, from the same key."""
    playground = pytest.importorskip("mujoco_playground")
    task = envs.make_task("playground:CartpoleBalance", max_episode_steps=LIMIT)
    reference = playground.registry.load("CartpoleBalance")
    key = jax.random.PRNGKey(7)
    state = jax.jit(task.reset)(key)
    expected = jax.jit(reference.reset)(jax.random.split(key)[1])
    step, ref_step = jax.jit(task.step), jax.jit(reference.step)
    for t in range(LIMIT):
        state, expected = step(state, jnp.array([0.3])), ref_step(expected, jnp.array([0.3]))
        np.testing.assert_allclose(np.asarray(state.obs), np.asarray(expected.obs), rtol=1e-6, atol=1e-7)
        # Two programs compute it (the task's step and the env's own): float32 rounding may differ.
        assert float(state.reward) == pytest.approx(float(expected.reward), rel=1e-6)
        assert bool(state.truncated) == (t == LIMIT - 1)


def test_command_line_trains_a_brax_env(tmp_path):
    """``python -m jaxpg.cli --env brax:NAME`` with the env's own option (``--env-kwargs backend=``)
    trains another jaxpg algorithm (TRPO) and saves the task's name for a resume or evaluation."""
    import json

    run_dir = tmp_path / "run"
    command = ["--env", "brax:inverted_pendulum", "--env-kwargs", "backend=spring", "--algo", "trpo"]
    sizes = ["--iterations", "1", "--num-envs", "8", "--horizon", "8", "--eval-envs", "2", "--eval-horizon", "8"]
    done = subprocess.run(
        [sys.executable, "-m", "jaxpg.cli", *command, *sizes, "--run-dir", str(run_dir)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    config = json.loads((run_dir / "config.json").read_text())
    assert config["task"] == "brax:inverted_pendulum"
    rows = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    assert rows and all(np.isfinite(v) for row in rows for v in row.values() if isinstance(v, float))
