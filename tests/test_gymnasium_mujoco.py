"""jaxpg's single Gymnasium env of an MJX task against Gymnasium's own env of it, with Gymnasium's
tools (``check_environments_match``, ``data_equivalence``): the same seed gives Gymnasium's start
state, rewards and ``info`` values have Gymnasium's types, ``env.unwrapped`` has ``MujocoEnv``'s
attributes, and Gymnasium's keywords are accepted or refused by name.

Compilation: the full reset check compiles one small reset program for each of six cheap tasks;
stepping uses InvertedPendulum, which tests/test_gymnasium_api.py compiles too. The other tasks'
start draws and reset ``info`` are checked on the host, where nothing compiles.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import gymnasium
import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.utils.env_match import check_environments_match

from jaxpg import envs
from jaxpg.envs import gymnasium_api, gymnasium_mujoco, gymnasium_spaces

MJX_TASKS = [task for task in gymnasium_mujoco.START_DRAWS]
CHEAP_TASKS = ["hopper", "walker2d", "half_cheetah", "swimmer", "ant", "inverted_pendulum"]
BIG_SEED = 2**70  # Gymnasium's own envs accept it


@contextlib.contextmanager
def mujoco_warnings_silenced() -> Iterator[None]:
    """Silences MuJoCo's compiler warning for Gymnasium's HalfCheetah model (and its log file)."""
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


def theirs(task: str) -> gymnasium.Env:
    with mujoco_warnings_silenced():
        return gymnasium.make(envs.GYMNASIUM_COUNTERPARTS[task][0])


@pytest.mark.parametrize("task", CHEAP_TASKS)
def test_reset_is_gymnasiums_for_the_same_seed(task):
    """Gymnasium's ``check_environments_match`` at reset (``num_steps=0``): the same observation
    (``np.allclose`` at 1e-5: MJX computes it in float32) and the same ``info``, equal to the bit
    and of the same types, for seeds 0, 1 and 2**70; an unseeded reset continues Gymnasium's
    stream of start states."""
    ours, reference = gymnasium.make(gymnasium_api.gymnasium_id(task)), theirs(task)
    for seed in (0, 1, BIG_SEED):
        check_environments_match(ours, reference, num_steps=0, seed=seed)
    obs, info = ours.reset()
    obs_t, info_t = reference.reset()
    assert data_equivalence(obs, obs_t) and data_equivalence(info, info_t, exact=True)
    np.testing.assert_array_equal(ours.unwrapped.data.qpos, reference.unwrapped.data.qpos)
    np.testing.assert_array_equal(ours.unwrapped.data.qvel, reference.unwrapped.data.qvel)


@pytest.mark.parametrize("task", MJX_TASKS)
def test_start_draws_and_reset_info_are_gymnasiums(task):
    """For every MJX task (those whose reset program is costly to compile included): the start
    state drawn from a generator seeded as Gymnasium seeds its env's, and the reset ``info``
    computed from it, equal Gymnasium's env's to the bit, for two seeds and an unseeded reset
    after them (Reacher's and Pusher's draw loops included)."""
    reference = theirs(task)
    mjx_task = envs.make_shared(task, fidelity="gymnasium", max_episode_steps=gymnasium_spaces.NO_LIMIT).unwrapped
    model = mjx_task.mj_model
    data = mujoco.MjData(model)
    rng = None
    for seed in (3, BIG_SEED, None):
        _, info_t = reference.reset(seed=seed)
        if seed is not None:
            rng, _ = gymnasium.utils.seeding.np_random(seed)
        qpos, qvel = gymnasium_mujoco.draw_start(task, mjx_task, rng)
        np.testing.assert_array_equal(qpos, reference.unwrapped.data.qpos)
        np.testing.assert_array_equal(qvel, reference.unwrapped.data.qvel)
        gymnasium_mujoco.set_start(model, data, qpos, qvel)
        keys = gymnasium_spaces.INFO_KEYS[task][0]
        info = gymnasium_mujoco.reset_info(task, keys, data, np.array(model.qpos0))
        assert data_equivalence(info, info_t, exact=True), (info, info_t)


@pytest.mark.parametrize("task", [*MJX_TASKS, "cartpole"])
def test_reward_and_info_types_are_gymnasiums(task):
    """Gymnasium's env's own reward and ``info`` values, passed through jaxpg's conversion, keep
    their Python types (what ``data_equivalence`` compares first), for float32 actions (what its
    action spaces sample) and float64 ones."""
    reference = theirs(task)
    _, info = reference.reset(seed=0)
    assert {k: type(v) for k, v in gymnasium_spaces.host_info(info, tuple(info), task).items()} == {
        k: type(v) for k, v in info.items()
    }
    for dtype in (np.float32, np.float64):
        action = reference.action_space.sample()
        if task != "cartpole":
            action = action.astype(dtype)
        _, reward, *_, info = reference.step(action)
        converted = gymnasium_spaces.host_info(info, tuple(info), task, np.asarray(action).dtype)
        assert {k: type(v) for k, v in converted.items()} == {k: type(v) for k, v in info.items()}, dtype
        assert type(gymnasium_spaces.host_reward(task, reward)) is type(reward)


@pytest.fixture(scope="module")
def pendulums():
    """``jaxpg/InvertedPendulum-v5`` and Gymnasium's ``InvertedPendulum-v5``."""
    return gymnasium.make("jaxpg/InvertedPendulum-v5"), gymnasium.make("InvertedPendulum-v5")


class ResetCounter(gymnasium.Wrapper):
    """Counts the resets that ``check_environments_match`` asks for."""

    resets = 0

    def reset(self, **kwargs):
        self.resets += 1
        return self.env.reset(**kwargs)


def test_check_environments_match_through_whole_episodes(pendulums):
    """InvertedPendulum passes ``check_environments_match`` with its default checks over 100
    random steps: several episodes, each ended and reset by the checker (float32 stays within the
    checker's 1e-5 here; rewards and ``info`` are compared exactly and are equal)."""
    ours = ResetCounter(pendulums[0])
    check_environments_match(ours, pendulums[1], num_steps=100, seed=5)
    assert ours.resets >= 4


def test_unwrapped_has_mujoco_envs_attributes(pendulums):
    """``dt``, ``frame_skip``, ``init_qpos``, ``init_qvel`` equal Gymnasium's (same dtype);
    ``data`` follows the env: equal to Gymnasium's after the same reset (derived quantities
    included), and within float32 after the same steps; ``state_vector()`` likewise; ``model``
    is the model simulated."""
    ours, reference = (env.unwrapped for env in pendulums)
    assert ours.dt == reference.dt and ours.frame_skip == reference.frame_skip
    for name in ("init_qpos", "init_qvel"):
        assert data_equivalence(getattr(ours, name), getattr(reference, name), exact=True), name
    ours.reset(seed=9)
    reference.reset(seed=9)
    assert isinstance(ours.data, mujoco.MjData) and isinstance(ours.model, mujoco.MjModel)
    assert ours.model.nq == reference.model.nq and ours.model.opt.timestep == reference.model.opt.timestep
    for field in ("qpos", "qvel", "xpos", "xquat"):
        np.testing.assert_array_equal(getattr(ours.data, field), getattr(reference.data, field), err_msg=field)
    np.testing.assert_array_equal(ours.state_vector(), reference.state_vector())
    for _ in range(3):
        action = np.array([0.3], np.float32)
        ours.step(action)
        reference.step(action)
    assert ours.data.time == pytest.approx(reference.data.time, rel=1e-6)
    np.testing.assert_allclose(ours.data.xpos, reference.data.xpos, atol=1e-5)
    np.testing.assert_allclose(ours.state_vector(), reference.state_vector(), atol=1e-5)
    qpos, qvel = np.array([0.1, -0.05]), np.array([0.2, 0.0])
    ours.set_state(qpos, qvel)
    np.testing.assert_array_equal(ours.data.qpos, qpos)
    with pytest.raises(AttributeError, match="not a MuJoCo env"):
        gymnasium.make("jaxpg/CartPole-v1").unwrapped.data  # noqa: B018


def test_gymnasium_keywords_accepted_or_refused_by_name():
    """``MujocoEnv``'s keywords: ``frame_skip`` at the task's value, ``width``, ``height``,
    ``camera_id``/``camera_name`` and ``render_mode="depth_array"`` are accepted; another
    ``frame_skip``, ``xml_file``, ``default_camera_config``, ``max_geom`` and ``visual_options``
    raise one ``ValueError`` naming the keyword; nothing here compiles."""
    env = gymnasium.make("jaxpg/InvertedPendulum-v5", frame_skip=2, width=64, height=48, camera_id=0)
    assert env.unwrapped.frame_skip == 2
    assert gymnasium.make("jaxpg/InvertedPendulum-v5", render_mode="depth_array").render_mode == "depth_array"
    assert "depth_array" in gymnasium_api.JaxpgEnv.metadata["render_modes"]
    refused = {
        "frame_skip": 5,
        "xml_file": "inverted_pendulum.xml",
        "default_camera_config": {"distance": 3.0},
        "max_geom": 2000,
        "visual_options": {2: True},
    }
    for keyword, value in refused.items():
        with pytest.raises(ValueError, match=rf"^{keyword}=.* is not supported by jaxpg's inverted_pendulum env"):
            gymnasium.make("jaxpg/InvertedPendulum-v5", **{keyword: value})
    with pytest.raises(ValueError, match="render_mode='depth_array' is for MuJoCo tasks"):
        gymnasium.make("jaxpg/CartPole-v1", render_mode="depth_array")
    with pytest.raises(ValueError, match="width must be a positive integer"):
        gymnasium.make("jaxpg/InvertedPendulum-v5", width=0)


def test_depth_array_renders_depths(pendulums):
    """``render_mode="depth_array"`` gives ``[height, width]`` float32 depths, ``"rgb_array"``
    ``[height, width, 3]`` uint8 frames, at the requested size; skipped, naming what is missing,
    where MuJoCo has no OpenGL backend."""
    from jaxpg import video

    problem = video.gl_problem()
    if problem is not None:
        pytest.skip(f"no rendering: {problem}")
    for mode, shape, dtype in (("depth_array", (48, 64), np.float32), ("rgb_array", (48, 64, 3), np.uint8)):
        env = gymnasium.make("jaxpg/InvertedPendulum-v5", render_mode=mode, width=64, height=48)
        env.reset(seed=0)
        frame = env.render()
        assert frame.shape == shape and frame.dtype == dtype and frame.std() > 0
        env.close()


def test_seeds_past_64_bits_give_distinct_keys():
    """``seed_key``: ``PRNGKey(seed)`` below 2**32, and seeds that differ only above 32 or 64 bits
    get different keys (JAX's ``PRNGKey`` alone keeps the low 32 bits)."""
    import jax

    np.testing.assert_array_equal(gymnasium_spaces.seed_key(12345), jax.random.PRNGKey(12345))
    keys = {tuple(np.asarray(gymnasium_spaces.seed_key(s)).tolist()) for s in (5, 5 + 2**32, 5 + 2**64, 5 + 2**70)}
    assert len(keys) == 4
