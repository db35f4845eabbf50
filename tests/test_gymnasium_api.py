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
from jaxpg.envs import gymnasium_api, gymnasium_worker

NUM_ENVS = 4
SAME_STEP, NEXT_STEP = gymnasium.vector.AutoresetMode.SAME_STEP, gymnasium.vector.AutoresetMode.NEXT_STEP


@pytest.fixture(scope="module")
def pendulum_vec():
    return envs.gymnasium_vector_env("inverted_pendulum", NUM_ENVS, max_episode_steps=12, autoreset_mode=SAME_STEP)


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


# The MuJoCo suite's other ids (inverted_pendulum is above, in Gymnasium's physics), each checked
# through its fast-physics id (``jaxpg/<Name>Fast-v5``): the same ``JaxpgEnv`` class, calls, spaces and
# time limit as the id in Gymnasium's physics, which differs only in the model's integrator and solver
# options. Each check compiles its single env's reset and step; on two idle CPU cores Humanoid's took
# 27 s in fast physics against 56 s in Gymnasium's, Walker2d's 10 s against 31 s (and about three times
# as long when both test processes compile at once). Gymnasium's physics of every task is compiled and
# checked against Gymnasium step by step in test_envs.py's parity runs; the ids' specs, in
# test_envs.py's check_gymnasium_id. HumanoidStandup's id is left out here: its env is Humanoid's
# class of calls on a model of the same sizes, and its check took as long (48 s on two busy cores).
SUITE_IDS = {
    task: gym_id
    for task, (gym_id, _) in envs.GYMNASIUM_COUNTERPARTS.items()
    if task not in ("inverted_pendulum", "cartpole", "humanoid_standup")
}


@pytest.mark.parametrize(("name", "gym_id"), SUITE_IDS.items(), ids=list(SUITE_IDS))
def test_gymnasium_check_env_accepts_every_suite_id(name, gym_id):
    """Gymnasium's checker passes on ``gymnasium.make("jaxpg/<Name>Fast-v5")`` of every MuJoCo task,
    with no warning that Gymnasium's own env of that id does not also get, and the id's spec carries
    Gymnasium's time limit."""
    from gymnasium.utils.env_checker import check_env

    env = gymnasium.make(gymnasium_api.gymnasium_id(name, "fast"))
    assert env.spec.max_episode_steps == gymnasium.spec(gym_id).max_episode_steps
    in_gymnasium_physics = gymnasium.make(gymnasium_api.gymnasium_id(name))  # built here, compiled only if stepped
    assert in_gymnasium_physics.unwrapped.env.unwrapped.fidelity == "gymnasium" != env.unwrapped.env.unwrapped.fidelity
    assert in_gymnasium_physics.observation_space == env.observation_space
    assert in_gymnasium_physics.action_space == env.action_space
    assert in_gymnasium_physics.spec.max_episode_steps == env.spec.max_episode_steps
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
    assert obs.dtype == np.float64 and obs.shape == (4,) and info == {}
    for t in range(5):
        obs, reward, terminated, truncated, _ = env.step(np.zeros(1, np.float32))
        assert type(reward) is int and not terminated  # as Gymnasium's InvertedPendulum-v5 gives it
        assert truncated == (t == 4)


def test_vector_spaces(pendulum_vec, cartpole_vec):
    vec = pendulum_vec
    assert vec.num_envs == NUM_ENVS
    assert vec.single_observation_space == gymnasium.spaces.Box(-np.inf, np.inf, (4,), np.float64)
    assert vec.single_action_space == gymnasium.spaces.Box(-3.0, 3.0, (1,), np.float32)
    assert vec.observation_space.shape == (NUM_ENVS, 4) and vec.action_space.shape == (NUM_ENVS, 1)
    assert vec.metadata["autoreset_mode"] == SAME_STEP and cartpole_vec.metadata["autoreset_mode"] == NEXT_STEP
    assert cartpole_vec.single_action_space == gymnasium.spaces.Discrete(2)
    assert cartpole_vec.action_space == gymnasium.spaces.MultiDiscrete([2] * NUM_ENVS)
    obs, _ = vec.reset(seed=0)
    assert obs.dtype == np.float64 and obs.shape == (NUM_ENVS, 4) and vec.observation_space.contains(obs)


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
    _, out = vec._step_fn(last, np.zeros((NUM_ENVS, 1), np.float32))
    np.testing.assert_array_equal(out["terminated"], True)
    np.testing.assert_array_equal(out["truncated"], [True, True, False, False])


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


# ----- Gymnasium users' code unchanged on jaxpg's ids: one test per point of the issue -----

MJX_IDS = [i for i, (task, _) in gymnasium_api.GYMNASIUM_IDS.items() if task not in gymnasium_api.NO_FIDELITY]


def balance_cartpole(obs: np.ndarray) -> int:
    """A controller that keeps Gymnasium's CartPole up for thousands of steps."""
    return int(obs[2] + 0.5 * obs[3] + 0.05 * obs[0] + 0.1 * obs[1] > 0)


@pytest.fixture(scope="module")
def pendulum():
    """``gymnasium.make("jaxpg/InvertedPendulum-v5")``, compiled once for the tests below (and for
    every single env of that id made in this process)."""
    return gymnasium.make("jaxpg/InvertedPendulum-v5")


def test_id_simulates_gymnasium_physics_and_fast_physics_is_its_own_id(pendulum):
    """1. From Gymnasium's InvertedPendulum-v5 states with the same actions, jaxpg's id of it gives
    the same observations within 1e-4 (float32 against float64), the same rewards and ``info``, and
    ends all 8 episodes at the same steps (``fidelity="fast"`` ended 3 of 8 differently). The fast
    physics is an id of its own for every MuJoCo task (``jaxpg/<Name>Fast-v<N>``)."""
    theirs = gymnasium.make("InvertedPendulum-v5")
    assert pendulum.unwrapped.env.unwrapped.fidelity == "gymnasium"
    rng = np.random.default_rng(0)
    worst = 0.0
    for episode in range(8):
        theirs.reset(seed=episode)
        pendulum.reset(seed=episode)
        pendulum.unwrapped.set_state(theirs.unwrapped.data.qpos, theirs.unwrapped.data.qvel)
        for t in range(100):
            action = rng.uniform(-1, 1, 1).astype(np.float32)
            obs_t, reward_t, terminated_t, truncated_t, info_t = theirs.step(action)
            obs, reward, terminated, truncated, info = pendulum.step(action)
            worst = max(worst, float(np.max(np.abs(obs - obs_t))))
            assert (reward, terminated, truncated, info) == (reward_t, terminated_t, truncated_t, info_t), (episode, t)
            if terminated:
                break
    assert worst < 1e-4, worst
    for gym_id in MJX_IDS:
        assert gymnasium.spec(gym_id).kwargs == gymnasium.spec(gym_id.split("/")[1]).kwargs == {}  # Gymnasium's
        fast = gymnasium.spec(gymnasium_api.fast_id(gym_id))
        assert fast.kwargs == {"fidelity": "fast"} and fast.entry_point == gymnasium.spec(gym_id).entry_point
        assert fast.max_episode_steps == gymnasium.spec(gym_id).max_episode_steps
    assert gymnasium_api.gymnasium_id("hopper", fidelity="fast") == "jaxpg/HopperFast-v5"


def test_jaxpg_helpers_take_either_id_with_its_fidelity():
    """1. ``gymnasium_env`` and ``gymnasium_vector_env`` given an id use the id's physics and time
    limit (a task name keeps the task's defaults: fast physics); nothing here compiles."""
    for gym_id, fidelity in (("jaxpg/InvertedPendulum-v5", "gymnasium"), ("jaxpg/InvertedPendulumFast-v5", "fast")):
        assert gymnasium_api.gymnasium_id(gym_id) == gym_id
        assert envs.gymnasium_env(gym_id).unwrapped.env.unwrapped.fidelity == fidelity
        vec = envs.gymnasium_vector_env(gym_id, 2)
        assert (vec.env.unwrapped.fidelity, vec.env.max_episode_steps) == (fidelity, 1000)
    assert envs.gymnasium_vector_env("inverted_pendulum", 2).env.unwrapped.fidelity == "fast"
    with pytest.raises(ValueError, match="unknown fidelity 'exact'"):
        gymnasium_api.gymnasium_id("hopper", fidelity="exact")


def test_make_vec_async_works_with_no_arguments_after_jax_started():
    """2. ``make_vec(id, 2, vectorization_mode="async")`` with Gymnasium's default (fork) context,
    from a process where JAX is running: the workers' envs run in fresh interpreters, so reset and
    step answer (a deadlock fails at the timeouts instead of hanging the run)."""
    jax.numpy.zeros(1).block_until_ready()
    vec = gymnasium.make_vec("jaxpg/CartPole-v1", 2, vectorization_mode="async")
    try:
        vec.reset_async(seed=0)
        obs, _ = vec.reset_wait(timeout=180)
        vec.step_async(np.array([0, 1]))
        obs, reward, terminated, truncated, _ = vec.step_wait(timeout=60)
    finally:
        vec.close(terminate=True)
    assert obs.shape == (2, 4) and obs.dtype == np.float32 and np.all(reward == 1.0)


def test_worker_process_answers_calls_and_reports_errors():
    """2. The fresh-interpreter worker that serves a single env made after a fork: it gives the
    env's spaces, answers ``reset``/``step`` like the env, raises the env's own errors here, and
    exits on ``close``."""
    worker = gymnasium_worker.Worker({"task": "cartpole"})
    try:
        observation_space, action_space, _ = worker.spaces
        assert action_space == gymnasium.spaces.Discrete(2) and observation_space.shape == (4,)
        local = gymnasium_api.JaxpgEnv("cartpole")
        np.testing.assert_array_equal(worker.call("reset", seed=5)[0], local.reset(seed=5)[0])
        np.testing.assert_array_equal(worker.call("step", 1)[0], local.step(1)[0])
        with pytest.raises(ValueError, match="integer actions"):
            worker.call("step", 0.5)
    finally:
        worker.close()
    assert worker.process.returncode == 0
    with pytest.raises(ValueError, match="no Gymnasium env for task 'nope'"):
        gymnasium_worker.Worker({"task": "nope"})


def test_make_vec_reaches_the_batched_env_for_every_id():
    """3. Every id has a ``vector_entry_point``: ``make_vec``'s default mode builds
    ``JaxpgVectorEnv`` (one jitted step for all envs) with the id's fidelity and time limit."""
    for gym_id in gymnasium_api.GYMNASIUM_IDS:
        name = gymnasium.spec(gym_id.split("/")[1]).entry_point.split(":")[1].removesuffix("Env")  # Gymnasium's
        assert gymnasium.spec(gym_id).entry_point == f"jaxpg.envs.gymnasium_api:{name}Env", gym_id
        assert gymnasium.spec(gym_id).vector_entry_point == f"jaxpg.envs.gymnasium_api:{name}VectorEnv", gym_id
    vec = gymnasium.make_vec("jaxpg/CartPole-v1", NUM_ENVS)
    assert isinstance(vec, gymnasium_api.JaxpgVectorEnv) and vec.num_envs == NUM_ENVS
    assert vec.env.max_episode_steps == 500 and vec.metadata["autoreset_mode"] == NEXT_STEP


@pytest.fixture(scope="module")
def cartpole_batched():
    """``gymnasium.make_vec("jaxpg/CartPole-v1", 2)``: jaxpg's batched env, next-step autoreset."""
    vec = gymnasium.make_vec("jaxpg/CartPole-v1", 2)
    assert isinstance(vec, gymnasium_api.JaxpgVectorEnv)
    return vec


def test_next_step_autoreset_lets_gymnasium_vector_wrappers_compose(cartpole_batched):
    """4. Next-step autoreset (Gymnasium's default): the step after an episode ends ignores its
    action and returns the next episode's first observation with reward 0; Gymnasium's vector
    ``NormalizeObservation``, ``TransformObservation`` and ``DtypeObservation`` accept the env."""
    from gymnasium.wrappers import vector as vw

    vec = cartpole_batched
    wrapped = vw.DtypeObservation(vw.TransformObservation(vw.NormalizeObservation(vec), lambda o: o * 2.0), np.float64)
    obs, _ = wrapped.reset(seed=0)
    assert obs.dtype == np.float64
    ended = np.zeros(2, bool)
    restarted = 0
    for _ in range(60):
        obs, reward, terminated, truncated, _ = vec.step(np.array([1, 1]))  # both fall to the right
        done = terminated | truncated
        if ended.any():
            np.testing.assert_array_equal(reward[ended], 0.0)
            np.testing.assert_array_equal(done[ended], False)
            assert np.max(np.abs(obs[ended])) <= 0.05  # a fresh start
            restarted += int(ended.sum())
        ended = done
    assert restarted >= 2
    wrapped.step(np.array([0, 1]))


def test_same_step_autoreset_gives_final_obs_and_final_info(pendulum_vec):
    """4. Same-step autoreset: ``final_obs`` and ``final_info`` (the ended episodes' last ``info``)
    with their masks, as Gymnasium's sync vector env gives them."""
    vec = pendulum_vec
    vec.reset(seed=0)
    push = np.array([[3.0], [-3.0], [0.0], [0.0]], np.float32)
    for _ in range(12):
        _, _, terminated, truncated, info = vec.step(push)
        if (terminated | truncated).any():
            break
    done = terminated | truncated
    np.testing.assert_array_equal(info["_final_info"], done)
    np.testing.assert_array_equal(info["final_info"]["_reward_survive"], done)
    np.testing.assert_array_equal(info["final_info"]["reward_survive"][done], 0.0)  # the falling step
    assert info["_reward_survive"].tolist() == (~done).tolist()  # the fresh episodes' info has no reward


def test_max_episode_steps_above_the_registered_limit_is_honoured():
    """5. ``max_episode_steps`` above the registered limit: a balanced CartPole runs to 1000 steps as
    Gymnasium's does (it was cut at 500); the MuJoCo ids' single env has no limit of its own."""
    lengths = []
    for gym_id in ("jaxpg/CartPole-v1", "CartPole-v1"):
        env = gymnasium.make(gym_id, max_episode_steps=1000)
        obs, _ = env.reset(seed=0)
        steps, terminated, truncated = 0, False, False
        while not (terminated or truncated or steps > 1000):
            obs, _, terminated, truncated, _ = env.step(balance_cartpole(obs))
            steps += 1
        lengths.append((steps, terminated, truncated))
    assert lengths == [(1000, False, True)] * 2
    limit = gymnasium.make("jaxpg/Hopper-v5", max_episode_steps=5000).unwrapped.env.max_episode_steps
    assert limit >= 5000


def test_info_has_gymnasium_v5_keys_for_every_id():
    """6. ``info`` after ``reset`` and ``step`` has the keys of Gymnasium's env of the id
    (``x_position``, ``reward_forward`` ...), in Gymnasium's env and in jaxpg's: the env of the id
    that the checks above stepped (its fast-physics id for the suite), whose compiled ``reset`` and
    ``step`` this test shares. HumanoidStandup, which no check above steps, plays its fast-physics
    id too: the same keys, from a program that compiles in 18 s on two cores where Gymnasium's
    physics (RK4) takes 52 s."""
    fast_ids = {*SUITE_IDS, "humanoid_standup"}
    with mujoco_warnings_silenced():
        for gym_id, (task, _) in gymnasium_api.GYMNASIUM_IDS.items():
            theirs = gymnasium.make(gym_id.split("/")[1])
            _, reset_info = theirs.reset(seed=0)
            *_, step_info = theirs.step(theirs.action_space.sample())
            reset_keys, step_keys = gymnasium_api.INFO_KEYS[task]
            assert (set(reset_keys), set(step_keys)) == (set(reset_info), set(step_info)), gym_id
            ours = gymnasium.make(gymnasium_api.gymnasium_id(task, "fast") if task in fast_ids else gym_id)
            _, reset_info = ours.reset(seed=0)
            *_, step_info = ours.step(ours.action_space.sample())
            assert (set(reset_keys), set(step_keys)) == (set(reset_info), set(step_info)), ours.spec.id


def test_pendulum_info_and_check_environments_match(pendulum):
    """6, 8. Gymnasium's ``check_environments_match`` passes on the spaces, the info keys and the
    flags (values differ: the two envs start from different random states)."""
    from gymnasium.utils.env_match import check_environments_match

    theirs = gymnasium.make("InvertedPendulum-v5")
    assert pendulum.observation_space == theirs.observation_space
    check_environments_match(
        pendulum, theirs, num_steps=5, skip_obs=True, skip_rew=True, info_comparison="keys-equivalence"
    )


def test_envs_pickle_and_deep_copy_and_continue_the_same_episode(pendulum):
    """7. ``pickle`` and ``copy.deepcopy`` of a made env (what async vector envs and SB3 do): the
    copy continues the episode exactly as the original does."""
    import copy
    import pickle

    for env, action in ((gymnasium.make("jaxpg/CartPole-v1"), 1), (pendulum, np.array([0.5], np.float32))):
        env.reset(seed=3)
        env.step(action)
        copies = [pickle.loads(pickle.dumps(env)), copy.deepcopy(env)]
        expected = env.step(action)
        for other in copies:
            got = other.step(action)
            np.testing.assert_array_equal(got[0], expected[0])
            assert got[1:] == expected[1:]


def test_spaces_and_spec_match_gymnasium_for_every_id():
    """8. Observation and action spaces, time limit and ``reward_threshold`` of every id are those
    of Gymnasium's env (float64 MuJoCo observations, CartPole's bounded box)."""
    with mujoco_warnings_silenced():
        for gym_id in gymnasium_api.GYMNASIUM_IDS:
            ours, theirs = gymnasium.make(gym_id), gymnasium.make(gym_id.split("/")[1])
            assert ours.observation_space == theirs.observation_space, gym_id
            assert ours.action_space == theirs.action_space, gym_id
            assert ours.spec.reward_threshold == theirs.spec.reward_threshold, gym_id
            assert ours.spec.max_episode_steps == theirs.spec.max_episode_steps, gym_id


def test_old_gymnasium_gets_one_line_naming_the_version_needed():
    """9. ``import jaxpg.envs.gymnasium_api`` under a Gymnasium older than 1.1 (faked here) fails
    with one line naming the version needed."""
    import subprocess
    import sys

    code = (
        "import gymnasium, gymnasium.vector; gymnasium.__version__ = '1.0.0'; del gymnasium.vector.AutoresetMode\n"
        "import jaxpg.envs.gymnasium_api"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    last = done.stderr.strip().splitlines()[-1]
    assert done.returncode != 0
    assert last == (
        "ImportError: jaxpg's Gymnasium API needs gymnasium>=1.1, found 1.0.0: pip install -U 'gymnasium>=1.1'"
    )
    with pytest.raises(ImportError, match=r"needs gymnasium>=1\.1, found 0\.29\.1"):
        gymnasium_api.check_gymnasium_version("0.29.1")
    gymnasium_api.check_gymnasium_version(gymnasium.__version__)


def test_closed_env_refuses_to_step_and_reset():
    """10. After ``close()`` the single and the vector env raise instead of stepping on."""
    env = gymnasium.make("jaxpg/CartPole-v1")
    env.reset(seed=0)
    env.close()
    with pytest.raises(RuntimeError, match="closed"):
        env.step(0)
    with pytest.raises(RuntimeError, match="closed"):
        env.reset()
    vec = envs.gymnasium_vector_env("cartpole", NUM_ENVS)
    vec.reset(seed=0)
    vec.close()
    with pytest.raises(RuntimeError, match="closed"):
        vec.step(np.zeros(NUM_ENVS, int))


# ----- a Gymnasium pipeline gives the same results on a jaxpg id as on Gymnasium's id -----


class StartLike(gymnasium.Wrapper):
    """Gymnasium's own env, started where jaxpg's env of ``jaxpg_id`` starts for the same seeds: a
    twin jaxpg env is reset alongside and its start state copied in (autoresets included), so that
    the two ids can be compared step by step through any pipeline."""

    def __init__(self, env: gymnasium.Env, jaxpg_id: str):
        super().__init__(env)
        self.twin = gymnasium.make(jaxpg_id).unwrapped

    def reset(self, *, seed=None, options=None):
        _, info = self.env.reset(seed=seed, options=options)
        self.twin.reset(seed=seed)
        data, inner = self.twin._state.data, self.env.unwrapped
        if hasattr(data, "qpos"):
            inner.set_state(np.asarray(data.qpos, np.float64), np.asarray(data.qvel, np.float64))
            return inner._get_obs(), info
        inner.state = np.asarray(data.state, np.float64)
        return np.array(inner.state, np.float32), info


def run_pipeline(vec, actions: np.ndarray) -> dict[str, np.ndarray]:
    """Observations, rewards, flags and ``RecordEpisodeStatistics``' episode returns and lengths
    (NaN where no episode ended) of ``vec`` under ``actions [T, num_envs, ...]`` from seed 0."""
    obs, _ = vec.reset(seed=0)
    rows: dict[str, list] = {"obs": [obs], "reward": [], "terminated": [], "truncated": [], "r": [], "l": []}
    for action in actions:
        obs, reward, terminated, truncated, info = vec.step(action)
        ended = info.get("_episode", np.zeros(vec.num_envs, bool))
        episode = info.get("episode", {"r": np.zeros(vec.num_envs), "l": np.zeros(vec.num_envs)})
        for key, value in (("obs", obs), ("reward", reward), ("terminated", terminated), ("truncated", truncated)):
            rows[key].append(value)
        rows["r"].append(np.where(ended, episode["r"], np.nan))
        rows["l"].append(np.where(ended, episode["l"], np.nan))
    return {k: np.asarray(v, np.float64) for k, v in rows.items()}


def assert_same_results(ours: dict[str, np.ndarray], theirs: dict[str, np.ndarray], tolerance: float) -> None:
    """Flags and episode lengths equal; observations, rewards and episode returns within
    ``tolerance``; and at least two episodes ended in the comparison."""
    for key in ("terminated", "truncated", "l"):
        np.testing.assert_array_equal(ours[key], theirs[key], err_msg=key)
    for key in ("obs", "reward", "r"):
        np.testing.assert_allclose(ours[key], theirs[key], rtol=tolerance, atol=tolerance, err_msg=key)
    assert np.sum(~np.isnan(ours["l"])) >= 2


def test_pipeline_sync_single_env_wrappers_same_results_as_gymnasium(pendulum):
    """Gymnasium's sync vector env of ``RecordEpisodeStatistics``, ``ClipAction``,
    ``NormalizeObservation`` and ``NormalizeReward`` around single envs, an 8-step time limit (so
    that episodes end both ways) and out-of-range actions: ``jaxpg/InvertedPendulum-v5`` gives
    Gymnasium's results within 1e-3 (float32 MJX against float64 MuJoCo, amplified by the
    normalisation; measured 7e-7)."""
    from gymnasium import wrappers as w

    del pendulum  # compiled there: the sync env's single envs reuse it
    pipeline = [w.RecordEpisodeStatistics, w.ClipAction, w.NormalizeObservation, w.NormalizeReward]
    actions = np.random.default_rng(1).uniform(-4, 4, (80, 2, 1)).astype(np.float32)
    ours = gymnasium.make_vec("jaxpg/InvertedPendulum-v5", 2, "sync", wrappers=pipeline, max_episode_steps=8)
    start_like = lambda env: StartLike(env, "jaxpg/InvertedPendulum-v5")  # noqa: E731
    theirs = gymnasium.make_vec("InvertedPendulum-v5", 2, "sync", wrappers=[start_like, *pipeline], max_episode_steps=8)
    assert_same_results(run_pipeline(ours, actions), run_pipeline(theirs, actions), 1e-3)


def test_pipeline_batched_and_async_same_results_as_gymnasium(cartpole_batched):
    """``make_vec("jaxpg/CartPole-v1", 2)`` (the batched env) under Gymnasium's vector
    ``RecordEpisodeStatistics``, ``NormalizeObservation`` and ``NormalizeReward``, and the async
    vector env of single envs under the single-env wrappers, both give the results of Gymnasium's
    ``CartPole-v1`` in a sync vector env under the same wrappers, within 1e-4 (float32 against
    float64 arithmetic), episodes, autoresets and statistics included."""
    from gymnasium import wrappers as w
    from gymnasium.wrappers import vector as vw

    actions = np.random.default_rng(2).integers(0, 2, (120, 2))
    start_like = lambda env: StartLike(env, "jaxpg/CartPole-v1")  # noqa: E731

    def vector_pipeline(vec):
        return vw.NormalizeReward(vw.NormalizeObservation(vw.RecordEpisodeStatistics(vec)))

    ours = run_pipeline(vector_pipeline(cartpole_batched), actions)
    theirs = run_pipeline(vector_pipeline(gymnasium.make_vec("CartPole-v1", 2, "sync", wrappers=[start_like])), actions)
    assert_same_results(ours, theirs, 1e-4)

    single = [w.RecordEpisodeStatistics, w.NormalizeObservation, w.NormalizeReward]
    vec = gymnasium.make_vec("jaxpg/CartPole-v1", 2, "async", wrappers=single)
    try:
        ours = run_pipeline(vec, actions)
    finally:
        vec.close(terminate=True)
    theirs = run_pipeline(gymnasium.make_vec("CartPole-v1", 2, "sync", wrappers=[start_like, *single]), actions)
    assert_same_results(ours, theirs, 1e-4)


def test_gymnasium_keywords_reach_the_task():
    """Gymnasium's keyword arguments of an env, given to ``gymnasium.make`` of a jaxpg id, reach
    the task with their meaning: the spaces match Gymnasium's own env made with the same ones, and
    the task holds, for every term Gymnasium's env keeps as ``_<keyword>`` (healthy ranges, reward
    weights, termination switch ...), the value Gymnasium's holds: the one given, or its default."""
    for gym_id, keywords in (
        ("Ant-v5", {"include_cfrc_ext_in_observation": False, "contact_cost_weight": 1e-3}),
        ("Hopper-v5", {"exclude_current_positions_from_observation": False, "healthy_z_range": (0.5, 2.0)}),
        ("Humanoid-v5", {"include_cinert_in_observation": False, "terminate_when_unhealthy": False}),
    ):
        ours = gymnasium.make(f"jaxpg/{gym_id}", **keywords)
        theirs = gymnasium.make(gym_id, **keywords)
        assert ours.observation_space.shape == theirs.observation_space.shape, gym_id
        task = ours.unwrapped.env.unwrapped
        terms = [
            name[1:]
            for name in vars(theirs.unwrapped)
            if name.startswith("_") and hasattr(task, name[1:]) and not callable(getattr(task, name[1:]))
        ]
        assert set(keywords) - {k for k in keywords if k.startswith(("include_", "exclude_"))} <= set(terms), gym_id
        for name in terms:
            assert getattr(task, name) == getattr(theirs.unwrapped, f"_{name}"), (gym_id, name)
        ours.close()
        theirs.close()
