"""Tests of the jaxpg tasks and wrappers: Gymnasium parity, batched rollouts, guards, warp vs jax.

The reference is Gymnasium itself (CPU MuJoCo for the MJX tasks, NumPy for CartPole), driven from
the same states with the same actions. Compiled functions are shared through module-scoped fixtures
and the float64 parity run overlaps with the rest in a subprocess, to keep the file at a few minutes
on two CPU cores.

Run as a script (``JAX_ENABLE_X64=1 python tests/test_envs.py TASK ...``) this file is the worker
of ``test_gymnasium_parity`` and prints its findings as JSON.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import inspect
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable

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
from jaxpg.envs.mjx_env import (
    FAST_LS_ITERATIONS,
    FAST_SOLVER_ITERATIONS,
    INTEGRATION_STATE,
    MjxEnv,
    warp_available,
)

# The MuJoCo tasks and the ids of the Gymnasium envs they reproduce (the package's map, checked
# against Gymnasium's registry by test_every_gymnasium_counterpart_is_in_gymnasiums_registry).
GYM_IDS = {
    task: gym_id
    for task, (gym_id, _) in envs.GYMNASIUM_COUNTERPARTS.items()
    if issubclass(envs.task_class(task), MjxEnv)
}
# Tasks that never terminate (Gymnasium's step always returns terminated False): their float64
# parity run is one whole episode to the time limit under random actions (``episode_parity``, checked
# by ``test_gymnasium_parity_whole_episode``) in place of the termination checks of the others.
WITHOUT_TERMINATION = ("half_cheetah", "swimmer", "reacher", "pusher")
# Tasks whose MJX contact frames are not MuJoCo's (capsules on the floor, see jaxpg/envs/ant.py), so
# that their trajectories part from Gymnasium's at the first such contact: their float64 parity run
# is ``contact_frame_parity`` (checked by test_gymnasium_parity_contact_frames) in place of the others.
CONTACT_FRAME_TASKS = ("ant",)
# Humanoid's two tasks: their float64 parity run is ``humanoid_parity``, checked by their own tests
# (test_gymnasium_parity_humanoid, test_gymnasium_parity_humanoid_standup). HumanoidStandup never
# terminates, but its body parts from Gymnasium's within an episode (see its test).
HUMANOID_TASKS = ("humanoid", "humanoid_standup")
NEVER_TERMINATING = (*WITHOUT_TERMINATION, "humanoid_standup")
TERMINATING = [task for task in GYM_IDS if task not in NEVER_TERMINATING + CONTACT_FRAME_TASKS + HUMANOID_TASKS]
# Terminating tasks without a cheap controller that keeps them alive to the time limit (a PD
# controller on Walker2d's joints, with or without feedback on the torso angle, falls in 50-350
# steps): their time limit is checked a step before a random episode terminates
# (test_gymnasium_parity_truncation_before_termination) instead of over a full episode.
WITHOUT_STABILISING_POLICY = ("walker2d", "humanoid")
PARITY_SEEDS = 4
PARITY_STEPS = 60  # per seed; stepping goes on after termination, as Gymnasium's MuJoCo envs allow
PARITY_STEPS_FOR_TASK = {"walker2d": 100}  # its random episodes of seeds 0-3 last 14-63 steps
FULL_EPISODE_NOISE = 0.2  # of the action range, added to the stabilising controller in the full episodes


def make_gymnasium(task: str, **kwargs) -> gym.Env:
    """``gymnasium.make`` of ``task``'s Gymnasium v5 env, without the warning MuJoCo's compiler gives
    for Gymnasium's HalfCheetah model (its deprecated ``settotalmass``), which MuJoCo also appends to
    a ``MUJOCO_LOG.TXT`` in the working directory. Other warnings are raised as Python warnings."""

    def warn(message: str) -> None:
        if "settotalmass" not in message:
            warnings.warn(f"MuJoCo: {message}", stacklevel=2)

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warn)
    try:
        env = gym.make(GYM_IDS[task], **kwargs)
    finally:
        mujoco.set_mju_user_warning(previous)
    if env.unwrapped.model.opt.solver == mujoco.mjtSolver.mjSOL_PGS:
        # Humanoid's model: MJX has no PGS and jaxpg's load_model gives it Newton; so does the reference
        # (test_humanoid_newton_in_place_of_pgs measures what that changes against Gymnasium's own PGS).
        env.unwrapped.model.opt.solver = mujoco.mjtSolver.mjSOL_NEWTON
    return env


def test_every_gymnasium_counterpart_is_in_gymnasiums_registry():
    """``envs.GYMNASIUM_COUNTERPARTS`` against Gymnasium itself: each id is an env of Gymnasium's
    registry whose step limit is the one the map gives, which is also the task's default
    ``max_episode_steps``."""
    for task, (gym_id, limit) in envs.GYMNASIUM_COUNTERPARTS.items():
        assert gym_id in gym.registry, (task, gym_id)
        assert gym.spec(gym_id).max_episode_steps == limit, (task, gym_id)
        assert inspect.signature(envs.task_class(task)).parameters["max_episode_steps"].default == limit, task


# --------------------------------------------------------------------------------------------
# "fast" fidelity: same observation and reward functions as Gymnasium's, from the same MuJoCo data


def poison_unselected(env: MjxEnv, data: mjx.Data) -> mjx.Data:
    """``data`` with NaN in every float field, public or MJX's own (``_impl``), that
    ``env.select_physics`` does not select: what a task may not read before its physics step."""
    kept = set(INTEGRATION_STATE + env.derived_fields_read)

    def poisoned(part: object) -> dict:
        fields = [f.name for f in dataclasses.fields(part) if f.name != "_impl" and f.name not in kept]
        values = {name: getattr(part, name) for name in fields}
        return {
            name: jnp.full_like(v, jnp.nan)
            for name, v in values.items()
            if isinstance(v, jax.Array | np.ndarray) and jnp.issubdtype(v.dtype, jnp.floating)
        }

    return data.replace(**poisoned(data), _impl=data._impl.replace(**poisoned(data._impl)))


@pytest.mark.parametrize("task", list(GYM_IDS))
def test_fast_fidelity_observation_and_reward_match_gymnasium(task):
    """In ``fidelity="fast"`` jaxpg's physics differs from Gymnasium's (Euler, short solve) but what
    it reads from the physics must not: Gymnasium's env, switched to the same solver settings,
    resets and steps on the CPU, jaxpg's reset and step are fed the resulting ``MjData`` in place
    of their own physics, and obs, reward and ``terminated`` must be those of Gymnasium, exactly
    after the float32 cast (computed in float64, as Gymnasium does). Each step gets its state with
    NaN in every derived field an automatic reset does not select (``poison_unselected``), so a
    task that reads one before its physics step without declaring it fails here."""
    env = envs.make_task(task, fidelity="fast", impl="jax")
    gym_env = make_gymnasium(task).unwrapped
    model = gym_env.model
    model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    model.opt.iterations = FAST_SOLVER_ITERATIONS
    model.opt.ls_iterations = FAST_LS_ITERATIONS
    assert model.opt.integrator == env.mj_model.opt.integrator  # same settings as jaxpg's "fast"

    def gym_physics_state(qpos: jax.Array, qvel: jax.Array, **derived: bool) -> mjx.Data:
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
            obs, reward, terminated, _, info = gym_env.step(action)
            after = mjx.put_data(model, gym_env.data)
            env.physics_step = lambda data, ctrl, after=after: after
            state = env.step(state.replace(data=poison_unselected(env, state.data)), jnp.asarray(action))
            np.testing.assert_array_equal(np.asarray(state.obs), obs.astype(np.float32))
            assert np.float32(state.reward) == np.float32(reward)
            assert bool(state.terminated) == terminated
            terminations += int(terminated)
            if task in INFO_KEYS:  # Gymnasium's info terms, to float32 rounding (norms may round apart)
                assert sorted(k for k in info if k in state.metrics) == INFO_KEYS[task]
                mine = np.float32([state.metrics[k] for k in INFO_KEYS[task]])
                theirs = np.float32([info[k] for k in INFO_KEYS[task]])
                np.testing.assert_allclose(mine, theirs, rtol=2**-23, atol=1e-30)
    if task in NEVER_TERMINATING:
        assert terminations == 0
    else:
        # random actions topple the pendulums; the others outlive these 25 steps
        assert terminations > 0 or task in ("hopper", "walker2d", "ant", "humanoid")


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


def test_hopper_reset_distribution_matches_gymnasium():
    """Hopper's reset noise against Gymnasium's ``Hopper-v5``: the same initial pose and
    ``reset_noise_scale`` s, and 2000 resets of each (jaxpg's keys, Gymnasium's seeded resets) give
    every coordinate of ``(qpos - init_qpos, qvel)`` the moments and shape of uniform(-s, s).

    Tolerances from the sample size n, each at 5 standard errors (or a false-alarm rate of ~1e-5):
    mean within 5 s / sqrt(3 n), std within 5 / sqrt(5 n) relative (the sample std of a uniform
    has relative standard error 1 / sqrt(5 n)), Kolmogorov-Smirnov distance to the uniform CDF
    below 2.47 / sqrt(n); the samples stay within s (plus float32 rounding of qpos ~1.25) and
    reach past 0.99 s on both sides (missed with probability 0.99^n ~ 2e-9). A normal
    distribution of the same std breaks the bound, a wrong scale the std, noise on qpos or on
    qvel only the std of the other."""
    n = 2000
    gym_env = gym.make("Hopper-v5").unwrapped
    scale = gym_env._reset_noise_scale
    env = envs.make_task("hopper", impl="jax")
    assert env.reset_noise_scale == scale == 5e-3
    np.testing.assert_array_equal(np.asarray(env.init_qpos), gym_env.init_qpos.astype(np.float32))
    np.testing.assert_array_equal(np.asarray(env.init_qvel), gym_env.init_qvel)

    data = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), n)).data
    init = np.asarray(env.init_qpos, np.float64)
    mine = np.concatenate([np.asarray(data.qpos, np.float64) - init, np.asarray(data.qvel, np.float64)], axis=1)
    theirs = []
    for seed in range(n):
        gym_env.reset(seed=seed)
        theirs.append(np.concatenate([gym_env.data.qpos - gym_env.init_qpos, gym_env.data.qvel]))
    uniform_cdf = (np.arange(1, n + 1) - 0.5) / n  # at the sorted samples, against (x + s) / 2s
    for name, noise in (("jaxpg", mine), ("gymnasium", np.stack(theirs))):
        assert noise.shape == (n, env.nq + env.nv), name
        assert np.all(np.abs(noise) <= scale + 1e-6), (name, np.abs(noise).max(axis=0))
        assert np.all(noise.max(axis=0) > 0.99 * scale) and np.all(noise.min(axis=0) < -0.99 * scale), name
        assert np.all(np.abs(noise.mean(axis=0)) < 5 * scale / np.sqrt(3 * n)), (name, noise.mean(axis=0))
        np.testing.assert_allclose(noise.std(axis=0), scale / np.sqrt(3), rtol=5 / np.sqrt(5 * n), err_msg=name)
        ks = np.abs((np.sort(noise, axis=0) + scale) / (2 * scale) - uniform_cdf[:, None]).max(axis=0) + 0.5 / n
        assert np.all(ks < 2.47 / np.sqrt(n)), (name, ks)


# Tasks whose MJCF asset is Gymnasium's v5 model to the bit (test_model_matches_gymnasium), and whose
# reset distribution is compared with Gymnasium's by samples (test_reset_distribution_matches_gymnasium).
EXACT_MODEL_TASKS = ("half_cheetah", "swimmer", "walker2d", "reacher", "ant", "humanoid", "humanoid_standup", "pusher")
RESET_SAMPLES = 2000


@pytest.mark.parametrize("task", EXACT_MODEL_TASKS)
def test_model_matches_gymnasium(task):
    """jaxpg's asset, compiled in fidelity "gymnasium", is Gymnasium's v5 model: every numeric array
    of the ``MjModel`` (geometry, masses and inertias, joints, actuators, contact and solver
    parameters, the constants MuJoCo derives from them) and every physics option equal to the bit.
    Only the name tables may differ (jaxpg names its models ``jaxpg_<task>``). The "fast" fidelity
    differs from it in the integrator and solver iterations alone."""
    reference = make_gymnasium(task).unwrapped.model
    for fidelity in ("gymnasium", "fast"):
        model = envs.make_task(task, fidelity=fidelity, impl="jax").mj_model
        arrays = [k for k in dir(reference) if not k.startswith("_") and isinstance(getattr(reference, k), np.ndarray)]
        assert len(arrays) > 100, arrays  # the model's arrays, not an empty list
        differ = [
            k
            for k in arrays
            if not k.startswith("name") and not np.array_equal(getattr(model, k), getattr(reference, k), equal_nan=True)
        ]
        options = [k for k in dir(reference.opt) if not k.startswith("_") and not callable(getattr(reference.opt, k))]
        differ += [f"opt.{k}" for k in options if not np.array_equal(getattr(model.opt, k), getattr(reference.opt, k))]
        if fidelity == "gymnasium":
            assert differ == [], differ
        else:
            assert set(differ) <= {"opt.integrator", "opt.iterations", "opt.ls_iterations"}, differ
            assert (model.opt.iterations, model.opt.ls_iterations) == (FAST_SOLVER_ITERATIONS, FAST_LS_ITERATIONS)


@pytest.mark.parametrize("task", EXACT_MODEL_TASKS)
def test_reset_distribution_matches_gymnasium(task):
    """``RESET_SAMPLES`` resets of jaxpg's task (from keys) against as many of Gymnasium's v5 env
    (seeded): the same initial pose, and every coordinate of ``(qpos - init_qpos, qvel)`` drawn from
    the same distribution: per coordinate, a two-sample Kolmogorov-Smirnov test (shape) and the
    Brown-Forsythe test (spread), each with p > 1e-4. Both sample sets are fixed by their seeds, so
    the outcome is deterministic; at 2000 samples a side the threshold accepts a KS distance up to
    0.070 and a spread ratio within about 10% (4 standard errors), which a noise scale 20% off,
    uniform noise in place of normal (KS distance >= 0.16) or noise on the wrong coordinates exceed.
    Coordinates that Gymnasium leaves without noise must be exactly that constant in jaxpg."""
    from scipy import stats

    gym_env = make_gymnasium(task).unwrapped
    env = envs.make_task(task, fidelity="gymnasium", impl="jax")
    np.testing.assert_array_equal(np.asarray(env.init_qpos), gym_env.init_qpos.astype(np.float32))
    np.testing.assert_array_equal(np.asarray(env.init_qvel), gym_env.init_qvel)
    # Only the noise is under test: skip a reset's forward pass, which would cost a compilation.
    env.physics_state = lambda qpos, qvel, **derived: MjxEnv.physics_state(env, qpos, qvel)
    data = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), RESET_SAMPLES)).data
    init = np.asarray(env.init_qpos, np.float64)
    mine = np.concatenate([np.asarray(data.qpos, np.float64) - init, np.asarray(data.qvel, np.float64)], axis=1)
    theirs = []
    for seed in range(RESET_SAMPLES):
        gym_env.reset(seed=seed)
        theirs.append(np.concatenate([gym_env.data.qpos - init, gym_env.data.qvel]))
    theirs = np.stack(theirs)
    for i in range(theirs.shape[1]):
        if np.all(theirs[:, i] == theirs[0, i]):
            np.testing.assert_array_equal(mine[:, i], theirs[0, i], err_msg=f"coordinate {i}")
        else:
            shape = stats.ks_2samp(mine[:, i], theirs[:, i])
            spread = stats.levene(mine[:, i], theirs[:, i], center="median")
            assert shape.pvalue > 1e-4 and spread.pvalue > 1e-4, (i, shape, spread)


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


def test_rollout_unrolled_gives_the_same_trajectory():
    """``rollout(..., unroll=k)`` runs k env steps per loop iteration (7 does not divide the
    horizon): the same transitions and final state as one step per iteration. On CartPole (time
    limit 16, so that episodes end and restart inside the loop): unrolling is the loop's business,
    not the env's, and an MJX step unrolled 7 times took about a minute to compile on two cores."""
    case = _rollout_case("cartpole", 16)
    auto, act = case["auto"], case["act"]
    env_state = rollout_lib.reset_batch(auto, jax.random.key(3), ROLLOUT_ENVS)
    outs = [
        jax.jit(lambda s, k, u=u: rollout_lib.rollout(auto, act, None, s, k, ROLLOUT_STEPS, unroll=u))(
            env_state, jax.random.key(4)
        )
        for u in (1, 7)
    ]
    assert np.any(np.asarray(outs[0][1].dones)), "the case should hold episode ends"

    def plain(x: jax.Array) -> np.ndarray:
        return np.asarray(jax.random.key_data(x) if jnp.issubdtype(x.dtype, jax.dtypes.prng_key) else x)

    for a, b in zip(jax.tree.leaves(outs[0]), jax.tree.leaves(outs[1]), strict=True):
        np.testing.assert_allclose(plain(a), plain(b), rtol=1e-6, atol=1e-6)


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


def _physics(state):
    return {"obs": state.obs, "qpos": state.data.qpos}


@pytest.mark.parametrize("jit", [True, False], ids=["jit", "nojit"])
def test_record_fn_reads_the_state_after_every_step(pendulum_case, jit):
    """``record_fn`` adds ``extras`` (``[T, B, ...]``, the state after each step) and changes
    nothing else; ``with_initial`` puts the reset states in front and ``last_valid`` picks each
    episode's last step, as NumPy indexing does."""
    env, auto, act = pendulum_case["env"], pendulum_case["auto"], pendulum_case["act"]
    key = jax.random.key(5)
    maybe_jit = jax.jit if jit else (lambda f, **kw: f)

    @functools.partial(maybe_jit, static_argnums=1)
    def episodic(key, record):
        reset_key, steps_key = jax.random.split(key)
        state = rollout_lib.reset_batch(env, reset_key, ROLLOUT_ENVS)
        traj = rollout_lib.rollout_episodes_from(env, act, None, state, steps_key, 12, _physics if record else None)
        return state, traj

    state, traj = episodic(key, True)
    plain = episodic(key, False)[1]
    assert plain.extras == {}
    assert all(jax.tree.leaves(jax.tree.map(jnp.array_equal, traj.replace(extras={}), plain)))
    assert traj.extras["qpos"].shape == (12, ROLLOUT_ENVS, 2)
    np.testing.assert_array_equal(traj.extras["obs"], traj.next_obs)  # no reset: the next observation
    states = rollout_lib.with_initial(_physics(state), traj.extras)
    np.testing.assert_array_equal(states["obs"][:-1], traj.obs)
    np.testing.assert_array_equal(states["qpos"][0], state.data.qpos)

    lengths = np.asarray(traj.valid).sum(axis=0).astype(int)
    assert np.all(lengths < 12)  # every episode ended (time limit 5)
    returns = np.asarray(traj.metrics["episode_return"])
    np.testing.assert_array_equal(
        rollout_lib.last_valid(traj, traj.metrics["episode_return"]), returns[lengths - 1, np.arange(ROLLOUT_ENVS)]
    )

    # Continuing sampling records the state the next step starts from (after an automatic reset).
    start = rollout_lib.reset_batch(auto, key, ROLLOUT_ENVS)
    _, cont = maybe_jit(lambda s, k: rollout_lib.rollout(auto, act, None, s, k, 12, _physics))(start, key)
    np.testing.assert_array_equal(cont.extras["obs"][:-1], cont.obs[1:])
    assert np.any(np.asarray(cont.dones)) and not np.array_equal(cont.extras["obs"], cont.next_obs)


@functools.cache
def _full_episodic_rollout(env: envs.Env, act: Callable, horizon: int) -> Callable:
    """The jitted full episodic rollout of ``horizon`` steps, compiled once per case and horizon
    (the three ``check_every`` values of horizon 40 check against the same program)."""
    return jax.jit(lambda s, k: rollout_lib.rollout_episodes_from(env, act, None, s, k, horizon))


@pytest.mark.parametrize("check_every, horizon", [(1, 40), (7, 40), (40, 40), (2, 3)])
def test_episode_totals_match_the_full_rollout_and_stop_early(rollout_case, check_every, horizon):
    """``episode_totals_from`` gives each episode's return, length and final task score as the
    full episodic rollout of ``horizon`` steps sums them, and stops stepping within
    ``check_every`` steps of the last episode's end (time limit 16 or 5: well before 40; at 3
    steps every episode is cut by the horizon, and the second chunk of 2 steps one past it)."""
    env, act = rollout_case["env"], rollout_case["act"]
    calls = []

    def counted_act(params, obs, key):
        jax.debug.callback(lambda: calls.append(1))
        return act(params, obs, key)

    reset_key, steps_key = jax.random.split(jax.random.key(11))
    state = rollout_lib.reset_batch(env, reset_key, ROLLOUT_ENVS)
    traj = _full_episodic_rollout(env, act, horizon)(state, steps_key)
    totals = jax.jit(lambda s, k: rollout_lib.episode_totals_from(env, counted_act, None, s, k, horizon, check_every))(
        state, steps_key
    )
    jax.effects_barrier()
    valid = np.asarray(traj.valid)
    np.testing.assert_allclose(totals["return"], np.sum(np.asarray(traj.rewards) * valid, axis=0), rtol=1e-5)
    np.testing.assert_array_equal(totals["length"], valid.sum(axis=0))
    np.testing.assert_array_equal(totals["task_score"], rollout_lib.last_valid(traj, traj.metrics["task_score"]))
    last_end = int(valid.sum(axis=0).max())
    assert last_end < horizon or horizon == 3
    chunk = min(check_every, horizon)
    assert len(calls) == min(-(-last_end // chunk) * chunk, -(-horizon // chunk) * chunk)


def test_evaluate_rollout_matches_a_python_loop_of_the_mean_policy(pendulum_case):
    """``jaxpg.run.evaluation.policy_episodes.play_episodes`` (mean-policy episodes with their physics states, through
    ``jaxpg.rollout``) against single envs stepped one at a time with the policy's mode."""
    from jaxpg.algos import npg
    from jaxpg.run.evaluation import policy_episodes

    env = pendulum_case["env"]
    ts = npg.init(jax.random.key(0), env, npg.Config(num_envs=4, horizon=16, value_batch_size=64, eval_envs=0))
    eps = policy_episodes.play_episodes(env, ts.policy, ts.params, ts.obs_stats, seed=3, num_episodes=2, horizon=8)

    reset_key, _ = jax.random.split(jax.random.PRNGKey(3))
    # A jitted reset, so that the step compiles once: an eager reset's state is partly uncommitted to a
    # device, and a jitted step fed it, then its own (committed) outputs, compiles twice.
    reset, step = jax.jit(env.reset), jax.jit(env.step)
    for i, k in enumerate(jax.random.split(reset_key, 2)):
        state, qpos, total, score = reset(k), [], 0.0, None
        qpos.append(np.asarray(state.data.qpos))
        while not bool(state.done):
            state = step(state, ts.policy.mode(ts.params, ts.obs_stats.normalize(state.obs[None]))[0])
            qpos.append(np.asarray(state.data.qpos))
            total, score = total + float(state.reward), float(state.metrics["task_score"])
        assert eps.lengths[i] == len(qpos) - 1
        np.testing.assert_allclose(eps.returns[i], total, rtol=1e-6)
        np.testing.assert_allclose(eps.task_score[i], score, rtol=1e-6)
        obs, ep_qpos, ep_qvel = eps.episode_states(i)
        np.testing.assert_allclose(ep_qpos, np.stack(qpos), atol=1e-5)
        assert obs.shape == (len(qpos), env.observation_size) and ep_qvel.shape == ep_qpos.shape


# --------------------------------------------------------------------------------------------
# Registry, wrappers and the non-finite guard


def test_make_unknown_name_lists_known_names():
    with pytest.raises(ValueError) as error:
        envs.make("nope")
    for name in envs.names():
        assert name in str(error.value)
    expected = ["atari_pong", "cartpole", "hopper", "inverted_double_pendulum", "inverted_pendulum", "pong"]
    expected += ["half_cheetah", "swimmer", "walker2d", "reacher", "pusher", "ant", "humanoid", "humanoid_standup"]
    assert envs.names() == sorted(expected)


# Humanoid and HumanoidStandup are left out of the command-line smoke run: their training programs
# took the longest (95-106 s each on two busy cores) and run the same code as the other tasks' on a
# larger model. They are planned from the command line instead (test_command_line_plans_a_task_run);
# Humanoid's step runs through Gymnasium's checker (test_gymnasium_api.py) and its reset state is
# checked against MuJoCo's (test_humanoid_reset_state_matches_mujocos_forward_pass).
SMOKE_TASKS = tuple(task for task in EXACT_MODEL_TASKS if task not in ("humanoid", "humanoid_standup"))


def check_gymnasium_id(task: str) -> None:
    """``task``'s Gymnasium id is the one jaxpg registers for it, with Gymnasium's time limit, and
    ``jaxpg.evaluate --gymnasium`` replays its policies in Gymnasium's env of that id."""
    from jaxpg.envs import gymnasium_api
    from jaxpg.run.evaluation import replay

    assert replay.gymnasium_counterpart(task) == GYM_IDS[task]
    gym_id = gymnasium_api.gymnasium_id(task)
    assert gym_id == f"jaxpg/{GYM_IDS[task]}"
    limit = envs.make_task(task, impl="jax").max_episode_steps
    assert gym.spec(gym_id).max_episode_steps == gym.spec(GYM_IDS[task]).max_episode_steps == limit


@pytest.mark.parametrize("task", SMOKE_TASKS)
def test_training_smoke_run_from_the_command_line(task, tmp_path):
    """Two NPG iterations of the task in the default "fast" fidelity from the command line (4 envs x
    16 steps, time limit 8 so that episodes end and restart inside the samples, no mean-policy
    evaluation): the run succeeds and logs both iterations with the samples they drew, the 8
    episodes that ended in each, finite returns and task scores, no non-finite step and no
    rejected update. The task is also the Gymnasium id jaxpg registers, with Gymnasium's limit
    (``check_gymnasium_id``)."""
    from jaxpg.run.command import main

    check_gymnasium_id(task)
    run_dir = tmp_path / "run"
    argv = ["--env", task, "--impl", "jax", "--num-envs", "4", "--horizon", "16", "--max-episode-steps", "8"]
    argv += ["--eval-envs", "0"]
    assert main.main([*argv, "--iterations", "2", "--no-progress", "--run-dir", str(run_dir)]) == 0
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    records = [r for r in records if "return_stochastic" in r]
    assert [r["env_steps"] for r in records] == [64, 128], records
    for r in records:
        assert r["nonfinite"] == 0 and not r.get("update_rejected") and r["episodes"] == 8, r
        assert np.isfinite(r["return_stochastic"]) and np.isfinite(r["task_score"]), r


@pytest.mark.parametrize("task", [task for task in EXACT_MODEL_TASKS if task not in SMOKE_TASKS])
def test_command_line_plans_a_task_run(task, tmp_path, monkeypatch):
    """The tasks left out of the smoke run, from the command line up to the compilation: ``--env``
    and the physics flags plan a run of the task (nothing compiled, nothing written); the task is
    also the Gymnasium id jaxpg registers, with Gymnasium's limit (``check_gymnasium_id``)."""
    from jaxpg.run.command import command_line, planning

    check_gymnasium_id(task)
    monkeypatch.chdir(tmp_path)
    argv = ["--env", task, "--impl", "jax", "--fidelity", "gymnasium", "--run-dir", "run"]
    plan = planning.plan(argv, command_line.Experiment())
    task_env = plan.env.unwrapped
    assert isinstance(task_env, envs.task_class(task)) and (task_env.fidelity, task_env.impl) == ("gymnasium", "jax")
    assert not (tmp_path / "run").exists()


def test_pusher_programs_are_compiled_with_the_legacy_cpu_emitters():
    """Pusher's deep arm makes XLA:CPU's fusion emitters exponentially slow on its kinematics
    (``jaxpg.envs.compile_options``): its programs on the CPU, and only its, are compiled with the
    legacy emitters, through its wrappers too (where XLA still has the option; XLA in jaxlib 0.11
    has not, and there Pusher compiles with the defaults); so compiled, its kinematic pass still
    agrees with MuJoCo's own (C, float64) on random arm poses, to float32 rounding of positions
    within a metre."""
    from jaxpg.envs import compile_options

    pusher = envs.make("pusher", impl="jax")
    known = compile_options._accepted(compile_options.LEGACY_CPU_EMITTERS)
    assert compile_options.compiler_options(pusher) == (compile_options.LEGACY_CPU_EMITTERS if known else ())
    for other in (envs.make("hopper", impl="jax"), envs.make("cartpole")):
        assert compile_options.compiler_options(other) == ()
    task = pusher.unwrapped
    qpos = np.asarray(task.init_qpos) + np.random.default_rng(0).uniform(-1.0, 1.0, (4, task.nq))
    data = jax.vmap(lambda q: task.physics_state(q, task.init_qvel))(jnp.asarray(qpos, jnp.float32))
    kinematics = compile_options.jit(jax.vmap(lambda d: mjx.kinematics(task.mjx_model, d)), pusher)
    xpos = np.asarray(kinematics(data).xpos)
    reference = mujoco.MjData(task.mj_model)
    for env_qpos, env_xpos in zip(qpos, xpos, strict=True):
        reference.qpos[:] = env_qpos
        mujoco.mj_kinematics(task.mj_model, reference)
        np.testing.assert_allclose(env_xpos, reference.xpos, atol=1e-5)


def test_wrappers_forward_task_attributes():
    cartpole = AutoReset(envs.make("cartpole"))
    assert cartpole.discrete and cartpole.action_size == 2 and cartpole.max_episode_steps == 500
    assert cartpole.task_score_name == "steps"
    pendulum = envs.make("inverted_pendulum", impl="jax")
    assert (pendulum.action_low, pendulum.action_high) == (-3.0, 3.0) and not pendulum.discrete
    assert pendulum.dt == pytest.approx(0.04) and pendulum.max_episode_steps == 1000
    double = envs.make_task("inverted_double_pendulum", impl="jax")
    assert double.observation_size == 9 and double.dt == pytest.approx(0.05)
    assert double.task_score_name == "tip_height"


def test_clip_action_clips_to_the_task_range(pendulum_case):
    """``ClipAction`` uses the task's range ([-3, 3] for the pendulum, not the default [-1, 1]): the
    control the task sets (``data.ctrl``, which MuJoCo's own clamp to ``ctrlrange`` leaves as set)
    is the clipped action."""
    state = pendulum_case["reset"](jax.random.key(0))
    big, edge, inside = (pendulum_case["step"](state, jnp.full((1,), a, jnp.float32)) for a in (100.0, 3.0, 2.0))
    assert float(big.data.ctrl[0]) == float(edge.data.ctrl[0]) == 3.0 and float(inside.data.ctrl[0]) == 2.0
    np.testing.assert_array_equal(np.asarray(big.obs), np.asarray(edge.obs))
    assert not np.array_equal(np.asarray(inside.obs), np.asarray(edge.obs))


def test_auto_reset_selecting_the_integration_state_gives_the_trajectory_of_selecting_all():
    """An MJX task's automatic reset selects only what the next step reads (``select_physics``):
    Hopper (contacts, a warm-started solver) with an episode limit of 3 steps gives, over 8 steps
    of 2 envs and 2 resets each, exactly the observations, rewards and ends of MJX's own selection
    of every field (``Data.where``)."""
    action_key = jax.random.key(3)
    # The reset does not select anything: one compiled reset starts both trajectories.
    start = jax.jit(jax.vmap(AutoReset(envs.make("hopper", impl="jax", max_episode_steps=3)).reset))(
        jax.random.split(jax.random.key(0), 2)
    )

    def trajectory(select_all: bool) -> list[np.ndarray]:
        env = envs.make("hopper", impl="jax", max_episode_steps=3)
        if select_all:
            env.unwrapped.select_physics = lambda pick_new, new, old: old.where(pick_new, new)
        step = jax.jit(jax.vmap(AutoReset(env).step))
        state = start
        outputs = []
        for key in jax.random.split(action_key, 8):
            state = step(state, jax.random.uniform(key, (2, env.action_size), minval=-1, maxval=1))
            outputs += [np.asarray(state.obs), np.asarray(state.reward), np.asarray(state.done)]
        return outputs

    selected, everything = trajectory(False), trajectory(True)
    assert sum(int(done.sum()) for done in selected[2::3]) == 2 * 2  # steps 3 and 6 of both envs
    for mine, theirs in zip(selected, everything, strict=True):
        np.testing.assert_array_equal(mine, theirs)


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


def test_programs_stepping_one_env_trace_its_physics_step_once(monkeypatch):
    """``MjxEnv.substep`` is one function object per env and model, so JAX traces the MJX step once
    for every program that steps the env (here: batches of 4 and 16 envs, a jitted rollout step and
    a jitted ``vmap``), and again, with the new model, once a task replaces its ``mjx_model``."""
    from jaxpg.envs import mjx_env

    env = envs.make_task("inverted_pendulum", impl="jax")
    traced = []
    real_step = mjx_env.mjx.step
    monkeypatch.setattr(mjx_env.mjx, "step", lambda model, data: (traced.append(model), real_step(model, data))[1])
    assert env.substep() is env.substep()
    keys = jax.random.split(jax.random.PRNGKey(0), 16)
    for batch in (4, 16):
        states = jax.vmap(env.reset)(keys[:batch])
        jax.jit(jax.vmap(env.step)).trace(states, jnp.zeros((batch, env.action_size)))
    assert len(traced) == 1 and traced[0] is env.mjx_model
    old_step = env.substep()
    env.mjx_model = env.mjx_model.replace(opt=env.mjx_model.opt.replace(timestep=0.01))
    assert env.substep() is not old_step
    jax.jit(jax.vmap(env.step)).trace(states, jnp.zeros((16, env.action_size)))
    assert len(traced) == 2 and traced[1] is env.mjx_model


@pytest.mark.skipif(not warp_available(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_warp_matches_jax_on_hopper():
    """Hopper (fast fidelity) under vmap with AutoReset: impl="warp" and impl="jax" give the same
    trajectory over 20 env steps, an automatic reset included, to 1e-4 in qpos (float32; found
    ~1e-6). Also checks that warp's contact buffer, shared by the batch, is sized for it."""
    import warp

    warp.config.quiet = True  # no line per kernel module
    trajectories = {}
    for impl in ("jax", "warp"):
        task = envs.make("hopper", impl=impl, max_episode_steps=12, max_batch=WARP_ENVS)
        env = AutoReset(task)
        if impl == "warp":
            assert env.unwrapped._data0._impl.naconmax == 16 * WARP_ENVS
        # A jitted reset, so that each impl's step compiles once (the reason is in
        # test_evaluate_rollout_matches_a_python_loop_of_the_mean_policy).
        states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), WARP_ENVS))
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
def test_warp_ant_computes_contact_forces():
    """Ant (fast fidelity) with impl="warp" observes the contact forces as impl="jax" does: MJX's
    ``rne_postconstraint`` is jax-only, so the warp model runs MuJoCo Warp's own (its option
    ``run_rne_postconstraint``) in the step's forward passes. Two envs, 12 random steps (the ants
    land within 2-4): the forces (``obs[27:]``, clipped to [-1, 1]) are nonzero at the same steps
    and agree to 1e-2 (measured 2.3e-3 over 30 steps, where the float32 trajectories of the two
    implementations have drifted ~1e-3 apart), and the contact cost follows them."""
    import warp

    warp.config.quiet = True
    forces, costs = {}, {}
    for impl in ("jax", "warp"):
        env = envs.make_task("ant", impl=impl, max_batch=WARP_ENVS)
        assert (impl == "warp") == bool(getattr(env.mjx_model.opt._impl, "run_rne_postconstraint", False))
        states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), WARP_ENVS))  # compiles one step
        step = jax.jit(jax.vmap(env.step))
        obs, cost = [], []
        for key in jax.random.split(jax.random.key(1), 12):
            states = step(states, jax.random.uniform(key, (WARP_ENVS, 8), minval=-1.0, maxval=1.0))
            obs.append(np.asarray(states.obs[:, 27:]))
            cost.append(np.asarray(states.metrics["reward_contact"]))
        forces[impl], costs[impl] = np.stack(obs), np.stack(cost)
    touching = np.abs(forces["jax"]).max(axis=2) > 0
    assert touching.any() and not touching.all(), touching
    np.testing.assert_array_equal(np.abs(forces["warp"]).max(axis=2) > 0, touching)
    np.testing.assert_allclose(forces["warp"], forces["jax"], atol=1e-2)
    np.testing.assert_allclose(costs["warp"], costs["jax"], atol=1e-4)


@pytest.mark.parametrize("impl", ["jax", "warp"])
def test_humanoid_reset_state_matches_mujocos_forward_pass(impl):
    """HumanoidStandup's reset state (lying on the floor, in contact) has what MuJoCo's forward pass
    gives at its ``qpos``/``qvel`` (Gymnasium's reset: ``set_state`` runs ``mj_forward``) in every
    field the observation, the centre of mass and Gymnasium's ``info`` read: ``xipos``,
    ``cinert``, ``cvel``, ``ten_length``, ``ten_velocity``; the contact forces ``cfrc_ext`` stay
    zero, as ``mj_forward`` leaves them. Float32 kinematics against MuJoCo's float64: 1e-5 of
    each quantity's scale."""
    if impl == "warp":
        if not warp_available():
            pytest.skip("warp-lang is not installed (pip install 'jaxpg[warp]')")
        import warp

        warp.config.quiet = True
    env = envs.make_task("humanoid_standup", impl=impl, max_batch=WARP_ENVS)
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.key(0), WARP_ENVS))
    assert np.all(np.asarray(states.obs)[:, -78:] == 0)  # cfrc_ext[1:]
    model, data = env.mj_model, mujoco.MjData(env.mj_model)
    for i in range(WARP_ENVS):
        data.qpos, data.qvel = np.asarray(states.data.qpos[i]), np.asarray(states.data.qvel[i])
        mujoco.mj_forward(model, data)
        assert data.ncon > 0 and np.abs(data.ten_velocity).max() > 0
        for name in ("xipos", "cinert", "cvel", "ten_length", "ten_velocity"):
            part = states.data if hasattr(states.data, name) else states.data._impl  # MJX keeps some in _impl
            theirs = getattr(data, name)
            mine = np.asarray(getattr(part, name)[i]).reshape(theirs.shape)
            np.testing.assert_allclose(mine, theirs, atol=1e-5 * max(1.0, np.abs(theirs).max()), err_msg=name)


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


@pytest.mark.skipif(not warp_available(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_warp_seeds_in_one_program_are_each_evaluated_as_alone():
    """Several seeds trained in one program (``--seeds``) with MuJoCo Warp: the mean-policy
    evaluation over the seed axis (``train.compiled_evaluate(..., seeds=True)``) gives each seed the
    return that evaluating it alone gives. Under a ``vmap`` over seeds the evaluation's loop,
    whose stopping condition is per seed, gave Warp's per-batch contact buffer a seed axis, and
    MJX's Warp step raised on it at the run's first evaluation."""
    from jaxpg import train
    from jaxpg.algos import npg

    env = envs.make("inverted_pendulum", impl="warp", max_batch=2 * WARP_ENVS)
    config = npg.Config(num_envs=WARP_ENVS, horizon=8, eval_envs=2, eval_horizon=40, value_batch_size=8)
    seeds = train.init_seeds(npg.init, [0, 1], env, config)
    together = train.compiled_evaluate(train.evaluate_state, True)(seeds)
    alone = [
        train.compiled_evaluate(train.evaluate_state, False)(npg.init(jax.random.PRNGKey(s), env, config))
        for s in (0, 1)
    ]
    for name, values in together.items():
        assert values.shape == (2,), name
        np.testing.assert_allclose(values, [float(a[name]) for a in alone], rtol=1e-6, err_msg=name)


@pytest.mark.skipif(not warp_available(), reason="warp-lang is not installed (pip install 'jaxpg[warp]')")
def test_warp_training_compiles_nothing_while_a_program_runs(monkeypatch):
    """With MuJoCo Warp, ``train.train`` compiles no program while another may be running: Warp
    captures its physics step into CUDA graphs during a run, and an XLA compilation on another
    thread meanwhile breaks the capture (on a GPU: CUDA error 901 or 904, which ended runs that
    shared a GPU). So the evaluation's program, compiled on a background thread, is ready before the
    first block runs, and a block of a new size (here the last, shorter one) compiles only after
    the blocks before it have finished. The order of events is recorded around ``train``'s calls."""
    from jaxpg import train
    from jaxpg.algos import npg

    events: list[str] = []
    original_block, original_compile = train.compiled_block, train._EarlyCompile._compile

    class RecordedBlock:
        """A compiled block that records its compilation and its calls."""

        def __init__(self, block, size):
            self.block, self.size = block, size

        def lower(self, *args):
            lowered = self.block.lower(*args)
            return type("Lowered", (), {"compile": lambda _: self.compile(lowered)})()

        def compile(self, lowered):
            events.append(f"compile {self.size}")
            return lowered.compile()

        def __call__(self, *args):
            events.append(f"run {self.size}")
            return self.block(*args)

    def recorded_compile(self, specs):
        original_compile(self, specs)
        events.append("evaluation compiled")

    def recorded_ready(x):
        events.append("ready")
        return original_ready(x)

    original_ready = jax.block_until_ready
    monkeypatch.setattr(
        train,
        "compiled_block",
        lambda update, size, seeds, *options: RecordedBlock(original_block(update, size, seeds, *options), size),
    )
    monkeypatch.setattr(train._EarlyCompile, "_compile", recorded_compile)
    monkeypatch.setattr(jax, "block_until_ready", recorded_ready)
    env = envs.make("inverted_pendulum", impl="warp", max_batch=2 * WARP_ENVS)
    config = npg.Config(num_envs=WARP_ENVS, horizon=8, eval_envs=2, eval_horizon=40, value_batch_size=8, eval_every=100)
    state = npg.init(jax.random.PRNGKey(0), env, config)
    train.train(npg.update, state, 3, block_size=2, final_eval=True)
    runs = [i for i, e in enumerate(events) if e.startswith("run")]
    assert [events[i] for i in runs] == ["run 2", "run 1"], events
    assert events.index("evaluation compiled") < runs[0], events
    assert events.index("compile 1") > events.index("ready", runs[0]), events


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


def _parity_env(task: str) -> tuple[envs.Env, Callable, Callable]:
    """The env a user gets from ``envs.make`` (``EpisodeStats(ClipAction(task))``) in fidelity
    "gymnasium" with MJX's jax impl, and its jitted ``reset`` and ``step``, shared by the parity runs."""
    env = envs.make(task, fidelity="gymnasium", impl="jax")
    return env, jax.jit(env.reset), jax.jit(env.step)


def gymnasium_parity(task: str, env, reset, step, seeds: int = PARITY_SEEDS, steps: int = PARITY_STEPS) -> dict:
    """Steps jaxpg's ``task`` (``env`` with its jitted ``reset`` and ``step``, see ``_parity_env``)
    and Gymnasium's v5 env side by side from jaxpg's reset states with the same uniform random
    in-range actions, ``steps`` steps from each of ``seeds`` resets. Returns the largest differences
    in qpos, qvel, obs and reward within the episodes (up to and including the first termination)
    and after them (Gymnasium's MuJoCo envs keep stepping), with the ``terminated`` mismatches and
    the episode lengths. Meant for a process with ``JAX_ENABLE_X64=1``."""
    gym_env = make_gymnasium(task).unwrapped  # no TimeLimit
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


def _lqr_gain(model: mujoco.MjModel, frame_skip: int) -> np.ndarray:
    """``K [nu, 2 nv]``: the discrete LQR gain (unit state and control costs) of one env step
    (``frame_skip`` MuJoCo steps) of ``model`` linearised about ``qpos = qvel = 0`` (the upright
    pole(s), a slide and hinges only, so that ``nq == nv``) by central differences."""
    data = mujoco.MjData(model)
    nq, n = model.nq, model.nq + model.nv

    def env_step(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        mujoco.mj_resetData(model, data)
        data.qpos[:], data.qvel[:], data.ctrl[:] = x[:nq], x[nq:], u
        mujoco.mj_step(model, data, frame_skip)
        return np.concatenate([data.qpos, data.qvel])

    def jacobian(f: Callable[[np.ndarray], np.ndarray], size: int, eps: float = 1e-6) -> np.ndarray:
        return np.stack([(f(eps * e) - f(-eps * e)) / (2 * eps) for e in np.eye(size)], axis=1)

    a = jacobian(lambda dx: env_step(dx, np.zeros(model.nu)), n)
    b = jacobian(lambda du: env_step(np.zeros(n), du), model.nu)
    p = np.eye(n)
    for _ in range(1000):  # Riccati iteration to the fixed point
        gain = np.linalg.solve(np.eye(model.nu) + b.T @ p @ b, b.T @ p @ a)
        p = np.eye(n) + a.T @ p @ (a - b @ gain)
    return gain


def stabilising_policy(
    task: str, model: mujoco.MjModel, frame_skip: int
) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """``(qpos, qvel) -> action`` (unclipped) that keeps ``task`` alive for its whole 1000-step
    episode, with room to spare under the ``FULL_EPISODE_NOISE`` added in ``time_limit_parity``.

    The pendulums: LQR on the state. Hopper: a PD controller holding the initial standing pose
    (gains 20 and 1 on the actuated joints' angles and velocities): the hopper stands on its foot,
    within its health bounds, up to the limit (with zero torques it falls in ~130 steps).
    Feedback on the float64 state rather than the float32 observation: with the same actions (the
    observations of both envs round to the same float32) their difference grows under the
    unstable open loop until the float32 rounding of the observations starts to differ, to ~1e-8
    in qpos; with feedback on the state it evolves under the stable closed loop and stays at
    float64 rounding."""
    if task == "hopper":
        return lambda qpos, qvel: -20.0 * qpos[3:] - 1.0 * qvel[3:]
    gain = _lqr_gain(model, frame_skip)
    return lambda qpos, qvel: -gain @ np.concatenate([qpos, qvel])


def time_limit_parity(task: str, env, reset, step, seed: int = 0) -> dict:
    """One full episode of jaxpg's ``task`` (``env`` from ``envs.make``, see ``_parity_env``) and of
    ``gymnasium.make(ID)`` with its TimeLimit, side by side from jaxpg's reset state under
    ``stabilising_policy`` plus uniform noise of ``FULL_EPISODE_NOISE`` times the action range
    (the same draws for both). Each env's action is computed from its own state, so that their
    difference evolves under the stable closed loop: it stays at rounding instead of growing as
    it would with one env's actions fed to the unstable open loop of the other.

    Returns the largest differences (qpos, qvel, obs, reward, action) over the episode, the
    ``(terminated, truncated)`` pairs of both at every step where either is set, the mismatches
    of jaxpg's flags against Gymnasium's under jaxpg's rule (see ``test_gymnasium_parity_to_time_limit``),
    the episode's length, Gymnasium's return and ``EpisodeStats``' metrics at jaxpg's last step.
    Meant for a process with ``JAX_ENABLE_X64=1``."""
    gym_env = make_gymnasium(task)  # with its TimeLimit(1000)
    base = gym_env.unwrapped
    policy = stabilising_policy(task, base.model, base.frame_skip)
    low, high = env.action_low, env.action_high
    state = reset(jax.random.key(seed))
    gym_env.reset(seed=seed)
    base.set_state(np.asarray(state.data.qpos, np.float64), np.asarray(state.data.qvel, np.float64))
    rng = np.random.default_rng(seed)
    result = {k: 0.0 for k in ("qpos", "qvel", "obs", "reward", "action")}
    result |= {"flags": [], "flag_mismatches": 0, "gym_return": 0.0}

    def note(name: str, a: np.ndarray, b: np.ndarray) -> None:
        result[name] = max(result[name], float(np.max(np.abs(np.asarray(a, np.float64) - b))))

    for t in range(1, 2 * env.max_episode_steps):
        noise = FULL_EPISODE_NOISE * rng.uniform(low, high, env.action_size)
        action = np.clip(policy(np.asarray(state.data.qpos), np.asarray(state.data.qvel)) + noise, low, high)
        gym_action = np.clip(policy(base.data.qpos, base.data.qvel) + noise, low, high)
        note("action", action, gym_action)
        state = step(state, jnp.asarray(action))
        gym_obs, reward, terminated, truncated, _ = gym_env.step(gym_action)
        result["gym_return"] += float(reward)
        for name, mine, theirs in (
            ("qpos", state.data.qpos, base.data.qpos),
            ("qvel", state.data.qvel, base.data.qvel),
            ("obs", state.obs, gym_obs),
            ("reward", state.reward, np.float64(reward)),
        ):
            note(name, mine, theirs)
        mine = (bool(state.terminated), bool(state.truncated))
        expected = (terminated, truncated and not terminated)  # jaxpg's rule: terminated wins
        result["flag_mismatches"] += int(mine != expected)
        if any(mine) or terminated or truncated:
            result["flags"].append([t, *mine, terminated, truncated])
        if bool(state.done) or terminated or truncated:
            break
    result["length"] = t
    result["metrics"] = {k: float(state.metrics[k]) for k in ("episode_return", "episode_length", "episode_done")}
    return result


def coincidence_parity(task: str, env, reset, step, length: int, seed: int = 0) -> dict:
    """The episode of ``seed`` under ``gymnasium_parity``'s random actions, which terminates at step
    ``length``, with the time limit at that same step: Gymnasium as ``gymnasium.make(ID,
    max_episode_steps=length)``, jaxpg with its step counter ``info["step"]`` started at
    ``max_episode_steps - length`` (where it stands ``length`` steps before the limit; the same
    as a time limit of ``length``, without compiling another step). Returns both envs' flags
    ``[t, terminated, truncated, gym terminated, gym truncated]`` at every step."""
    gym_env = make_gymnasium(task, max_episode_steps=length)
    state = reset(jax.random.key(seed))
    state = state.replace(info={**state.info, "step": jnp.asarray(env.max_episode_steps - length, jnp.int32)})
    gym_env.reset(seed=seed)
    gym_env.unwrapped.set_state(np.asarray(state.data.qpos, np.float64), np.asarray(state.data.qvel, np.float64))
    rng = np.random.default_rng(seed)
    flags = []
    for t in range(1, length + 1):
        action = rng.uniform(env.action_low, env.action_high, env.action_size)
        state = step(state, jnp.asarray(action))
        _, _, terminated, truncated, _ = gym_env.step(action)
        flags.append([t, bool(state.terminated), bool(state.truncated), terminated, truncated])
    return {"flags": flags}


# Free-running steps after which ``episode_parity`` sets jaxpg's physics state to Gymnasium's before
# every step; tasks not listed run free to the time limit (see test_gymnasium_parity_whole_episode).
RESYNC_AFTER = {"half_cheetah": 20}


def episode_parity(task: str, env, reset, step, seed: int = 0) -> dict:
    """One whole episode of jaxpg's ``task`` (``env`` from ``envs.make``, see ``_parity_env``) and of
    ``gymnasium.make(ID)`` with its TimeLimit, side by side from jaxpg's reset state with the same
    uniform random in-range actions, for a task that never terminates.

    Runs free for the first ``RESYNC_AFTER[task]`` steps (all of them for tasks not listed); after
    those, jaxpg's ``qpos``, ``qvel`` and ``qacc_warmstart`` (the constraint solver's starting
    point) are set to Gymnasium's before each step, so that each step is compared from the same
    state where chaos would amplify rounding over a whole episode. Returns the largest differences
    in qpos, qvel, obs, reward and the ``info`` terms that jaxpg's metrics share with Gymnasium's
    (``info``), separately for the free ("free_*") and the re-synced steps ("synced_*"), the
    largest free difference at each step (``free_qpos_by_step``), the reset observation's
    difference, the flags ``[t, terminated, truncated, gym terminated, gym truncated]`` wherever
    one is set, the episode's length, the ``info`` keys compared, Gymnasium's return with the bound
    on its float32 accumulation (``return_rounding``: 2^-24 times the sum of the running sums'
    magnitudes) and ``EpisodeStats``' metrics at the last step. Meant for ``JAX_ENABLE_X64=1``."""
    gym_env = make_gymnasium(task)  # with its TimeLimit
    base = gym_env.unwrapped
    resync_after = RESYNC_AFTER.get(task, env.max_episode_steps)
    state = reset(jax.random.key(seed))
    gym_env.reset(seed=seed)
    base.set_state(np.asarray(state.data.qpos, np.float64), np.asarray(state.data.qvel, np.float64))
    quantities = ("qpos", "qvel", "obs", "reward", "info")
    result = {f"{part}_{q}": 0.0 for part in ("free", "synced") for q in quantities}
    result |= {"reset_obs": float(np.max(np.abs(np.asarray(state.obs, np.float64) - base._get_obs())))}
    result |= {"free_qpos_by_step": [], "flags": [], "info_keys": [], "gym_return": 0.0, "return_rounding": 0.0}
    rng = np.random.default_rng(seed)

    def note(name: str, a: np.ndarray, b: np.ndarray) -> float:
        difference = float(np.max(np.abs(np.asarray(a, np.float64) - b)))
        result[name] = max(result[name], difference)
        return difference

    for t in range(1, 2 * env.max_episode_steps):
        action = rng.uniform(env.action_low, env.action_high, env.action_size)
        part = "free" if t <= resync_after else "synced"
        if part == "synced":
            data = state.data.replace(
                qpos=jnp.asarray(base.data.qpos), qvel=jnp.asarray(base.data.qvel),
                qacc_warmstart=jnp.asarray(base.data.qacc_warmstart),
            )  # fmt: skip
            state = state.replace(data=data)
        state = step(state, jnp.asarray(action))
        obs, reward, terminated, truncated, info = gym_env.step(action)
        qpos = note(f"{part}_qpos", state.data.qpos, base.data.qpos)
        if part == "free":
            result["free_qpos_by_step"].append(qpos)
        note(f"{part}_qvel", state.data.qvel, base.data.qvel)
        note(f"{part}_obs", state.obs, obs)
        note(f"{part}_reward", state.reward, np.float64(reward))
        shared = sorted(k for k in info if k in state.metrics)
        result["info_keys"] = shared
        note(f"{part}_info", np.array([state.metrics[k] for k in shared]), np.array([info[k] for k in shared]))
        result["gym_return"] += float(reward)
        result["return_rounding"] += 2.0**-24 * abs(result["gym_return"])
        flags = [bool(state.terminated), bool(state.truncated), terminated, truncated]
        if any(flags):
            result["flags"].append([t, *flags])
        if bool(state.done) or terminated or truncated:
            break
    result["length"] = t
    result["metrics"] = {k: float(state.metrics[k]) for k in ("episode_return", "episode_length", "episode_done")}
    return result


# ``contact_frame_parity``: seeds, steps of the env a user gets (its trajectories part from
# Gymnasium's within a few steps) and the steps of each frame-swapped episode held to rounding
# (chaos parts them later); see test_gymnasium_parity_contact_frames.
CONTACT_FRAME_SEEDS = 4
USER_ENV_STEPS = 12
CONTACT_FRAME_TIGHT_STEPS = 50


@contextlib.contextmanager
def mujoco_capsule_frames():
    """MJX's jax collider for capsule-plane contacts with MuJoCo's contact frame while in the
    context. JAX's caches of traced functions are cleared on entry and on exit (MJX's inner
    functions would otherwise reuse traces made with the other collider), so only what is both
    traced and run inside the context has it. MuJoCo aligns the first tangent with the capsule's
    axis projected on the plane (``mjc_PlaneCapsule``, then ``mju_makeFrame``); MJX does too
    only while that projection's length is at least 0.5 and takes a fixed world axis below. Here
    the fixed axis is kept only where the projection vanishes (a capsule exactly upright)."""
    from mujoco.mjx._src import collision_driver, collision_primitive
    from mujoco.mjx._src import math as mjx_math

    @collision_primitive.collider(ncon=2)
    def plane_capsule(plane, cap):
        n, axis = plane.mat[:, 2], cap.mat[:, 2]
        b, b_norm = mjx_math.normalize_with_norm(axis - n * jnp.dot(n, axis))
        fixed = jnp.where((-0.5 < n[1]) & (n[1] < 0.5), jnp.array([0.0, 1.0, 0.0]), jnp.array([0.0, 0.0, 1.0]))
        b = jnp.where(b_norm < 1e-10, fixed, b)
        frame = jnp.array([[n, b, jnp.cross(n, b)]])
        contacts = []
        for end in (cap.size[1] * axis, -cap.size[1] * axis):
            dist, pos = collision_primitive._plane_sphere(n, plane.pos, cap.pos + end, cap.size[0])
            contacts.append((dist[None], pos[None], frame))
        return jax.tree.map(lambda *x: jnp.concatenate(x), *contacts)

    key = (mujoco.mjtGeom.mjGEOM_PLANE, mujoco.mjtGeom.mjGEOM_CAPSULE)
    original = collision_driver._COLLISION_FUNC[key]
    jax.clear_caches()
    collision_driver._COLLISION_FUNC[key] = plane_capsule
    try:
        yield
    finally:
        collision_driver._COLLISION_FUNC[key] = original
        jax.clear_caches()


def side_by_side(task: str, env, reset, step, seed: int, steps: int) -> dict:
    """jaxpg's ``task`` (``env`` from ``envs.make`` with its jitted ``reset`` and ``step``) and
    ``gymnasium.make(ID)`` with its TimeLimit from jaxpg's reset state of ``seed`` under the same
    uniform random in-range actions, until either episode ends or ``steps`` steps. Returns the
    reset observation's difference, per-step largest differences (qpos, qvel, obs, reward, the
    ``info`` terms jaxpg's metrics share), the flags ``[t, terminated, truncated, gym terminated,
    gym truncated]`` wherever one is set, and the length. Meant for ``JAX_ENABLE_X64=1``."""
    gym_env = make_gymnasium(task)
    base = gym_env.unwrapped
    state = reset(jax.random.key(seed))
    gym_env.reset(seed=seed)
    base.set_state(np.asarray(state.data.qpos, np.float64), np.asarray(state.data.qvel, np.float64))
    quantities = ("qpos", "qvel", "obs", "reward", "info")
    result = {q: [] for q in quantities} | {"flags": []}
    result["reset_obs"] = float(np.max(np.abs(np.asarray(state.obs, np.float64) - base._get_obs())))
    rng = np.random.default_rng(seed)
    for t in range(1, steps + 1):
        action = rng.uniform(env.action_low, env.action_high, env.action_size)
        state = step(state, jnp.asarray(action))
        obs, reward, terminated, truncated, info = gym_env.step(action)
        shared = INFO_KEYS[task]
        for name, mine, theirs in (
            ("qpos", state.data.qpos, base.data.qpos),
            ("qvel", state.data.qvel, base.data.qvel),
            ("obs", state.obs, obs),
            ("reward", state.reward, np.float64(reward)),
            ("info", np.array([state.metrics[k] for k in shared]), np.array([info[k] for k in shared])),
        ):
            result[name].append(float(np.max(np.abs(np.asarray(mine, np.float64) - theirs))))
        flags = [bool(state.terminated), bool(state.truncated), terminated, truncated]
        if any(flags):
            result["flags"].append([t, *flags])
        if bool(state.done) or terminated or truncated:
            break
    result["length"] = t
    return result


def contact_frame_parity(task: str, env, reset, step) -> dict:
    """The float64 parity run of a task in ``CONTACT_FRAME_TASKS``: ``side_by_side`` for seeds
    0-3, ``USER_ENV_STEPS`` steps of the env a user gets ("user"), and whole episodes of the same
    env with ``mujoco_capsule_frames`` ("swapped", compiled separately), with ``coincidence_parity``
    of the swapped env at the termination step of seed 0's episode ("coincidence") and a step
    before it ("truncation")."""
    seeds = range(CONTACT_FRAME_SEEDS)
    result = {"user": [side_by_side(task, env, reset, step, seed, USER_ENV_STEPS) for seed in seeds]}
    with mujoco_capsule_frames():
        swapped = envs.make(task, fidelity="gymnasium", impl="jax")
        reset, step = jax.jit(swapped.reset), jax.jit(swapped.step)
        limit = swapped.max_episode_steps
        result["swapped"] = [side_by_side(task, swapped, reset, step, seed, 2 * limit) for seed in seeds]
        length = result["swapped"][0]["length"]
        result["coincidence"] = coincidence_parity(task, swapped, reset, step, length)
        result["truncation"] = coincidence_parity(task, swapped, reset, step, length - 1)
    return result


# Humanoid's observation in parts (qpos[2:], qvel, cinert[1:], cvel[1:], qfrc_actuator[6:], cfrc_ext[1:]).
HUMANOID_OBS_PARTS = {"qpos": 22, "qvel": 23, "cinert": 130, "cvel": 78, "qfrc_actuator": 17, "cfrc_ext": 78}
# Steps of ``humanoid_parity`` after each seed's "episode" part: Humanoid's episode ends with its
# termination (the humanoid falling to the floor); HumanoidStandup never terminates and is given an
# episode part of ``STANDUP_EPISODE_STEPS`` (see test_gymnasium_parity_humanoid_standup).
HUMANOID_STEPS_AFTER = {"humanoid": 10, "humanoid_standup": 50}
STANDUP_EPISODE_STEPS = 12


def humanoid_parity(task: str, env, reset, step, seeds: int = PARITY_SEEDS) -> dict:
    """``gymnasium_parity`` for Humanoid's two tasks: jaxpg's env (``_parity_env``) against
    Gymnasium's v5 env (its model's PGS switched to Newton, see ``make_gymnasium``) from jaxpg's
    reset states with the same uniform random in-range actions (the draws of ``gymnasium_parity``).
    Each seed runs an "episode" part and ``HUMANOID_STEPS_AFTER`` steps "after" it: Humanoid's
    episode ends with its termination, HumanoidStandup's, which never terminates, after
    ``STANDUP_EPISODE_STEPS`` (``episode_lengths``: the parts' lengths). Observations are compared
    relative to ``max(1, |obs|)`` (the contact forces ``cfrc_ext`` reach ~2e3, where float32 rounds at
    ~1e-4), with the absolute differences of each part of the observation within the episodes
    (``episode_parts``); also Gymnasium's ``info`` terms (``INFO_KEYS``) against jaxpg's metrics and
    the norms of jaxpg's reset quaternions (``reset_quaternion_norms``)."""
    gym_env = make_gymnasium(task).unwrapped  # no TimeLimit; Newton
    quantities = ("qpos", "qvel", "obs", "reward", "info")
    result = {"reset_obs": 0.0, "episode_lengths": [], "episode_mismatches": 0, "after_mismatches": 0}
    result |= {f"{part}_{q}": 0.0 for part in ("episode", "after") for q in quantities}
    result["episode_parts"] = {k: 0.0 for k in HUMANOID_OBS_PARTS}
    result["reset_quaternion_norms"] = []
    bounds = np.cumsum([0, *HUMANOID_OBS_PARTS.values()])
    keys = INFO_KEYS[task]

    def note(name: str, a: np.ndarray, b: np.ndarray, relative: bool = False) -> np.ndarray:
        difference = np.abs(np.asarray(a, np.float64) - b)
        if relative:
            difference /= np.maximum(1.0, np.abs(b))
        result[name] = max(result[name], float(np.max(difference)))
        return difference

    for seed in range(seeds):
        state = reset(jax.random.key(seed))
        gym_env.reset(seed=seed)
        gym_env.set_state(np.asarray(state.data.qpos, np.float64), np.asarray(state.data.qvel, np.float64))
        note("reset_obs", state.obs, gym_env._get_obs(), relative=True)
        result["reset_quaternion_norms"].append(float(np.linalg.norm(state.data.qpos[3:7])))
        rng = np.random.default_rng(seed)
        part, left = "episode", HUMANOID_STEPS_AFTER[task]
        for t in range(1, 200):  # random episodes last 17-37 steps; a longer one fails the test
            if task == "humanoid_standup" and part == "episode" and t > STANDUP_EPISODE_STEPS:
                result["episode_lengths"].append(STANDUP_EPISODE_STEPS)
                part = "after"
            action = rng.uniform(env.action_low, env.action_high, env.action_size)
            state = step(state, jnp.asarray(action))
            obs, reward, terminated, _, info = gym_env.step(action)
            note(f"{part}_qpos", state.data.qpos, gym_env.data.qpos)
            note(f"{part}_qvel", state.data.qvel, gym_env.data.qvel)
            note(f"{part}_obs", state.obs, obs, relative=True)
            note(f"{part}_reward", state.reward, np.float64(reward))
            note(f"{part}_info", np.array([state.metrics[k] for k in keys]), np.array([info[k] for k in keys]))
            if part == "episode":
                absolute = np.abs(np.asarray(state.obs, np.float64) - obs)
                for i, name in enumerate(HUMANOID_OBS_PARTS):
                    largest = float(absolute[bounds[i] : bounds[i + 1]].max())
                    result["episode_parts"][name] = max(result["episode_parts"][name], largest)
            result[f"{part}_mismatches"] += int(bool(state.terminated) != terminated)
            if part == "after":
                left -= 1
                if left == 0:
                    break
            elif terminated:
                result["episode_lengths"].append(t)
                part = "after"
    return result


def state_type_changes(env, reset, step) -> list[str]:
    """The leaves of the ``State`` whose type (shape, dtype, weak type) ``step`` changes from what
    ``reset`` gave, as ``"path: before -> after"``. Any such leaf makes a jitted ``step`` compile
    twice, once for the reset state and once for every later one (a float32 zero in a reset's
    metrics against the float64 the step computes with ``JAX_ENABLE_X64=1`` cost 18-27 s of
    compilation a task on two cores). Compiles ``reset`` and ``step`` for seed 0's reset state."""
    before = reset(jax.random.key(0))
    after = step(before, jnp.zeros(env.action_size))
    if jax.tree.structure(before) != jax.tree.structure(after):
        return [f"structure: {jax.tree.structure(before)} -> {jax.tree.structure(after)}"]
    leaves = zip(jax.tree_util.tree_leaves_with_path(before), jax.tree.leaves(after), strict=True)
    return [
        f"{jax.tree_util.keystr(path)}: {jax.typeof(a)} -> {jax.typeof(b)}"
        for (path, a), b in leaves
        if jax.typeof(a) != jax.typeof(b)  # the abstract value's equality includes the weak type ("~")
    ]


def parity_worker_main(tasks: list[str]) -> dict:
    """The float64 worker's findings for each of ``tasks``: ``gymnasium_parity`` ("random"),
    ``time_limit_parity`` ("time_limit") and ``coincidence_parity`` ("coincidence"), all on one
    compiled ``reset`` and ``step`` per task, with the CPU seconds of the first two ("cpu_seconds",
    the first with the compilation); ``episode_parity`` ("episode") alone for the tasks
    ``WITHOUT_TERMINATION``; for HumanoidStandup, which never terminates, ``humanoid_parity``
    ("random") and its time limit (``coincidence_parity``, "time_limit"); for every task,
    ``state_type_changes`` ("state_types_changed")."""
    results = {}
    for task in tasks:
        started = time.process_time()
        env, reset, step = _parity_env(task)
        results[task] = {"state_types_changed": state_type_changes(env, reset, step)}
        if task in CONTACT_FRAME_TASKS:
            results[task] |= contact_frame_parity(task, env, reset, step)
            results[task]["cpu_seconds"] = time.process_time() - started
            continue
        if task in WITHOUT_TERMINATION:
            results[task]["episode"] = episode_parity(task, env, reset, step)
            results[task]["cpu_seconds"] = {"episode": time.process_time() - started}
            continue
        if task in HUMANOID_TASKS:
            random = humanoid_parity(task, env, reset, step)
        else:
            random = gymnasium_parity(task, env, reset, step, steps=PARITY_STEPS_FOR_TASK.get(task, PARITY_STEPS))
        seconds = {"random": time.process_time() - started}
        if task == "humanoid_standup":  # never terminates: the time limit alone, at the episode part's end
            full = {"truncation": coincidence_parity(task, env, reset, step, STANDUP_EPISODE_STEPS)}
            results[task] |= {"random": random, "time_limit": full, "cpu_seconds": seconds}
            continue
        if task in WITHOUT_STABILISING_POLICY:
            full = {"truncation": coincidence_parity(task, env, reset, step, random["episode_lengths"][0] - 1)}
        else:
            full = time_limit_parity(task, env, reset, step)
        seconds["time_limit"] = time.process_time() - started - seconds["random"]
        coincidence = coincidence_parity(task, env, reset, step, random["episode_lengths"][0])
        results[task] |= {"random": random, "time_limit": full, "coincidence": coincidence, "cpu_seconds": seconds}
    return results


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
    # The worker imports the jaxpg under test (this process's), not one installed elsewhere.
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(envs.__file__))))
    path = os.pathsep.join(p for p in (root, os.environ.get("PYTHONPATH")) if p)
    proc = subprocess.Popen(
        [sys.executable, __file__, *tasks],
        env={**os.environ, "JAX_ENABLE_X64": "1", "PYTHONPATH": path},
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
def test_gymnasium_parity_step_keeps_the_reset_state_types(task, parity_results):
    """With ``JAX_ENABLE_X64=1`` (the float64 worker), ``step`` returns a ``State`` of the same
    structure and leaf types as ``reset``'s, so that a jitted step compiles once
    (``state_type_changes``). In float32 the two always agreed; in float64 the reset metrics of
    seven tasks were float32 zeros where the step computed float64, and every jitted step compiled
    twice."""
    assert parity_results[task]["state_types_changed"] == [], parity_results[task]["state_types_changed"]


@pytest.mark.parametrize("task", TERMINATING)
def test_gymnasium_parity(task, parity_results):
    """jaxpg's MJX task in ``fidelity="gymnasium"`` against Gymnasium's v5 env, step by step.

    Run in float64 (``JAX_ENABLE_X64=1``, in a subprocess started with the module). In float32, MJX
    against MuJoCo's float64 stays close (Hopper's obs within 5e-5 over 150 random steps) but only
    loose tolerances would hold. In float64 MJX repeats MuJoCo's RK4 and forward pass to rounding:
    over 4 resets x 60 random in-range actions, qpos and qvel agree to ~1e-14 for every step of
    every episode (up to its termination: Hopper 14-26 steps, the pendulums 3-7; tolerance 1e-9;
    more seeds find longer Hopper episodes, whose foot contact lets the solvers part: 9e-9 in 16),
    and obs and reward to their float32 rounding (1e-5 absolute, obs up to 10 in magnitude).
    Past the termination the falling hopper lies in contact with the floor and the poles hit their
    joint or rail limits: there MuJoCo's and MJX's iterative constraint solvers stop at different
    iterations within their tolerance (1e-8), which shows as a one-step jump to 1e-10..1e-8,
    then the chaotic fallen hopper amplifies it (up to 5e-5 in qpos and 3e-5 in reward after 100
    steps over 16 seeds; here, 4 seeds x 60 steps, the largest are 7e-9 in qpos, the pendulum on its
    rail limit, and 7e-7 in reward, the double pendulum's float32 rounding); qpos, qvel and obs are
    held to 1e-3..1e-2 there, enough to catch any difference in the model or the step semantics,
    and the reward to 1e-4: above what the amplification reached, below the smallest reward term
    that a wrong reward function would change (Hopper's control cost, ~1e-3).
    Walker2d (run 100 steps a seed: its episodes last 14-63): within and after its episodes qpos and
    qvel agreed to <= 5.8e-14 and 1.0e-12, obs and reward to their float32 rounding (8 seeds x 60
    steps measured; the fallen walker's contacts had not yet parted the solvers).
    """
    r = parity_results[task]["random"]
    assert len(r["episode_lengths"]) == PARITY_SEEDS, r  # every episode ended within the horizon
    assert r["episode_mismatches"] == 0 and r["after_mismatches"] == 0, r
    assert r["episode_qpos"] < 1e-9 and r["episode_qvel"] < 1e-9, r
    assert r["reset_obs"] < 1e-6 and r["episode_obs"] < 1e-5 and r["episode_reward"] < 1e-5, r
    assert r["after_qpos"] < 1e-3 and r["after_qvel"] < 1e-2 and r["after_obs"] < 1e-2, r
    assert r["after_reward"] < 1e-4, r


# Bounds on the largest differences over the full episode of seed 0 under the stabilising controller
# (measured maxima over seeds 0-3 in test_gymnasium_parity_to_time_limit's docstring): qpos, qvel
# and action in float64; obs and reward after jaxpg's float32 cast.
TIME_LIMIT_TOLERANCES = {
    "inverted_pendulum": {"qpos": 1e-12, "qvel": 1e-12, "action": 1e-12, "obs": 1e-6, "reward": 1e-6},
    "inverted_double_pendulum": {"qpos": 1e-12, "qvel": 1e-12, "action": 1e-12, "obs": 1e-6, "reward": 1e-5},
    "hopper": {"qpos": 1e-7, "qvel": 5e-6, "action": 5e-6, "obs": 5e-6, "reward": 5e-6},
}


@pytest.mark.parametrize("task", [task for task in TERMINATING if task not in WITHOUT_STABILISING_POLICY])
def test_gymnasium_parity_to_time_limit(task, parity_results):
    """A full 1000-step episode of the env a user gets (``envs.make(task, fidelity="gymnasium")``:
    ``EpisodeStats(ClipAction(task))``) against ``gymnasium.make(ID)`` with its TimeLimit, side by
    side from jaxpg's reset state, each under the same stabilising controller on its own state
    plus the same uniform noise of 20% of the action range (``time_limit_parity``).

    Both survive to the limit, with ``terminated`` and ``truncated`` False at steps 1-999 and,
    at step 1000, ``truncated`` True and ``terminated`` False in both; ``EpisodeStats`` reports the
    episode there (length 1000, return equal to the sum of Gymnasium's rewards up to float32
    accumulation: 1000 roundings of a running sum up to ~9400; measured up to 6e-7 relative,
    rtol 2e-5). Largest differences over the episode (measured on seeds 0-3; the test runs seed 0):
    the pendulums' qpos, qvel and actions stay at float64 rounding, <= 1.1e-14 (tolerance 1e-12):
    without contacts MJX repeats MuJoCo's steps to rounding and the closed loop damps the
    differences. The standing hopper's foot is in contact with the floor at every step, where the
    two constraint solvers stop at different iterations within their tolerance (1e-8, see
    ``test_gymnasium_parity``): seed 0 reaches 1.1e-9 in qpos, 6.0e-8 in qvel and 6.4e-8 in the
    actions (seeds 1-3: <= 2e-11 and 1.6e-9; tolerances 1e-7, 5e-6 and 5e-6). obs and reward agree
    to their float32 rounding (obs <= 1.2e-7, reward <= 4.8e-7; ``TIME_LIMIT_TOLERANCES``: 1e-6 to
    1e-5 by magnitude).

    Where termination and the time limit coincide the two differ, by design: Gymnasium's
    TimeLimit sets ``truncated`` whatever ``terminated`` says, jaxpg's flags are exclusive
    (``Env.step``: a step that both ends the task and reaches the limit is ``terminated`` only,
    the value of its next state being zero). ``done`` is the same and a learner that bootstraps
    exactly where jaxpg says ``truncated`` treats the step as Gymnasium's ``terminated`` says it
    should. ``coincidence_parity`` checks that rule on the random episode of seed 0 with the time
    limit at its termination step: Gymnasium (True, True), jaxpg (True, False).
    """
    r = parity_results[task]["time_limit"]
    assert r["length"] == 1000, r
    # [step, terminated, truncated, Gymnasium's terminated, Gymnasium's truncated] wherever one is set
    assert r["flags"] == [[1000, False, True, False, True]], r
    assert r["flag_mismatches"] == 0, r
    for name, tolerance in TIME_LIMIT_TOLERANCES[task].items():
        assert r[name] < tolerance, (name, r)
    metrics = r["metrics"]
    assert metrics["episode_done"] == 1.0 and metrics["episode_length"] == 1000.0, r
    assert metrics["episode_return"] == pytest.approx(r["gym_return"], rel=2e-5), r

    length = parity_results[task]["random"]["episode_lengths"][0]
    flags = parity_results[task]["coincidence"]["flags"]
    assert flags[:-1] == [[t, False, False, False, False] for t in range(1, length)], flags
    assert flags[-1] == [length, True, False, True, True], flags


@pytest.mark.parametrize("task", WITHOUT_STABILISING_POLICY)
def test_gymnasium_parity_truncation_before_termination(task, parity_results):
    """The time limit of a task that no cheap controller keeps alive: the random episode of seed 0
    (``gymnasium_parity``'s actions), which terminates at step L, with the time limit at step L - 1
    (``coincidence_parity``: Gymnasium made with ``max_episode_steps=L - 1``, jaxpg's step counter
    started that many steps before its limit): both say ``truncated`` and not ``terminated`` at
    L - 1 and nothing before. With the limit at L itself, Gymnasium says (True, True), jaxpg
    (True, False), as ``test_gymnasium_parity_to_time_limit`` explains."""
    length = parity_results[task]["random"]["episode_lengths"][0]
    flags = parity_results[task]["time_limit"]["truncation"]["flags"]
    assert flags[:-1] == [[t, False, False, False, False] for t in range(1, length - 1)], flags
    assert flags[-1] == [length - 1, False, True, False, True], flags
    flags = parity_results[task]["coincidence"]["flags"]
    assert flags[:-1] == [[t, False, False, False, False] for t in range(1, length)], flags
    assert flags[-1] == [length, True, False, True, True], flags


@pytest.mark.parametrize("task", CONTACT_FRAME_TASKS)
def test_gymnasium_parity_contact_frames(task, parity_results):
    """Ant against Gymnasium's ``Ant-v5`` (float64 worker, ``contact_frame_parity``): the env a user
    gets (``envs.make(task, fidelity="gymnasium", impl="jax")``) and Gymnasium's with its TimeLimit
    from the same reset states under the same random actions, seeds 0-3 (measured on seeds 0-7).

    The env a user gets agrees to rounding until a lower leg first touches the floor steeper than 60
    degrees from horizontal: there MJX's contact frame is not MuJoCo's (jaxpg/envs/ant.py), the
    pyramidal friction cone points its edges elsewhere and the trajectories part by O(1), not by
    rounding. Measured: qpos within 8e-16 over the first 2-4 steps (the ant drops ~0.2 m onto the
    floor first), then qvel apart by 0.02-0.6 at the step of that contact and by 0.3-4.7 within 12
    steps. The test holds qpos and qvel to 1e-9 over the first 2 steps and checks that they part
    (qvel by more than 1e-3 within 12 steps), which fails if MJX adopts MuJoCo's frame: then this
    test and the docstring of jaxpg/envs/ant.py need updating.

    With MuJoCo's frame swapped into MJX's collider (``mujoco_capsule_frames``, the same env traced
    in that context) the two run whole episodes together. Over the first 50 steps of every episode
    qpos agree to <= 2.6e-11 and qvel to <= 5.2e-10 (tolerance 1e-8): the contacts' and joint
    limits' Newton solves stop at different iterations within their tolerance 1e-8, as in
    ``test_gymnasium_parity``, and the tumbling ant amplifies that about e-fold every 5 steps from
    step ~40 (1e-9 in qvel at steps 55-73, 1e-7 at 75-98, O(1) after ~150 in the long episodes).
    Over those 50 steps the obs, contact forces included, agree to their float32 rounding (<= 4.8e-7,
    entries up to ~10; tolerance 1e-5), the reward to <= 1.2e-7 (float32; tolerance 1e-5), and
    Gymnasium's info terms to <= 1.4e-10 (velocities ``dx / dt`` of ``xpos`` with dt 0.05;
    tolerance 1e-8). Episodes that end inside that window end at the same step: seeds 0, 2, 3
    terminate at 44, 28, 38 in both (the ant flips or leaves the height range). Seed 1 runs past the
    window; here it reaches the 1000-step limit in both, ``truncated`` and never ``terminated``,
    though its trajectories have parted long before. What happens after the window compares two
    different trajectories (of seeds 4-7, seed 5 terminated at step 211 in jaxpg alone), which
    other rounding could change, so the test asks only that a step-1000 end be truncation in both
    and that no flag be set within the window. The time limit's coincidence with
    termination follows jaxpg's rule (``test_gymnasium_parity_to_time_limit``): seed 0 with the
    limit at its termination step L, Gymnasium (True, True), jaxpg (True, False); at L - 1 both
    truncated only.
    """
    r = parity_results[task]
    for seed, run in enumerate(r["user"]):
        assert run["reset_obs"] < 1e-6, (seed, run["reset_obs"])
        assert max(run["qpos"][:2]) < 1e-9 and max(run["qvel"][:2]) < 1e-9, (seed, run)
        assert max(run["obs"][:2]) < 1e-5 and max(run["reward"][:2]) < 1e-5 and max(run["info"][:2]) < 1e-8, run
        assert max(run["qvel"]) > 1e-3, (seed, run)  # the frames part the trajectories (see the docstring)
    lengths = [run["length"] for run in r["swapped"]]
    assert [lengths[0], lengths[2], lengths[3]] == [44, 28, 38] and lengths[1] > CONTACT_FRAME_TIGHT_STEPS, lengths
    for seed, run in enumerate(r["swapped"]):
        length = run["length"]
        assert run["reset_obs"] < 1e-6, (seed, run["reset_obs"])
        if length <= CONTACT_FRAME_TIGHT_STEPS:  # ended together, by termination
            assert run["flags"] == [[length, True, False, True, False]], (seed, run["flags"])
        else:  # nothing inside the window; at the time limit, truncated in both (seed 1 here)
            assert run["flags"][0][0] > CONTACT_FRAME_TIGHT_STEPS, (seed, run["flags"])
            assert run["flags"][-1] == [1000, False, True, False, True] or length < 1000, (seed, run["flags"])
        tight = min(length, CONTACT_FRAME_TIGHT_STEPS)
        assert max(run["qpos"][:tight]) < 1e-8 and max(run["qvel"][:tight]) < 1e-8, (seed, run)
        assert max(run["obs"][:tight]) < 1e-5 and max(run["reward"][:tight]) < 1e-5, (seed, run)
        assert max(run["info"][:tight]) < 1e-8, (seed, run)
    length = lengths[0]
    flags = r["truncation"]["flags"]
    assert flags[:-1] == [[t, False, False, False, False] for t in range(1, length - 1)], flags
    assert flags[-1] == [length - 1, False, True, False, True], flags
    flags = r["coincidence"]["flags"]
    assert flags[:-1] == [[t, False, False, False, False] for t in range(1, length)], flags
    assert flags[-1] == [length, True, False, True, True], flags


@pytest.mark.parametrize("task", ["humanoid"])
def test_gymnasium_parity_humanoid(task, parity_results):
    """Humanoid in ``fidelity="gymnasium"`` against Gymnasium's Humanoid-v5 with its model's solver
    switched from PGS to Newton, as jaxpg's is (MJX has no PGS; ``test_humanoid_newton_in_place_of_pgs``
    measures that change), step by step in float64 (``humanoid_parity``: seeds 0-3 of random in-range
    actions to termination and 10 steps on; RK4 at 3 ms, frame skip 5). The flags at the time limit
    are checked by ``test_gymnasium_parity_truncation_before_termination``.

    Measured on seeds 0-3: episodes of 22, 24, 32 and 21 steps, ending at the same step in both, no
    ``terminated`` mismatch before or after. Within them MJX repeats MuJoCo to rounding: qpos 2.0e-14
    and qvel 2.2e-13 (tolerance 1e-9); the 348 observation entries to their float32 rounding, 5.9e-8
    relative to ``max(1, |obs|)`` (tolerance 1e-6; in absolute terms 5.8e-8 in qpos, 6.1e-7 in qvel,
    2.5e-7 in cinert, 4.7e-7 in cvel, 3.8e-6 in the actuator forces up to ~120, 8.1e-5 in the contact
    forces ``cfrc_ext`` up to ~2e3), the reset observation 5.8e-8; the reward (up to ~6) 2.4e-7
    (tolerance 1e-6), Gymnasium's ``info`` terms against jaxpg's metrics 9.0e-14 (tolerance 1e-9).

    Those seeds' episodes touch the floor with the feet (spheres) alone. Where capsules collide, MJX's
    collision detection is not MuJoCo's to rounding, and a single physics step parts the two by
    1e-5..1e-2 in qvel: two shins touching (capsule-capsule: distance 1.3e-8 apart from the same state)
    or a limb lying on the floor (capsule-plane: MJX gives a contact another tangent frame than
    MuJoCo's, which turns the pyramidal friction cone of the model's condim-3 floor contacts). Over
    seeds 0-11 that happens within the episode in 4 (seeds 4, 5, 6, 10: up to 6.0e-5 in qpos and qvel,
    1.1e-3 relative in obs, 6.8e-6 in reward; the episodes end at the same step all the same) and in
    every seed after the termination, where the humanoid falls onto the floor: seeds 0-3 reach 4.2e-4
    in qvel, 6.1e-4 relative in obs and 5.1e-6 in reward within 10 steps (tolerances: qpos 1e-3, qvel
    and obs 1e-2, reward and ``info`` 1e-3); one seed of 12 (9) parts there by 0.1 in qvel, O(1) in
    obs. The worker's humanoid run costs ~55 s of CPU, ~50 s of it compiling MJX's float64 RK4 step.
    """
    r = parity_results[task]["random"]
    assert len(r["episode_lengths"]) == PARITY_SEEDS, r
    # The reset keeps the noisy, unnormalised quaternion, as Gymnasium's does (Humanoid.physics_state)
    assert all(abs(norm - 1.0) > 1e-5 for norm in r["reset_quaternion_norms"]), r
    assert r["episode_mismatches"] == 0 and r["after_mismatches"] == 0, r
    assert r["episode_qpos"] < 1e-9 and r["episode_qvel"] < 1e-9, r
    assert r["reset_obs"] < 1e-6 and r["episode_obs"] < 1e-6 and r["episode_reward"] < 1e-6, r
    assert r["episode_info"] < 1e-9, r
    assert r["after_qpos"] < 1e-3 and r["after_qvel"] < 1e-2 and r["after_obs"] < 1e-2, r
    assert r["after_reward"] < 1e-3 and r["after_info"] < 1e-3, r


# Gymnasium's observation keywords of Humanoid and HumanoidStandup, each combination checked below.
HUMANOID_OBSERVATION_KEYWORDS = [
    {},
    {"exclude_current_positions_from_observation": False, "include_cinert_in_observation": False},
    {"include_cvel_in_observation": False, "include_cfrc_ext_in_observation": False},
    {"include_qfrc_actuator_in_observation": False, "include_cinert_in_observation": False},
]


@pytest.mark.parametrize("task", HUMANOID_TASKS)
def test_humanoid_observation_keywords_match_gymnasium(task):
    """Each combination of Gymnasium's observation keywords gives Gymnasium's own observation
    (``_get_obs`` of its v5 env made with them), read from the same MuJoCo data after 20 or more
    random steps (up to one with contact forces; actuator forces nonzero), and the same
    observation size."""
    for keywords in HUMANOID_OBSERVATION_KEYWORDS:
        gym_env = make_gymnasium(task, **keywords).unwrapped
        gym_env.reset(seed=0)
        rng = np.random.default_rng(0)
        for t in range(300):  # on until a step with contacts (the lying humanoid bounces off the floor)
            gym_env.step(rng.uniform(-0.4, 0.4, gym_env.action_space.shape))
            if t >= 20 and np.abs(gym_env.data.cfrc_ext).max() > 0:
                break
        env = envs.make_task(task, impl="jax", **keywords)
        data = mjx.put_data(env.mj_model, gym_env.data)
        expected = gym_env._get_obs()
        assert env.observation_size == expected.shape[0] == gym_env.observation_space.shape[0], keywords
        assert np.abs(gym_env.data.cfrc_ext).max() > 0 and np.abs(gym_env.data.qfrc_actuator).max() > 0
        observation = np.asarray(env.observation(data))
        np.testing.assert_allclose(observation, expected, rtol=1e-6, atol=1e-6, err_msg=str(keywords))


@pytest.mark.parametrize("task", ["hopper", "walker2d", "half_cheetah", "swimmer"])
def test_planar_observation_keyword_matches_gymnasium(task):
    """``exclude_current_positions_from_observation=False`` observes the positions too, as
    Gymnasium's ``_get_obs`` does from the same state (after 30 random steps)."""
    for keywords in ({}, {"exclude_current_positions_from_observation": False}):
        gym_env = make_gymnasium(task, **keywords).unwrapped
        gym_env.reset(seed=1)
        rng = np.random.default_rng(1)
        for _ in range(30):
            gym_env.step(rng.uniform(-1, 1, gym_env.action_space.shape))
        env = envs.make_task(task, impl="jax", **keywords)
        expected = gym_env._get_obs()
        assert env.observation_size == expected.shape[0] == gym_env.observation_space.shape[0], keywords
        observation = env.observation(jnp.asarray(gym_env.data.qpos), jnp.asarray(gym_env.data.qvel))
        np.testing.assert_allclose(np.asarray(observation), expected, rtol=1e-6, atol=1e-6, err_msg=str(keywords))


def test_hopper_healthy_ranges_match_gymnasium():
    """Hopper's healthy ranges, Gymnasium's defaults and narrowed ones (Gymnasium's keywords), judge
    states as Gymnasium's ``is_healthy`` does: 200 states each, the height and the angle drawn
    across each range's bounds (half of them), the other coordinates and velocities around them."""
    narrowed = {"healthy_z_range": (0.9, 1.4), "healthy_angle_range": (-0.3, 0.1), "healthy_state_range": (-3.0, 3.0)}
    for ranges in ({}, narrowed):
        gym_env = make_gymnasium("hopper", **ranges).unwrapped
        gym_env.reset(seed=0)
        env = envs.make_task("hopper", impl="jax", **ranges)
        (z_low, z_high), (angle_low, angle_high) = gym_env._healthy_z_range, gym_env._healthy_angle_range
        rng = np.random.default_rng(0)
        verdicts = []
        for i in range(200):
            qpos = gym_env.init_qpos + rng.uniform(-0.6, 0.6, gym_env.model.nq)
            qvel = rng.uniform(-3.5, 3.5, gym_env.model.nv)
            if i % 2:
                qpos[1] = rng.choice([z_low, min(z_high, 2.0)]) + rng.uniform(-0.1, 0.1)
                qpos[2] = rng.choice([angle_low, angle_high]) + rng.uniform(-0.05, 0.05)
            gym_env.set_state(qpos, qvel)
            verdicts.append(bool(gym_env.is_healthy))
            assert bool(env.is_healthy(jnp.asarray(qpos), jnp.asarray(qvel))) == verdicts[-1], (ranges, qpos, qvel)
        assert 0 < sum(verdicts) < len(verdicts), ranges  # both kinds of state were judged


# The tasks that end an unhealthy episode, and the index of the torso's height in their qpos.
TERMINATING_TASKS_HEIGHT = {"hopper": 1, "walker2d": 1, "humanoid": 2}


@pytest.mark.parametrize("task", sorted(TERMINATING_TASKS_HEIGHT))
def test_terminate_when_unhealthy(task, monkeypatch):
    """``terminate_when_unhealthy=False`` (Gymnasium's keyword): a fallen body's step is not
    terminal and earns no survive reward, as in Gymnasium v5; by default it terminates."""
    gym_env = make_gymnasium(task).unwrapped
    gym_env.reset(seed=0)
    qpos = gym_env.data.qpos.copy()
    qpos[TERMINATING_TASKS_HEIGHT[task]] = 0.3  # the torso below the healthy height
    gym_env.set_state(qpos, gym_env.data.qvel)
    action = np.zeros(gym_env.action_space.shape)
    for terminate in (True, False):
        env = envs.make_task(task, impl="jax", terminate_when_unhealthy=terminate)
        monkeypatch.setattr(env, "physics_step", lambda data, ctrl: data)  # stay where set: no physics
        data = mjx.put_data(env.mj_model, gym_env.data)
        state = envs.State(data=data, obs=None, reward=None, terminated=None, truncated=None, metrics={}, info={})
        _, _, _, terminated, metrics = env._step(state, action)
        assert bool(terminated) is terminate and float(metrics["reward_survive"]) == 0.0


def test_humanoid_newton_in_place_of_pgs():
    """Gymnasium's Humanoid-v5 model asks for the PGS solver, which ``mjx.put_model`` refuses; jaxpg's
    asset asks for it too (it is Gymnasium's model) and ``load_model`` gives it Newton in both
    fidelities. What the swap changes, in MuJoCo itself (cheap, no MJX): Gymnasium's env with its
    model untouched (PGS) and switched to Newton, from the same seeded reset with the same random
    in-range actions, 8 seeds to the termination. Measured: the episodes (17-37 steps) end at the
    same step under both solvers; qpos and qvel agree within 1e-6 for the first 5-20 steps and part
    by at most 9e-6 by the termination,
    the observation by at most 8.2e-5 relative to ``max(1, |obs|)`` (the contact forces), the reward
    by 5.3e-7. Running on after the termination, the fallen humanoid amplifies it: qpos and qvel
    1e-5..2e-4 apart at step 100, and 0.66 on one seed of 8 (seed 6, 1e-3 apart at step 94)."""
    path = os.path.join(os.path.dirname(envs.__file__), "assets", "humanoid.xml")
    assert mujoco.MjModel.from_xml_path(path).opt.solver == mujoco.mjtSolver.mjSOL_PGS
    with pytest.raises(NotImplementedError):
        mjx.put_model(mujoco.MjModel.from_xml_path(path), impl="jax")
    for fidelity in ("gymnasium", "fast"):
        assert (
            envs.make_task("humanoid", fidelity=fidelity, impl="jax").mj_model.opt.solver
            == mujoco.mjtSolver.mjSOL_NEWTON
        )
    lengths = []
    for seed in range(8):
        pgs, newton = gym.make("Humanoid-v5").unwrapped, make_gymnasium("humanoid").unwrapped
        assert pgs.model.opt.solver == mujoco.mjtSolver.mjSOL_PGS
        assert newton.model.opt.solver == mujoco.mjtSolver.mjSOL_NEWTON
        pgs.reset(seed=seed)
        newton.reset(seed=seed)
        rng = np.random.default_rng(seed)
        for t in range(1, 100):
            action = rng.uniform(-0.4, 0.4, 17)
            obs_pgs, reward_pgs, terminated_pgs, _, _ = pgs.step(action)
            obs, reward, terminated, _, _ = newton.step(action)
            assert terminated == terminated_pgs, (seed, t)
            state = np.concatenate([newton.data.qpos - pgs.data.qpos, newton.data.qvel - pgs.data.qvel])
            assert np.max(np.abs(state)) < 1e-4, (seed, t, np.max(np.abs(state)))
            assert np.max(np.abs(obs - obs_pgs) / np.maximum(1.0, np.abs(obs_pgs))) < 1e-3, (seed, t)
            assert abs(reward - reward_pgs) < 1e-5, (seed, t)
            if terminated:
                break
        lengths.append(t)
    assert 10 < min(lengths) and max(lengths) < 99, lengths


@pytest.mark.parametrize("task", ["humanoid_standup"])
def test_gymnasium_parity_humanoid_standup(task, parity_results):
    """HumanoidStandup in ``fidelity="gymnasium"`` against Gymnasium's HumanoidStandup-v5 with its
    model's solver switched from PGS to Newton, checked as Humanoid is (``humanoid_parity``, float64,
    seeds 0-3 of random in-range actions, tight tolerances in an "episode" part and Humanoid's loose
    ones after it; ``test_humanoid_standup_newton_in_place_of_pgs`` measures the solver change). The
    task never terminates, and its trajectories part from Gymnasium's within an episode (below), so
    the episode part is its first ``STANDUP_EPISODE_STEPS`` (12) steps, and 50 steps follow.

    Measured, free-running over the whole 1000-step episodes of seeds 0-3: MJX repeats MuJoCo to
    rounding for the first 30, 57, 128 and 13 steps (qpos <= 6.3e-14, qvel <= 8.2e-13), the lying
    body's floor contacts and most of its contacts with itself included (the hands on the pelvis
    and thighs at the reset, the feet together; with ``mujoco_capsule_frames`` the numbers are the
    same). They part where a hand, foot or thigh presses on a leg's capsule (seed 3: left hand on
    left thigh; 0 and 2: right foot on left shin; 1: right thigh on left shin) in a contact whose
    normal MJX computes 4e-6..3e-5 apart from MuJoCo's (contact point 2e-7..1e-6, distance 1e-11):
    one physics step then parts qacc by ~1e-3. The flailing body amplifies that to 0.1 in qvel
    after 222, 414, 390 and 367 steps: no whole episode can be compared step for step (nor can
    Newton follow PGS through one).

    Here, within the episode parts: qpos 2.1e-15 and qvel 7.4e-14 (tolerance 1e-9); the observation
    5.9e-8 relative to ``max(1, |obs|)`` (tolerance 1e-6; in absolute terms 2.9e-8 in qpos, 4.6e-7
    in qvel, 2.5e-7 in cinert, 4.7e-7 in cvel, 3.8e-6 in the actuator forces, 3.0e-5 in the contact
    forces), the reset observation 5.8e-8; the reward (25-60, the torso's height over the 3 ms
    timestep) 1.9e-6, its float32 rounding (tolerance 1e-5); Gymnasium's ``info`` terms against
    jaxpg's metrics 9.2e-14 (tolerance 1e-9). Over the 50 steps after (seeds 3, 0 and 1 part there):
    qpos 5.8e-6, qvel 7.4e-5, obs 1.7e-3 relative, reward 1.7e-5, ``info`` 1.6e-5 (Humanoid's
    tolerances: qpos 1e-3, qvel and obs 1e-2, reward and ``info`` 1e-3). No ``terminated`` in
    either. The time limit: jaxpg's step counter started 12 steps before its limit and Gymnasium
    made with ``max_episode_steps=12`` (``coincidence_parity``) both say ``truncated`` at step 12
    and nothing before. The worker's run costs ~50 s of CPU, ~40 s of it compiling the step.
    """
    r = parity_results[task]["random"]
    assert r["episode_lengths"] == [STANDUP_EPISODE_STEPS] * PARITY_SEEDS, r
    assert all(abs(norm - 1.0) > 1e-5 for norm in r["reset_quaternion_norms"]), r  # as Humanoid's
    assert r["episode_mismatches"] == 0 and r["after_mismatches"] == 0, r
    assert r["episode_qpos"] < 1e-9 and r["episode_qvel"] < 1e-9, r
    assert r["reset_obs"] < 1e-6 and r["episode_obs"] < 1e-6 and r["episode_reward"] < 1e-5, r
    assert r["episode_info"] < 1e-9, r
    assert r["after_qpos"] < 1e-3 and r["after_qvel"] < 1e-2 and r["after_obs"] < 1e-2, r
    assert r["after_reward"] < 1e-3 and r["after_info"] < 1e-3, r
    flags = parity_results[task]["time_limit"]["truncation"]["flags"]
    steps = STANDUP_EPISODE_STEPS
    assert flags == [[t, False, False, False, False] for t in range(1, steps)] + [[steps, False, True, False, True]]


def test_humanoid_standup_newton_in_place_of_pgs():
    """HumanoidStandup-v5's model asks for the PGS solver as Humanoid's does, and ``load_model``
    gives it Newton in both fidelities. What the swap changes, in MuJoCo itself as for Humanoid
    (``test_humanoid_newton_in_place_of_pgs``): Gymnasium's env with its model untouched (PGS) and
    switched to Newton, from the same seeded reset with the same random in-range actions, 8 seeds x
    50 steps. The body lies on the floor, so the two solvers have contacts to solve from the first
    step and part there: measured 1.9e-6..9.7e-6 in qpos and qvel at step 1, at most 9.1e-5 over
    the 50 steps (the observation 7.9e-3 relative to ``max(1, |obs|)``, the reward 2.9e-4).
    Tolerances: parted by more than 1e-7 at step 1; within 1e-3 in qpos and qvel, 5e-2 in obs and
    1e-2 in reward over the 50. Running on, the flailing body amplifies it to O(1) (above 0.1 in
    qpos or qvel after 211-469 steps on the 8 seeds): Newton cannot follow PGS through an episode."""
    path = os.path.join(os.path.dirname(envs.__file__), "assets", "humanoid_standup.xml")
    assert mujoco.MjModel.from_xml_path(path).opt.solver == mujoco.mjtSolver.mjSOL_PGS
    for fidelity in ("gymnasium", "fast"):
        model = envs.make_task("humanoid_standup", fidelity=fidelity, impl="jax").mj_model
        assert model.opt.solver == mujoco.mjtSolver.mjSOL_NEWTON
    for seed in range(8):
        pgs, newton = gym.make("HumanoidStandup-v5").unwrapped, make_gymnasium("humanoid_standup").unwrapped
        assert newton.model.opt.solver == mujoco.mjtSolver.mjSOL_NEWTON
        pgs.reset(seed=seed)
        newton.reset(seed=seed)
        rng = np.random.default_rng(seed)
        for t in range(1, 51):
            action = rng.uniform(-0.4, 0.4, 17)
            obs_pgs, reward_pgs, *_ = pgs.step(action)
            obs, reward, *_ = newton.step(action)
            state = np.max(np.abs(np.concatenate([newton.data.qpos - pgs.data.qpos, newton.data.qvel - pgs.data.qvel])))
            assert state > 1e-7 or t > 1, (seed, state)
            assert state < 1e-3, (seed, t, state)
            assert np.max(np.abs(obs - obs_pgs) / np.maximum(1.0, np.abs(obs_pgs))) < 5e-2, (seed, t)
            assert abs(reward - reward_pgs) < 1e-2, (seed, t)


# Bounds on the largest differences in ``episode_parity`` (float64; obs and reward after jaxpg's
# float32 cast; "info" the metrics Gymnasium also reports), the same for its free and its re-synced
# steps; measured maxima over seeds 0-5 in test_gymnasium_parity_whole_episode's docstring.
EPISODE_TOLERANCES = {
    "half_cheetah": {"qpos": 1e-6, "qvel": 1e-4, "obs": 1e-4, "reward": 5e-5, "info": 5e-5},
    "swimmer": {"qpos": 1e-6, "qvel": 1e-5, "obs": 1e-5, "reward": 5e-5, "info": 5e-5},
    "reacher": {"qpos": 1e-10, "qvel": 1e-10, "obs": 1e-5, "reward": 1e-6, "info": 1e-10},
    "pusher": {"qpos": 1e-6, "qvel": 1e-5, "obs": 1e-5, "reward": 1e-5, "info": 1e-5},
}
# The keys of Gymnasium's step info that jaxpg's metrics carry too, under the same names.
INFO_KEYS = {
    "half_cheetah": ["reward_ctrl", "reward_forward", "x_position", "x_velocity"],
    "swimmer": [
        "distance_from_origin",
        "reward_ctrl",
        "reward_forward",
        "x_position",
        "x_velocity",
        "y_position",
        "y_velocity",
    ],  # fmt: skip
    "reacher": ["reward_ctrl", "reward_dist"],
    "pusher": ["reward_ctrl", "reward_dist", "reward_near"],
    "ant": [
        "distance_from_origin",
        "reward_contact",
        "reward_ctrl",
        "reward_forward",
        "reward_survive",
        "x_position",
        "x_velocity",
        "y_position",
        "y_velocity",
    ],  # fmt: skip
    "walker2d": [
        "reward_ctrl",
        "reward_forward",
        "reward_survive",
        "x_position",
        "x_velocity",
        "z_distance_from_origin",
    ],  # fmt: skip
    "humanoid": [
        "distance_from_origin",
        "reward_contact",
        "reward_ctrl",
        "reward_forward",
        "reward_survive",
        "x_position",
        "x_velocity",
        "y_position",
        "y_velocity",
    ],  # fmt: skip
    "humanoid_standup": [
        "reward_impact",
        "reward_linup",
        "reward_quadctrl",
        "x_position",
        "y_position",
        "z_distance_from_origin",
    ],  # fmt: skip
}


@pytest.mark.parametrize("task", WITHOUT_TERMINATION)
def test_gymnasium_parity_whole_episode(task, parity_results):
    """A task without termination through a whole episode under random actions against Gymnasium's
    v5 env with its TimeLimit (``episode_parity``, seed 0, in the float64 worker): observation,
    reward, Gymnasium's ``info`` terms (``INFO_KEYS``: jaxpg's metrics carry them under the same
    names), ``terminated`` never set and ``truncated`` at the time limit in both, and
    ``EpisodeStats``' return equal to Gymnasium's up to the per-step reward differences and the
    float32 accumulation of the running sum.

    HalfCheetah (Euler at 10 ms, body and feet in contact with the floor): without contacts MJX
    repeats MuJoCo to rounding; where a contact is active the two Newton solvers stop at different
    iterations within their tolerance (1e-8), and the stiff contacts and the chaotic gait amplify
    the difference: free-running, qpos agree to 1e-16..1e-14 over the first 5 steps and to 1e-14..3e-10
    after 20 (seeds 0-5), then part by 1e-6 at step 50 and by O(1) after 100-200 steps. So the
    episode runs free for 20 steps (``RESYNC_AFTER``) and from then on jaxpg's physics state is set
    to Gymnasium's before every step: each of the 980 steps from the same state agrees to 1e-14 in
    qpos and 1e-12 in qvel, except a rare step where a contact's solve parts (seed 2: 2.4e-9 in
    qpos, 5.2e-7 in qvel). Tolerances: qpos 1e-6, qvel 1e-4 (200x over the largest measured; a
    1% error in a mass or a gear changes a step's velocities by ~1e-3 and more); obs and reward
    hold the float32 rounding (<= 9.5e-7 for obs up to 16, 1.1e-7 measured for the reward) on top
    of that; the ``info`` terms and the reward differ by the velocity ``dx / dt`` with dt 0.05, 20x
    qpos's tolerance.

    Swimmer (RK4 at 10 ms, viscous fluid, nothing collides): runs free for the whole episode. Its
    joints reach their +-100 degree limits, whose constraint solves part within tolerance as the
    contacts do, and the difference then grows about e-fold every 80 steps: qpos agree to 1e-15
    over the first 100 steps and to at most 1.6e-8 (qvel 1.2e-7) over the 1000 (seeds 0-2).
    Tolerances: qpos 1e-6, qvel and obs 1e-5 (60x over the largest measured), reward and ``info``
    5e-5 (velocities ``dx / dt`` with dt 0.04).

    Reacher (RK4 at 10 ms, 50 steps, nothing collides): runs free; qpos and qvel stay at float64
    rounding (<= 3.3e-15 and 2.0e-14 over seeds 0-7), the ``info`` terms too (2.5e-16). Tolerances:
    1e-10 for those, room for the elbow's limit solve should an episode reach it; obs 1e-5 and
    reward 1e-6, their float32 rounding (obs up to ~100 in magnitude, reward up to ~5; measured
    9.5e-7 and 9.5e-8).

    Pusher (Euler at 10 ms, frame skip 5, 100 steps, no gravity; the arm can touch the object and
    the table): runs free. Over seed 0 qpos and qvel stay within 5.7e-13 and 4.8e-12 (they grow from
    1e-17 as the arm's joint limits and contacts are solved by the two Newton solvers, which stop at
    different iterations within their tolerance), obs, reward and the ``info`` terms within their
    float32 rounding (2.3e-7, 1.2e-7, 5.7e-8: positions and distances computed in float32).
    Tolerances: qpos 1e-6, qvel 1e-5, swimmer's, for contacts that part the solvers as they do
    there; obs, reward and ``info`` 1e-5 (the terms are distances of order 1 and a control cost with
    weight 0.1: a wrong weight or a position read before the step changes them by 1e-3 or more)."""
    r = parity_results[task]["episode"]
    limit = envs.make_task(task, impl="jax").max_episode_steps
    assert r["length"] == limit, r
    # [step, terminated, truncated, Gymnasium's terminated, Gymnasium's truncated] wherever one is set
    assert r["flags"] == [[limit, False, True, False, True]], r
    assert r["info_keys"] == INFO_KEYS[task], r
    assert r["reset_obs"] < 1e-6, r
    for name, tolerance in EPISODE_TOLERANCES[task].items():
        assert r[f"free_{name}"] < tolerance and r[f"synced_{name}"] < tolerance, (name, r)
    metrics = r["metrics"]
    assert metrics["episode_done"] == 1.0 and metrics["episode_length"] == limit, r
    reward_bound = limit * max(r["free_reward"], r["synced_reward"])
    assert abs(metrics["episode_return"] - r["gym_return"]) <= r["return_rounding"] + reward_bound, r


if __name__ == "__main__":
    print(json.dumps(parity_worker_main(sys.argv[1:])))
