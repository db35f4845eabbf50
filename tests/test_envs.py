"""Tests of the jaxpg tasks and wrappers: Gymnasium parity, batched rollouts, guards, warp vs jax.

The reference is Gymnasium itself (CPU MuJoCo for the MJX tasks, NumPy for CartPole), driven from
the same states with the same actions. Compiled functions are shared through module-scoped fixtures
and the float64 parity run overlaps with the rest in a subprocess, to keep the file at a few minutes
on two CPU cores.

Run as a script (``JAX_ENABLE_X64=1 python tests/test_envs.py TASK ...``) this file is the worker
of ``test_gymnasium_parity`` and prints its findings as JSON.
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
import tempfile

import gymnasium as gym
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from mujoco import mjx

import jaxpg.envs as envs
from jaxpg import rollout as rollout_lib
from jaxpg.envs import AutoReset
from jaxpg.envs.cartpole import CartPoleData
from jaxpg.envs.mjx_env import FAST_LS_ITERATIONS, FAST_SOLVER_ITERATIONS, MjxEnv, warp_available

GYM_IDS = {
    "hopper": "Hopper-v5",
    "inverted_pendulum": "InvertedPendulum-v5",
    "inverted_double_pendulum": "InvertedDoublePendulum-v5",
}
PARITY_SEEDS = 4
PARITY_STEPS = 60  # per seed; stepping goes on after termination, as Gymnasium's MuJoCo envs allow


# --------------------------------------------------------------------------------------------
# "fast" fidelity: same observation and reward functions as Gymnasium's, from the same MuJoCo data


@pytest.mark.parametrize("task", list(GYM_IDS))
def test_fast_fidelity_observation_and_reward_match_gymnasium(task):
    """In ``fidelity="fast"`` jaxpg's physics differs from Gymnasium's (Euler, short solve) but what
    it reads from the physics must not: Gymnasium's env, switched to the same solver settings,
    resets and steps on the CPU, jaxpg's reset and step are fed the resulting ``MjData`` in place
    of their own physics, and obs, reward and ``terminated`` must be those of Gymnasium, exactly
    after the float32 cast (computed in float64, as Gymnasium does)."""
    env = envs.make_task(task, fidelity="fast", impl="jax")
    gym_env = gym.make(GYM_IDS[task]).unwrapped
    model = gym_env.model
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    model.opt.iterations = FAST_SOLVER_ITERATIONS
    model.opt.ls_iterations = FAST_LS_ITERATIONS
    assert model.opt.integrator == env.mj_model.opt.integrator  # same settings as jaxpg's "fast"

    def gym_physics_state(qpos: jax.Array, qvel: jax.Array, forward: bool = False) -> mjx.Data:
        gym_env.set_state(np.asarray(qpos, np.float64), np.asarray(qvel, np.float64))  # with mj_forward
        return mjx.put_data(model, gym_env.data)

    gym_env.reset(seed=0)
    rng = np.random.default_rng(0)
    terminations = 0
    with jax.enable_x64(True):
        env.physics_state = gym_physics_state
        state = env.reset(jax.random.key(0))
        np.testing.assert_array_equal(np.asarray(state.obs), gym_env._get_obs().astype(np.float32))
        for _ in range(25):
            action = rng.uniform(env.action_low, env.action_high, env.action_size)
            obs, reward, terminated, _, _ = gym_env.step(action)
            after = mjx.put_data(model, gym_env.data)
            env.physics_step = lambda data, ctrl, after=after: after
            state = env.step(state, jnp.asarray(action))
            np.testing.assert_array_equal(np.asarray(state.obs), obs.astype(np.float32))
            assert np.float32(state.reward) == np.float32(reward)
            assert bool(state.terminated) == terminated
            terminations += int(terminated)
    assert terminations > 0 or task == "hopper"  # random actions topple the pendulums


def test_reset_distributions():
    """Reset noise as in Gymnasium around the model's initial pose: pendulum qpos and qvel uniform
    +-0.01, double pendulum qpos uniform +-0.1 and qvel normal(0, 0.1), CartPole uniform +-0.05."""
    keys = jax.random.split(jax.random.key(0), 2000)

    def check_uniform(x: jax.Array, bound: float) -> None:
        x = np.asarray(x)
        assert 0.99 * bound < np.max(np.abs(x)) <= bound
        np.testing.assert_allclose(x.std(axis=0), bound / np.sqrt(3), rtol=0.06)

    data = jax.jit(jax.vmap(envs.make_task("inverted_pendulum", impl="jax").reset))(keys).data
    check_uniform(data.qpos, 0.01)
    check_uniform(data.qvel, 0.01)
    double = envs.make_task("inverted_double_pendulum", impl="jax")
    # Only the noise is under test: skip the reset's forward pass, which would cost a compilation.
    double.physics_state = lambda qpos, qvel, forward: MjxEnv.physics_state(double, qpos, qvel)
    data = jax.jit(jax.vmap(double.reset))(keys).data
    check_uniform(data.qpos, 0.1)
    np.testing.assert_allclose(np.asarray(data.qvel).std(axis=0), 0.1, rtol=0.06)
    assert np.max(np.abs(np.asarray(data.qvel))) > 0.25  # normal tails, not uniform
    check_uniform(jax.vmap(envs.make_task("cartpole").reset)(keys).obs, 0.05)


# --------------------------------------------------------------------------------------------
# CartPole against Gymnasium's CartPole-v1


def _balance(obs: np.ndarray) -> int:
    """A linear controller that keeps CartPole up for the whole 500 steps."""
    return int(np.dot([0.1, 0.5, 1.0, 1.0], obs) > 0)


def test_cartpole_matches_gymnasium():
    """Same initial state, same actions: the same reward, terminated and truncated at every step.

    In float64 jaxpg's state is set to Gymnasium's before every step, and each step agrees to
    rounding (1e-15; XLA and NumPy round a few operations differently) with float32 obs equal to
    their rounding. Rounding differences are not compared over whole episodes because the upright
    pole amplifies them e-fold every ~14 steps, even under a balancing controller (1e-10 after
    200 steps). Free-running in float32 (jaxpg's default, against Gymnasium's float64) a random
    episode stays within 1e-4. A balancing controller reaches the 500-step limit, which is
    ``truncated``; random actions end in ``terminated``, with reward 1 on the terminating step.
    """
    env = envs.make_task("cartpole")
    gym_env = gym.make("CartPole-v1")  # with its TimeLimit(500)
    rng = np.random.default_rng(0)
    outcomes = []
    for x64, policy in [(True, "random"), (True, "balance"), (False, "random")]:
        with jax.enable_x64(x64):
            step = jax.jit(env.step)
            state = env.reset(jax.random.key(len(outcomes)))
            gym_env.reset(seed=len(outcomes))
            gym_env.unwrapped.state = np.asarray(state.data.state, np.float64)
            obs = np.asarray(state.obs)
            length = 0
            while length < 600:
                length += 1
                action = int(rng.integers(2)) if policy == "random" else _balance(obs)
                if x64:
                    state = state.replace(data=CartPoleData(state=jnp.asarray(gym_env.unwrapped.state)))
                obs, reward, terminated, truncated, _ = gym_env.step(action)
                state = step(state, jnp.int32(action))
                if x64:
                    np.testing.assert_allclose(np.asarray(state.data.state), gym_env.unwrapped.state, atol=1e-15)
                    np.testing.assert_allclose(np.asarray(state.obs), obs, rtol=1e-7, atol=1e-15)
                else:
                    np.testing.assert_allclose(np.asarray(state.obs), obs, atol=1e-4)
                assert float(state.reward) == reward == 1.0
                assert (bool(state.terminated), bool(state.truncated)) == (terminated, truncated)
                if terminated or truncated:
                    break
            outcomes.append((policy, length, terminated, truncated))
    assert all(terminated for policy, _, terminated, _ in outcomes if policy == "random"), outcomes
    assert outcomes[1] == ("balance", 500, False, True), outcomes


# --------------------------------------------------------------------------------------------
# Batched rollouts against a step-by-step loop

ROLLOUT_ENVS = 3
ROLLOUT_STEPS = 40


def _random_act_fn(env: envs.Env):
    """``act_fn`` of uniform random in-range actions (the observation only gives the batch size)."""

    def act(params, obs, key):
        batch = obs.shape[0]
        if env.discrete:
            action = jax.random.randint(key, (batch,), 0, env.action_size)
        else:
            action = jax.random.uniform(key, (batch, env.action_size), minval=env.action_low, maxval=env.action_high)
        return action, jnp.zeros(batch)

    return act


@functools.cache
def _rollout_case(name: str, limit: int) -> dict:
    """``name`` with ``make``'s wrappers and time limit ``limit``, its ``AutoReset`` version, a
    random ``act_fn`` and the jitted single-env ``reset``/``step`` of the ``AutoReset`` version
    (until its first episode ends, an env with AutoReset steps exactly as one without, so the
    episodic loop uses them too and one single-env step is compiled per task)."""
    env = envs.make(name, max_episode_steps=limit, **({} if name == "cartpole" else {"impl": "jax"}))
    auto = AutoReset(env)
    return {
        "env": env,
        "auto": auto,
        "act": _random_act_fn(env),
        "reset": jax.jit(auto.reset),
        "step": jax.jit(auto.step),
    }


# Short time limits so that a 40-step rollout holds both terminations and truncations.
@pytest.fixture(scope="module", params=[("cartpole", 16), ("inverted_pendulum", 5)], ids=lambda p: p[0])
def rollout_case(request) -> dict:
    return _rollout_case(*request.param)


@pytest.fixture(scope="module")
def pendulum_case() -> dict:
    return _rollout_case("inverted_pendulum", 5)


def _python_loop(reset, step, act, reset_keys, step_keys):
    """Runs ``len(reset_keys)`` single envs one step at a time with the actions ``act`` draws for
    the batch from ``step_keys``; returns per-step ``[T, B]`` arrays of the named metrics."""
    states = [reset(k) for k in reset_keys]
    rows = []
    for key in step_keys:
        actions, _ = act(None, jnp.stack([s.obs for s in states]), key)
        states = [step(s, a) for s, a in zip(states, actions, strict=True)]
        rows.append(
            {
                "obs": np.stack([np.asarray(s.obs) for s in states]),
                "done": np.array([bool(s.done) for s in states]),
                **{k: np.array([float(s.metrics[k]) for s in states]) for k in ("episode_return", "episode_length")},
            }
        )
    return {k: np.stack([r[k] for r in rows]) for k in rows[0]}


def test_rollout_matches_python_loop(rollout_case):
    """``rollout`` (continuing, AutoReset) under jit + vmap: finite, deterministic for a key, and its
    episode statistics are those of a plain loop over single envs with the same keys."""
    auto, act = rollout_case["auto"], rollout_case["act"]
    k_reset, k_roll = jax.random.split(jax.random.key(7))

    @jax.jit
    def sample(k_reset, k_roll):
        env_state = rollout_lib.reset_batch(auto, k_reset, ROLLOUT_ENVS)
        return rollout_lib.rollout(auto, act, None, env_state, k_roll, ROLLOUT_STEPS)

    final, traj = sample(k_reset, k_roll)
    _, again = sample(k_reset, k_roll)
    assert all(jax.tree.leaves(jax.tree.map(lambda a, b: bool(jnp.array_equal(a, b)), traj, again)))
    _, other = sample(k_reset, jax.random.key(8))
    assert not np.array_equal(np.asarray(other.obs), np.asarray(traj.obs))
    assert bool(jnp.all(jnp.isfinite(traj.obs))) and bool(jnp.all(jnp.isfinite(traj.next_obs)))
    assert traj.obs.shape == (ROLLOUT_STEPS, ROLLOUT_ENVS, auto.observation_size)

    loop = _python_loop(
        rollout_case["reset"],
        rollout_case["step"],
        act,
        jax.random.split(k_reset, ROLLOUT_ENVS),
        jax.random.split(k_roll, ROLLOUT_STEPS),
    )
    done = np.asarray(traj.metrics["episode_done"]) > 0
    np.testing.assert_array_equal(done, loop["done"])
    np.testing.assert_array_equal(done, np.asarray(traj.dones))
    assert np.any(np.asarray(traj.terminated)) and np.any(np.asarray(traj.truncated))
    np.testing.assert_allclose(np.asarray(traj.obs[1:]), loop["obs"][:-1], atol=1e-5)
    for k in ("episode_return", "episode_length"):
        np.testing.assert_allclose(np.asarray(traj.metrics[k])[done], loop[k][done], rtol=1e-6)
    summary = rollout_lib.episode_summary(traj)
    assert int(summary["episodes"]) == done.sum()
    np.testing.assert_allclose(float(summary["episode_length"]), loop["episode_length"][done].mean(), rtol=1e-6)


def test_rollout_episodes_matches_python_loop(rollout_case):
    """``rollout_episodes`` (episodic, no reset) under jit + vmap: ``valid`` covers each env's first
    episode up to its end, whose statistics are those of a plain loop with the same keys."""
    env, act = rollout_case["env"], rollout_case["act"]
    key = jax.random.key(3)
    sample = jax.jit(lambda k: rollout_lib.rollout_episodes(env, act, None, k, ROLLOUT_ENVS, ROLLOUT_STEPS))
    traj = sample(key)
    again = sample(key)
    np.testing.assert_array_equal(np.asarray(traj.obs), np.asarray(again.obs))
    assert bool(jnp.all(jnp.isfinite(traj.obs)))

    k_reset, k_steps = jax.random.split(key)
    loop = _python_loop(
        rollout_case["reset"],
        rollout_case["step"],
        act,
        jax.random.split(k_reset, ROLLOUT_ENVS),
        jax.random.split(k_steps, ROLLOUT_STEPS),
    )
    first_end = np.argmax(loop["done"], axis=0)
    assert np.all(loop["done"][first_end, np.arange(ROLLOUT_ENVS)])  # every env ended an episode
    expected_valid = (np.arange(ROLLOUT_STEPS)[:, None] <= first_end[None, :]).astype(np.float32)
    np.testing.assert_array_equal(np.asarray(traj.valid), expected_valid)
    ended = np.asarray(traj.metrics["episode_done"]) * np.asarray(traj.valid) > 0
    np.testing.assert_array_equal(np.argmax(ended, axis=0), first_end)
    for k in ("episode_return", "episode_length"):
        np.testing.assert_allclose(np.asarray(traj.metrics[k])[ended], loop[k][ended], rtol=1e-6)


# --------------------------------------------------------------------------------------------
# Registry, wrappers and the non-finite guard


def test_make_unknown_name_lists_known_names():
    with pytest.raises(ValueError) as error:
        envs.make("nope")
    for name in envs.names():
        assert name in str(error.value)
    assert envs.names() == sorted(["cartpole", "hopper", "inverted_double_pendulum", "inverted_pendulum", "pong"])


def test_wrappers_forward_task_attributes():
    cartpole = AutoReset(envs.make("cartpole"))
    assert cartpole.discrete and cartpole.action_size == 2 and cartpole.max_episode_steps == 500
    assert cartpole.eval_metric_name == "steps"
    pendulum = envs.make("inverted_pendulum", impl="jax")
    assert (pendulum.action_low, pendulum.action_high) == (-3.0, 3.0) and not pendulum.discrete
    assert pendulum.dt == pytest.approx(0.04) and pendulum.max_episode_steps == 1000
    double = envs.make_task("inverted_double_pendulum", impl="jax")
    assert double.observation_size == 9 and double.dt == pytest.approx(0.05)
    assert double.eval_metric_name == "tip_height"


def test_clip_action_clips_to_the_task_range(pendulum_case):
    """``ClipAction`` uses the task's range ([-3, 3] for the pendulum, not the default [-1, 1])."""
    state = pendulum_case["reset"](jax.random.key(0))
    big, edge, inside = (pendulum_case["step"](state, jnp.full((1,), a, jnp.float32)) for a in (100.0, 3.0, 2.0))
    np.testing.assert_array_equal(np.asarray(big.obs), np.asarray(edge.obs))
    assert not np.array_equal(np.asarray(inside.obs), np.asarray(edge.obs))


def test_nonfinite_state_terminates_and_auto_resets(pendulum_case):
    """A NaN velocity ends the episode as ``terminated`` with a finite observation, zero reward and
    ``metrics["nonfinite"] == 1``; ``AutoReset`` then starts a fresh, finite episode."""
    state = pendulum_case["reset"](jax.random.key(0))
    state = pendulum_case["step"](state, jnp.zeros(1))
    bad = state.replace(data=state.data.replace(qvel=jnp.full_like(state.data.qvel, jnp.nan)))
    out = pendulum_case["step"](bad, jnp.zeros(1))
    assert bool(out.terminated) and not bool(out.truncated)
    assert float(out.metrics["nonfinite"]) == 1.0 and float(out.reward) == 0.0
    assert float(out.metrics["episode_done"]) == 1.0
    assert bool(jnp.all(jnp.isfinite(out.obs))) and bool(jnp.all(jnp.isfinite(out.info["final_obs"])))
    # AutoReset started a new episode from the key the old one carried.
    fresh = pendulum_case["reset"](bad.info["rng"])
    assert int(out.info["step"]) == 0
    assert bool(jnp.all(jnp.isfinite(out.data.qpos))) and bool(jnp.all(jnp.isfinite(out.data.qvel)))
    np.testing.assert_array_equal(np.asarray(out.obs), np.asarray(fresh.obs))
    assert float(pendulum_case["step"](out, jnp.zeros(1)).metrics["nonfinite"]) == 0.0


# --------------------------------------------------------------------------------------------
# MJX's warp implementation (MuJoCo Warp) against its jax implementation

WARP_ENVS = 2
WARP_STEPS = 20


@pytest.mark.skipif(not warp_available(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_warp_matches_jax_on_hopper():
    """Hopper (fast fidelity) under vmap with AutoReset: impl="warp" and impl="jax" give the same
    trajectory over 20 env steps, an automatic reset included, to 1e-4 in qpos (float32; found
    ~1e-6). Also checks that warp's contact buffer, shared by the batch, is sized for it."""
    import warp

    warp.config.quiet = True  # no line per kernel module
    trajectories = {}
    for impl in ("jax", "warp"):
        env = AutoReset(envs.make("hopper", impl=impl, max_episode_steps=12, max_batch=WARP_ENVS))
        if impl == "warp":
            assert env.unwrapped._data0._impl.naconmax == 16 * WARP_ENVS
        states = jax.vmap(env.reset)(jax.random.split(jax.random.key(0), WARP_ENVS))
        step = jax.jit(jax.vmap(env.step))
        qpos, done = [], []
        for key in jax.random.split(jax.random.key(1), WARP_STEPS):
            states = step(states, jax.random.uniform(key, (WARP_ENVS, 3), minval=-1.0, maxval=1.0))
            qpos.append(np.asarray(states.data.qpos))
            done.append(np.asarray(states.done))
        trajectories[impl] = np.stack(qpos), np.stack(done)
    (q_jax, d_jax), (q_warp, d_warp) = trajectories["jax"], trajectories["warp"]
    np.testing.assert_array_equal(d_jax, d_warp)
    assert d_jax.any(axis=0).all()  # every env was reset at least once (time limit 12)
    np.testing.assert_allclose(q_warp, q_jax, atol=1e-4)


@pytest.mark.skipif(not warp_available(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_warp_overflow_flags_are_counted_per_step_not_printed():
    """MuJoCo Warp's kernels print nothing (``warn_overflow`` is 0); its per-env overflow flags
    (solver iteration limit, full buffers) become ``metrics["physics_overflow"]``, cleared before
    every env step so that each step counts alone. MJX's JAX implementation always reports 0.
    (On the CPU Warp's solver does not raise the iteration flag; on an H100 the default Hopper
    counted 30-41 of 1.97 M env steps, BENCHMARKS.md section K.)"""
    env = envs.make("hopper", impl="warp", max_batch=WARP_ENVS)
    assert env.mjx_model.opt._impl.warn_overflow == 0
    state = jax.vmap(env.reset)(jax.random.split(jax.random.key(0), WARP_ENVS))
    overflow = state.data._impl.overflow
    flagged = state.replace(
        data=state.data.replace(_impl=state.data._impl.replace(overflow=jnp.full_like(overflow, 1024)))
    )
    read = jax.vmap(env.unwrapped._physics_overflow)
    np.testing.assert_array_equal(read(state.data), 0.0)
    np.testing.assert_array_equal(read(flagged.data), 1.0)
    stepped = jax.jit(jax.vmap(env.step))(flagged, jnp.zeros((WARP_ENVS, 3)))
    np.testing.assert_array_equal(stepped.metrics["physics_overflow"], 0.0)  # cleared, then not raised
    jax_env = envs.make("hopper", impl="jax")
    assert float(jax_env.step(jax_env.reset(jax.random.key(0)), jnp.ones(3)).metrics["physics_overflow"]) == 0.0


def test_importing_without_warp_prints_nothing():
    """MJX prints "Failed to import warp" when imported without warp-lang; jaxpg keeps it quiet."""
    code = (
        "import sys; sys.modules['warp'] = None\n"
        "import jaxpg.envs\n"
        "assert jaxpg.envs.make('inverted_pendulum').impl == 'jax'\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout == "" and "warp" not in proc.stderr.lower(), (proc.stdout, proc.stderr)


# --------------------------------------------------------------------------------------------
# Parity with Gymnasium in the "gymnasium" fidelity (float64 worker process)


def gymnasium_parity(task: str, seeds: int = PARITY_SEEDS, steps: int = PARITY_STEPS) -> dict:
    """Steps jaxpg's ``task`` (fidelity "gymnasium", MJX's jax impl) and Gymnasium's v5 env side by
    side from jaxpg's reset states with the same uniform random in-range actions, ``steps`` steps
    from each of ``seeds`` resets. Returns the largest differences in qpos, qvel, obs and reward
    within the episodes (up to and including the first termination) and after them (Gymnasium's
    MuJoCo envs keep stepping), with the ``terminated`` mismatches and the episode lengths.
    Meant for a process with ``JAX_ENABLE_X64=1``."""
    env = envs.make_task(task, fidelity="gymnasium", impl="jax")
    gym_env = gym.make(GYM_IDS[task]).unwrapped  # no TimeLimit
    reset, step = jax.jit(env.reset), jax.jit(env.step)
    quantities = ("qpos", "qvel", "obs", "reward")
    result = {"reset_obs": 0.0, "episode_lengths": [], "episode_mismatches": 0, "after_mismatches": 0}
    result |= {f"{part}_{q}": 0.0 for part in ("episode", "after") for q in quantities}

    def note(name: str, a: np.ndarray, b: np.ndarray) -> None:
        result[name] = max(result[name], float(np.max(np.abs(np.asarray(a, np.float64) - b))))

    for seed in range(seeds):
        state = reset(jax.random.key(seed))
        gym_env.reset(seed=seed)
        gym_env.set_state(np.asarray(state.data.qpos, np.float64), np.asarray(state.data.qvel, np.float64))
        note("reset_obs", state.obs, gym_env._get_obs())
        rng = np.random.default_rng(seed)
        part = "episode"
        for t in range(steps):
            action = rng.uniform(env.action_low, env.action_high, env.action_size)
            state = step(state, jnp.asarray(action))
            obs, reward, terminated, _, _ = gym_env.step(action)
            for name, mine, theirs in zip(
                quantities,
                (state.data.qpos, state.data.qvel, state.obs, state.reward),
                (gym_env.data.qpos, gym_env.data.qvel, obs, np.float64(reward)),
                strict=True,
            ):
                note(f"{part}_{name}", mine, theirs)
            result[f"{part}_mismatches"] += int(bool(state.terminated) != terminated)
            if terminated and part == "episode":
                result["episode_lengths"].append(t + 1)
                part = "after"
    return result


@pytest.fixture(scope="module", autouse=True)
def parity_worker(request: pytest.FixtureRequest):
    """Starts the float64 parity worker at the beginning of the module when a parity test is
    selected, so that its compilation overlaps with the other tests."""
    tasks = sorted(
        {
            item.callspec.params["task"]
            for item in request.session.items
            if item.name.startswith("test_gymnasium_parity")
        }
    )
    if not tasks:
        yield None
        return
    out = tempfile.TemporaryFile("w+")
    err = tempfile.TemporaryFile("w+")
    proc = subprocess.Popen(
        [sys.executable, __file__, *tasks],
        env={**os.environ, "JAX_ENABLE_X64": "1"},
        stdout=out,
        stderr=err,
        text=True,
    )
    yield proc, out, err
    if proc.poll() is None:
        proc.kill()
        proc.wait()
    out.close()
    err.close()


@pytest.fixture(scope="module")
def parity_results(parity_worker) -> dict:
    proc, out, err = parity_worker
    proc.wait(timeout=900)
    out.seek(0)
    err.seek(0)
    assert proc.returncode == 0, err.read()[-4000:]
    return json.loads(out.read().strip().splitlines()[-1])


@pytest.mark.parametrize("task", list(GYM_IDS))
def test_gymnasium_parity(task, parity_results):
    """jaxpg's MJX task in ``fidelity="gymnasium"`` against Gymnasium's v5 env, step by step.

    Run in float64 (``JAX_ENABLE_X64=1``, in a subprocess started with the module). In float32, MJX
    against MuJoCo's float64 stays close (Hopper's obs within 5e-5 over 150 random steps) but only
    loose tolerances would hold. In float64 MJX repeats MuJoCo's RK4 and forward pass to rounding:
    over 4 resets x 60 random in-range actions, qpos and qvel agree to ~1e-14 for every step of
    every episode (up to its termination: Hopper 14-26 steps, the pendulums 3-7; tolerance 1e-9),
    and obs and reward to their float32 rounding (1e-5 absolute, obs up to 10 in magnitude).
    Past the termination the falling hopper lies in contact with the floor and the poles hit their
    joint or rail limits: there MuJoCo's and MJX's iterative constraint solvers stop at different
    iterations within their tolerance (1e-8), which shows as a one-step jump to 1e-10..1e-8,
    then the chaotic fallen hopper amplifies it (up to 2e-5 in qpos after 100 steps); that part
    is held to 1e-3, enough to catch any difference in the model or the step semantics.
    """
    r = parity_results[task]
    assert len(r["episode_lengths"]) == PARITY_SEEDS, r  # every episode ended within the horizon
    assert r["episode_mismatches"] == 0 and r["after_mismatches"] == 0, r
    assert r["episode_qpos"] < 1e-9 and r["episode_qvel"] < 1e-9, r
    assert r["reset_obs"] < 1e-6 and r["episode_obs"] < 1e-5 and r["episode_reward"] < 1e-5, r
    assert r["after_qpos"] < 1e-3 and r["after_qvel"] < 1e-2 and r["after_obs"] < 1e-2, r


if __name__ == "__main__":
    print(json.dumps({task: gymnasium_parity(task) for task in sys.argv[1:]}))
