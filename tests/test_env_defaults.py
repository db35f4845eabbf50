"""Every MuJoCo task's defaults against Gymnasium's v5 env of the same name: the keyword defaults,
the values a task made without keywords holds, and the reward, health and termination that its step
computes from states chosen to straddle every default health bound.

The reference is Gymnasium itself: its env classes' signatures, the private attributes its envs keep
(``Hopper-v5``'s ``_healthy_z_range`` ...) and its ``step`` from states set with ``set_state``. No
physics is compiled here: jaxpg's step is fed the ``MjData`` Gymnasium's step ended in (as
``tests/test_envs.py``'s fast-fidelity test does from resets, where a hopper never comes near its
bounds), so each task costs one small compiled program.
"""

from __future__ import annotations

import importlib
import inspect
import warnings

import gymnasium as gym
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from mujoco import mjx

import jaxpg.envs as envs
from jaxpg.envs.mjx_env import MjxEnv

GYM_IDS = {
    task: gym_id
    for task, (gym_id, _) in envs.GYMNASIUM_COUNTERPARTS.items()
    if issubclass(envs.task_class(task), MjxEnv)
}
# Keywords of Gymnasium's constructors that name its model file or viewer, not the task's terms.
GYMNASIUM_ONLY = {"self", "kwargs", "xml_file", "frame_skip", "default_camera_config", "main_body"}
# jaxpg's keywords that Gymnasium hard-codes, with Gymnasium's constant (each checked by behaviour
# below or by tests/test_envs.py's reset-distribution tests).
JAXPG_ONLY = {
    "inverted_pendulum": {"max_angle": 0.2},  # Gymnasium: |qpos[1]| > 0.2 terminates
    "inverted_double_pendulum": {"min_tip_height": 1.0},  # Gymnasium: tip height y <= 1 terminates
    "reacher": {"arm_noise_scale": 0.1, "arm_velocity_noise_scale": 5e-3, "target_radius": 0.2},
}
BACKEND_KEYWORDS = {"self", "mjx_kwargs", "fidelity", "impl", "max_episode_steps", "naconmax", "njmax"}


def gymnasium_class(task: str) -> type:
    """The class of Gymnasium's v5 env that ``task`` reproduces (from its registry entry)."""
    module, name = gym.spec(GYM_IDS[task]).entry_point.split(":")
    return getattr(importlib.import_module(module), name)


def make_gymnasium(task: str, **kwargs) -> gym.Env:
    """The unwrapped Gymnasium env, without MuJoCo's warning about HalfCheetah's ``settotalmass``."""

    def warn(message: str) -> None:
        if "settotalmass" not in message:
            warnings.warn(f"MuJoCo: {message}", stacklevel=2)

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warn)
    try:
        env = gym.make(GYM_IDS[task], **kwargs).unwrapped
    finally:
        mujoco.set_mju_user_warning(previous)
    if env.model.opt.solver == mujoco.mjtSolver.mjSOL_PGS:
        env.model.opt.solver = mujoco.mjtSolver.mjSOL_NEWTON  # as jaxpg's load_model (MJX has no PGS)
    return env


@pytest.mark.parametrize("task", list(GYM_IDS))
def test_keyword_defaults_are_gymnasiums(task):
    """Every keyword of Gymnasium's v5 constructor (but its model file and viewer) is one of jaxpg's
    task, with the same default; jaxpg's extra keywords are backend settings or Gymnasium's
    hard-coded constants, with those constants as defaults."""
    theirs = inspect.signature(gymnasium_class(task).__init__).parameters
    mine = inspect.signature(envs.task_class(task).__init__).parameters
    shared = [name for name in theirs if name not in GYMNASIUM_ONLY]
    assert shared and all(name in mine for name in shared), (task, [n for n in shared if n not in mine])
    for name in shared:
        assert mine[name].default == theirs[name].default, (task, name, mine[name].default, theirs[name].default)
    extra = {name for name in mine if name not in theirs} - BACKEND_KEYWORDS
    assert extra == set(JAXPG_ONLY.get(task, {})), (task, extra)
    for name, value in JAXPG_ONLY.get(task, {}).items():
        assert mine[name].default == value, (task, name)


@pytest.mark.parametrize("task", list(GYM_IDS))
def test_task_made_without_keywords_holds_gymnasiums_values(task):
    """A task made without keywords keeps, in the attribute named as the keyword, the value a
    Gymnasium env made without keywords keeps in ``_<keyword>`` (reward weights, healthy ranges,
    reset noise scales ...), and steps the same simulated time (frame skip and ``dt``)."""
    theirs = make_gymnasium(task)
    mine = envs.make_task(task, impl="jax")
    compared = 0
    for name in inspect.signature(gymnasium_class(task).__init__).parameters:
        if name in GYMNASIUM_ONLY or not hasattr(theirs, f"_{name}"):
            continue
        expected = getattr(theirs, f"_{name}")
        if isinstance(expected, bool) and not hasattr(mine, name):
            continue  # an observation switch (exclude_current_positions ...): test_envs checks its observations
        assert getattr(mine, name) == expected, (task, name, getattr(mine, name), expected)
        compared += 1
    assert compared >= 1, task
    assert mine.frame_skip == theirs.frame_skip and mine.dt == pytest.approx(theirs.dt, rel=1e-12), task


# --------------------------------------------------------------------------------------------
# Reward, health and termination from states that straddle the default bounds


def _perturbed_states(task: str, gym_env: gym.Env, rng: np.random.Generator, count: int):
    """``count`` ``(qpos, qvel)`` around Gymnasium's initial pose, each moving the coordinates that
    the task's default health terms read across their bounds (and the rest a little)."""
    nq, nv = gym_env.model.nq, gym_env.model.nv
    for i in range(count):
        qpos = gym_env.init_qpos + rng.uniform(-0.05, 0.05, nq)
        qvel = rng.uniform(-0.5, 0.5, nv)
        if task == "hopper":  # z in (0.7, inf), angle in (-0.2, 0.2), (qpos, qvel)[2:] in (-100, 100)
            qpos[1] = rng.uniform(0.6, 0.9) if i % 2 else qpos[1]
            qpos[2] = rng.uniform(-0.3, 0.3)
            if i % 5 == 0:
                qvel[rng.integers(2, nv)] = rng.choice([-1, 1]) * rng.uniform(90.0, 130.0)
        elif task == "walker2d":  # z in (0.8, 2.0), angle in (-1, 1)
            qpos[1] = rng.uniform(0.7, 0.95) if i % 2 else rng.uniform(1.9, 2.1)
            qpos[2] = rng.uniform(-1.2, 1.2)
        elif task == "ant":  # torso z in (0.2, 1.0); a low torso puts the legs on the floor (contact cost)
            qpos[2] = rng.uniform(0.1, 0.35) if i % 2 else rng.uniform(0.9, 1.1)
        elif task == "humanoid":  # torso z in (1.0, 2.0)
            qpos[2] = rng.uniform(0.9, 1.1) if i % 2 else rng.uniform(1.9, 2.1)
        elif task == "inverted_pendulum":  # |angle| <= 0.2
            qpos[1] = rng.uniform(-0.3, 0.3)
        elif task == "inverted_double_pendulum":  # tip height > 1
            qpos[1:] = rng.uniform(-0.6, 0.6, 2)
            qvel = rng.uniform(-3.0, 3.0, nv)
        else:  # tasks without health terms: any pose, so that the distance terms vary too
            qpos = gym_env.init_qpos + rng.uniform(-0.5, 0.5, nq)
            qvel = rng.uniform(-2.0, 2.0, nv)
        yield qpos, qvel


STATES = 24


@pytest.mark.parametrize("task", list(GYM_IDS))
def test_default_reward_and_termination_match_gymnasium(task):
    """From ``STATES`` states set in Gymnasium's env made without keywords (straddling each default
    health bound: ``_perturbed_states``), one step with a random action in range: jaxpg's task made
    without keywords, given the ``MjData`` Gymnasium's step ended in, computes Gymnasium's
    observation, reward, ``terminated`` and every ``info`` reward term it shares. In float64, as
    Gymnasium, then cast: equal to one float32 rounding. Both outcomes of ``terminated`` occur on
    the tasks that terminate."""
    gym_env = make_gymnasium(task)
    gym_env.reset(seed=0)
    env = envs.make_task(task, impl="jax")
    rng = np.random.default_rng(0)
    befores, afters, actions, expected = [], [], [], []
    with jax.enable_x64(True):
        for qpos, qvel in _perturbed_states(task, gym_env, rng, STATES):
            gym_env.set_state(qpos, qvel)
            befores.append(mjx.put_data(gym_env.model, gym_env.data))
            action = rng.uniform(env.action_low, env.action_high, env.action_size)
            obs, reward, terminated, _, info = gym_env.step(action)
            afters.append(mjx.put_data(gym_env.model, gym_env.data))
            actions.append(action)
            expected.append((obs, reward, terminated, info))

        def judged(before, after, action):
            env.physics_step = lambda data, ctrl: after
            state = envs.State(
                data=before,
                obs=None,
                reward=None,
                terminated=None,
                truncated=None,
                metrics={},
                info={"step": jnp.zeros((), jnp.int32)},
            )
            _, obs, reward, terminated, metrics = env._step(state, action)
            return obs, reward, terminated, metrics

        before, after = (jax.tree.map(lambda *xs: jnp.stack(xs), *datas) for datas in (befores, afters))
        obs, reward, terminated, metrics = jax.jit(jax.vmap(judged))(before, after, jnp.asarray(actions))
    shared = sorted(k for k in expected[0][3] if k in metrics and k.startswith(("reward", "x_", "y_", "z_")))
    for i, (gym_obs, gym_reward, gym_terminated, info) in enumerate(expected):
        assert bool(terminated[i]) == gym_terminated, (task, i)
        np.testing.assert_allclose(np.float32(obs[i]), gym_obs.astype(np.float32), rtol=2**-23, atol=1e-30)
        np.testing.assert_allclose(np.float32(reward[i]), np.float32(gym_reward), rtol=2**-22, atol=1e-30)
        for k in shared:
            np.testing.assert_allclose(np.float32(metrics[k][i]), np.float32(info[k]), rtol=2**-22, atol=1e-30)
    verdicts = {bool(t) for _, _, t, _ in expected}
    never_terminates = task in ("half_cheetah", "swimmer", "reacher", "pusher", "humanoid_standup")
    assert verdicts == ({False} if never_terminates else {False, True}), (task, verdicts)
