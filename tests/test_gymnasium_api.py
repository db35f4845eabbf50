"""jaxpg's tasks through the Gymnasium API: the single env and the vector env, judged by
Gymnasium's own checker (and Stable-Baselines3's, in the optional run ``pytest -m optional``), and
the semantics the module promises: same-step autoreset with final observations, TimeLimit
truncation, seeding, spaces, bad actions refused with one clear line.

Small batches and the cheap tasks (inverted_pendulum, cartpole) keep compilation short.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator

import gymnasium
import jax
import numpy as np
import pytest

from jaxpg import envs
from jaxpg.envs import gymnasium_api

NUM_ENVS = 4


@pytest.fixture(scope="module")
def pendulum_vec():
    return envs.gymnasium_vector_env("inverted_pendulum", NUM_ENVS, max_episode_steps=12)


@pytest.fixture(scope="module")
def cartpole_vec():
    return envs.gymnasium_vector_env("cartpole", NUM_ENVS)


def checker_warnings(check, env) -> set[str]:
    """The messages of the warnings ``check(env)`` raised (it raises on errors itself)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check(env)
    return {str(w.message) for w in caught}


@pytest.mark.parametrize(
    ("name", "gym_id"), [("inverted_pendulum", "InvertedPendulum-v5"), ("cartpole", "CartPole-v1")]
)
def test_gymnasium_check_env_accepts_the_single_env(name, gym_id):
    """Gymnasium's checker passes, with no warning that Gymnasium's own env does not also get
    (InvertedPendulum's [-3, 3] action range draws a "use a normalised range" recommendation)."""
    from gymnasium.utils.env_checker import check_env

    env = envs.gymnasium_env(name)
    assert env.spec.id == gymnasium_api.gymnasium_id(name) and env.spec.max_episode_steps in (500, 1000)
    ours = checker_warnings(lambda e: check_env(e, skip_render_check=True), env.unwrapped)
    theirs = checker_warnings(lambda e: check_env(e, skip_render_check=True), gymnasium.make(gym_id).unwrapped)
    assert ours <= theirs, ours - theirs


# The MuJoCo suite's other ids (inverted_pendulum is above): each compiles its single env's reset and
# step, 5-25 s a task on two CPU cores (90 s for the nine).
SUITE_IDS = {
    "hopper": "Hopper-v5",
    "inverted_double_pendulum": "InvertedDoublePendulum-v5",
    "half_cheetah": "HalfCheetah-v5",
    "swimmer": "Swimmer-v5",
    "walker2d": "Walker2d-v5",
    "reacher": "Reacher-v5",
    "pusher": "Pusher-v5",
    "ant": "Ant-v5",
    "humanoid": "Humanoid-v5",
}


@pytest.mark.parametrize(("name", "gym_id"), SUITE_IDS.items(), ids=list(SUITE_IDS))
def test_gymnasium_check_env_accepts_every_suite_id(name, gym_id):
    """Gymnasium's checker passes on ``gymnasium.make("jaxpg/<Id>")`` of every MuJoCo task, with
    no warning that Gymnasium's own env of that id does not also get, and the id's spec carries
    Gymnasium's time limit."""
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make(gymnasium_api.gymnasium_id(name))
    assert env.spec.max_episode_steps == gymnasium.spec(gym_id).max_episode_steps
    ours = checker_warnings(lambda e: check_env(e, skip_render_check=True), env.unwrapped)
    with mujoco_warnings_silenced():
        theirs = checker_warnings(lambda e: check_env(e, skip_render_check=True), gymnasium.make(gym_id).unwrapped)
    assert ours <= theirs, ours - theirs


@contextlib.contextmanager
def mujoco_warnings_silenced() -> Iterator[None]:
    """Silences MuJoCo's warnings, such as the one its compiler gives for Gymnasium's HalfCheetah
    model (its deprecated ``settotalmass``), which MuJoCo would also append to a ``MUJOCO_LOG.TXT``
    in the working directory; Python warnings are untouched."""
    import mujoco

    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda message: None)
    try:
        yield
    finally:
        mujoco.set_mju_user_warning(previous)


@pytest.mark.optional  # pip install -e ".[sb3]" && pytest -m optional; the default run deselects it
def test_stable_baselines3_check_env_accepts_the_single_env():
    from stable_baselines3.common import env_checker as sb3_checker  # the optional run installs it: no skip

    check = lambda e: sb3_checker.check_env(e, warn=True, skip_render_check=True)  # noqa: E731
    ours = checker_warnings(check, envs.gymnasium_env("inverted_pendulum").unwrapped)
    theirs = checker_warnings(check, gymnasium.make("InvertedPendulum-v5").unwrapped)
    assert ours <= theirs, ours - theirs


def test_single_env_truncates_at_the_time_limit_and_matches_the_registration():
    env = gymnasium.make("jaxpg/InvertedPendulum-v5", max_episode_steps=5)
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.float32 and obs.shape == (4,) and info == {}
    for t in range(5):
        obs, reward, terminated, truncated, _ = env.step(np.zeros(1, np.float32))
        assert isinstance(reward, float) and not terminated
        assert truncated == (t == 4)


def test_vector_spaces(pendulum_vec, cartpole_vec):
    vec = pendulum_vec
    assert vec.num_envs == NUM_ENVS
    assert vec.single_observation_space == gymnasium.spaces.Box(-np.inf, np.inf, (4,), np.float32)
    assert vec.single_action_space == gymnasium.spaces.Box(-3.0, 3.0, (1,), np.float32)
    assert vec.observation_space.shape == (NUM_ENVS, 4) and vec.action_space.shape == (NUM_ENVS, 1)
    assert vec.metadata["autoreset_mode"] == gymnasium.vector.AutoresetMode.SAME_STEP
    assert cartpole_vec.single_action_space == gymnasium.spaces.Discrete(2)
    assert cartpole_vec.action_space == gymnasium.spaces.MultiDiscrete([2] * NUM_ENVS)
    obs, _ = vec.reset(seed=0)
    assert obs.dtype == np.float32 and obs.shape == (NUM_ENVS, 4) and vec.observation_space.contains(obs)


def test_vector_seeding_is_reproducible(pendulum_vec):
    vec = pendulum_vec
    actions = np.linspace(-1, 1, NUM_ENVS, dtype=np.float32)[:, None]
    runs = []
    for _ in range(2):
        obs, _ = vec.reset(seed=7)
        trace = [obs]
        for _ in range(3):
            trace.append(vec.step(actions)[0])
        runs.append(np.stack(trace))
    np.testing.assert_array_equal(runs[0], runs[1])
    other, _ = vec.reset(seed=8)
    assert not np.allclose(other, runs[0][0])
    assert len({tuple(row) for row in runs[0][0]}) == NUM_ENVS  # each env its own reset noise
    per_env, _ = vec.reset(seed=[1, 2, 3, 4])
    again, _ = vec.reset(seed=[1, 2, 3, 4])
    np.testing.assert_array_equal(per_env, again)
    with pytest.raises(ValueError, match="expected 4 seeds"):
        vec.reset(seed=[1, 2])


def test_vector_autoreset_keeps_final_observations(pendulum_vec):
    """Same-step autoreset: at an episode's end ``obs`` is the next episode's first observation
    and ``info["final_obs"]`` the one it ended in; the time limit (12 here) truncates."""
    vec = pendulum_vec
    obs, _ = vec.reset(seed=0)
    push = np.array([[3.0], [-3.0], [0.0], [0.0]], np.float32)  # envs 0 and 1 fall over fast
    ended = np.zeros(NUM_ENVS, bool)
    for t in range(12):
        obs, reward, terminated, truncated, info = vec.step(push)
        assert reward.shape == (NUM_ENVS,) and terminated.dtype == bool and truncated.dtype == bool
        done = terminated | truncated
        if done.any():
            np.testing.assert_array_equal(info["_final_obs"], done)
            for i in range(NUM_ENVS):
                if done[i]:
                    final = info["final_obs"][i]
                    assert final.shape == (4,) and not np.allclose(final, obs[i])
                    # a fresh episode starts near the upright rest state
                    assert np.max(np.abs(obs[i])) <= 0.011
                else:
                    assert info["final_obs"][i] is None
        else:
            assert "final_obs" not in info
        ended |= terminated
        if t == 11:
            # the envs still up at the limit are truncated, not terminated
            np.testing.assert_array_equal(truncated[2:], True)
    assert ended[:2].all() and not ended[2:].any()


def test_vector_truncation_follows_time_limit_when_termination_coincides(pendulum_vec):
    """Gymnasium's TimeLimit truncates at the limit even when the last step also terminates."""
    vec = pendulum_vec
    vec.reset(seed=0)
    state = vec._state
    last = state.replace(
        data=state.data.replace(qpos=state.data.qpos.at[:, 1].set(0.5)),  # tipped past 0.2 rad: terminates
        info={**state.info, "step": state.info["step"].at[:2].set(11)},  # envs 0, 1 at the 12-step limit
    )
    _, (_, _, terminated, truncated, _) = vec._step_fn(last, np.zeros((NUM_ENVS, 1), np.float32))
    np.testing.assert_array_equal(terminated, True)
    np.testing.assert_array_equal(truncated, [True, True, False, False])


def test_vector_discrete_actions_and_bad_actions_refused(cartpole_vec):
    vec = cartpole_vec
    vec.reset(seed=0)
    obs, reward, *_ = vec.step(np.array([0, 1, 0, 1]))
    assert obs.shape == (NUM_ENVS, 4) and np.all(reward == 1.0)
    with pytest.raises(ValueError, match=r"integer actions of shape \(4,\)"):
        vec.step(np.zeros((NUM_ENVS,), np.float32))
    with pytest.raises(ValueError, match=r"in \[0, 2\)"):
        vec.step(np.array([0, 1, 2, 0]))


def test_vector_bad_actions_and_sizes_refused(pendulum_vec):
    vec = pendulum_vec
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=r"real actions of shape \(4, 1\)"):
        vec.step(np.zeros((3, 1), np.float32))
    with pytest.raises(ValueError, match="finite"):
        vec.step(np.full((NUM_ENVS, 1), np.nan, np.float32))
    with pytest.raises(ValueError, match="num_envs must be a positive integer"):
        envs.gymnasium_vector_env("inverted_pendulum", 0)
    with pytest.raises(ValueError, match="unknown environment 'walker'"):
        envs.gymnasium_vector_env("walker", 2)
    with pytest.raises(ValueError, match="no Gymnasium id for 'pong'"):
        envs.gymnasium_env("pong")


def test_vector_jax_arrays_stay_on_device():
    vec = envs.gymnasium_vector_env("cartpole", NUM_ENVS, array_type="jax")
    obs, _ = vec.reset(seed=0)
    assert isinstance(obs, jax.Array)
    obs, reward, terminated, truncated, _ = vec.step(jax.numpy.zeros(NUM_ENVS, jax.numpy.int32))
    assert isinstance(obs, jax.Array) and isinstance(reward, jax.Array) and hasattr(obs, "__dlpack__")


def test_render_draws_env_zero(pendulum_vec):
    """``render_mode="rgb_array"`` draws a frame (of env 0 for the vector env); skipped, naming what
    is missing, where MuJoCo has no OpenGL backend."""
    from jaxpg import video

    problem = video.gl_problem()
    if problem is not None:
        pytest.skip(f"no rendering: {problem}")
    env = envs.gymnasium_env("inverted_pendulum", render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and frame.std() > 0
    vec = envs.gymnasium_vector_env("inverted_pendulum", NUM_ENVS, max_episode_steps=12, render_mode="rgb_array")
    vec.reset(seed=0)
    assert vec.render().shape == frame.shape
    assert pendulum_vec.render() is None  # no render_mode: nothing drawn
