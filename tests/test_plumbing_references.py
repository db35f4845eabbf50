"""The plumbing between the env and the learner, each piece against an independent reference: value
targets and standardised advantages against hand-built batches in NumPy, observation statistics
over the valid samples only, the observation clip, the training key's stream, the mean policy's
evaluation against a loop of its mode, ``AutoReset``'s final observation against a loop that resets
by hand, ``ClipAction`` against Gymnasium's, and the time limit against Gymnasium's ``TimeLimit``.

Everything runs on CartPole (pure JAX, cheap to compile) or on small hand-made arrays; the one
MuJoCo task (Hopper, for ``ClipAction``'s control cost) has its physics step replaced, so nothing
here compiles a physics step.
"""

from __future__ import annotations

from types import SimpleNamespace

import gymnasium as gym
import jax
import jax.numpy as jnp
import numpy as np
import numpy_reference as ref
import pytest

import jaxpg.envs as envs
from jaxpg import rollout as rollout_lib
from jaxpg import train
from jaxpg.algos import core, npg
from jaxpg.algos.core.state import RunningStats
from jaxpg.rollout import Trajectory

GAMMA = 0.9
SMALL = dict(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=8)


@pytest.fixture(scope="module")
def cartpole():
    return envs.make("cartpole")


def env_major(x: np.ndarray) -> np.ndarray:
    """``[T, B, ...] -> [B * T, ...]``, env by env: the row order of every training batch."""
    x = np.asarray(x)
    return np.swapaxes(x, 0, 1).reshape((-1,) + x.shape[2:])


# --------------------------------------------------------------------------------------------
# Value targets and advantages


def numpy_returns(rewards, terminated, truncated, next_values, gamma):
    """``[T, B]`` discounted returns by a backward loop: a terminated step ends with its reward, a
    truncated one adds ``gamma V(next_obs)``, and the last row, if its episode goes on, too."""
    steps, batch = rewards.shape
    out = np.zeros((steps, batch))
    for b in range(batch):
        for t in reversed(range(steps)):
            if terminated[t, b]:
                after = 0.0
            elif truncated[t, b] or t == steps - 1:
                after = next_values[t, b]
            else:
                after = out[t + 1, b]
            out[t, b] = rewards[t, b] + gamma * after
    return out


def test_returns_value_target_bootstraps_at_truncation_and_the_last_row():
    """``value_target="returns"`` (as LyceumAI fits): the value targets of a hand-built ``[6, 5]``
    batch are discounted returns that bootstrap ``V(next_obs)`` where an episode was truncated and
    at the batch's last row, and stop at terminations (a NumPy loop); with either recursion. The
    columns end in a truncation, a termination, a running episode, one truncated then one running,
    and both flags (termination wins). float32 sums of six terms: relative error ~1e-6."""
    rng = np.random.default_rng(0)
    steps, batch = 6, 5
    terminated = np.zeros((steps, batch), bool)
    truncated = np.zeros((steps, batch), bool)
    truncated[5, 0] = True
    terminated[5, 1] = True
    truncated[2, 3] = True
    terminated[3, 4] = truncated[3, 4] = True
    terminated[1, 2] = True
    rewards = rng.normal(size=(steps, batch))
    values, next_values = rng.normal(size=(steps, batch)), 5.0 + rng.normal(size=(steps, batch))
    traj = SimpleNamespace(
        rewards=jnp.asarray(rewards, jnp.float32), terminated=jnp.asarray(terminated), truncated=jnp.asarray(truncated)
    )
    expected = numpy_returns(rewards, terminated, truncated, next_values, GAMMA)
    assert np.abs(expected - numpy_returns(rewards, terminated, truncated, 0 * next_values, GAMMA)).max() > 1.0
    ts = SimpleNamespace(config=npg.Config(gamma=GAMMA, gae_lambda=0.8, value_target="returns"))
    for parallel in (False, True):
        advantages, targets = core.gae_advantages(
            ts, traj, jnp.asarray(values, jnp.float32), jnp.asarray(next_values, jnp.float32), parallel=parallel
        )
        np.testing.assert_allclose(np.asarray(targets), expected, rtol=1e-5, atol=1e-5)
        gae = ref.gae(rewards, values, next_values, terminated, truncated, GAMMA, 0.8)
        np.testing.assert_allclose(np.asarray(advantages), gae, rtol=1e-5, atol=1e-5)


def hand_trajectory(obs_size: int, rng: np.random.Generator) -> Trajectory:
    """An episodic ``[8, 4]`` batch built by hand: env 0 terminates at step 2, env 1 is truncated
    at step 4, env 2 terminates at its last step, env 3 runs on; ``valid`` covers each env up to
    its episode's end. The padding after an end holds rewards of 100 and observations near 50,
    far from the valid samples', so that a statistic that counts them is far off."""
    steps, batch = 8, 4
    terminated = np.zeros((steps, batch), bool)
    truncated = np.zeros((steps, batch), bool)
    terminated[2, 0], truncated[4, 1], terminated[7, 2] = True, True, True
    valid = np.ones((steps, batch), np.float32)
    valid[3:, 0], valid[5:, 1] = 0.0, 0.0
    obs = rng.normal(size=(steps, batch, obs_size))
    obs[valid == 0] = 50.0 + rng.normal(size=(int((valid == 0).sum()), obs_size))
    rewards = np.where(valid > 0, rng.normal(size=(steps, batch)), 100.0)
    zeros = jnp.zeros((steps, batch), jnp.float32)
    metric_names = ("episode_done", "episode_return", "episode_length", "episode_task_score")
    return Trajectory(
        obs=jnp.asarray(obs, jnp.float32),
        actions=jnp.zeros((steps, batch), jnp.int32),
        log_probs=zeros,
        rewards=jnp.asarray(rewards, jnp.float32),
        terminated=jnp.asarray(terminated),
        truncated=jnp.asarray(truncated),
        next_obs=jnp.asarray(np.roll(obs, -1, axis=0) + 0.1, jnp.float32),
        valid=jnp.asarray(valid),
        metrics={k: zeros for k in (*metric_names, "nonfinite", "invalid_action", "physics_overflow")},
    )


def test_advantages_are_standardised_over_the_valid_samples_only(cartpole):
    """``phase_advantages`` of a hand-built episodic batch with padding (``hand_trajectory``) under
    observation statistics: GAE over the value network's predictions at the normalised ``obs`` and
    ``next_obs`` (a float64 NumPy forward pass), standardised with the mean
    and std of the valid samples alone, 0 on the padding; the value targets are the lambda-returns.
    float32 network and recursions over 8 steps: errors ~1e-6 of values of size ~1."""
    ts = npg.init(jax.random.PRNGKey(0), cartpole, npg.Config(**SMALL, sampling="episodic", gamma=GAMMA))
    rng = np.random.default_rng(1)
    traj = hand_trajectory(cartpole.observation_size, rng)
    obs_mean, obs_var = rng.normal(size=cartpole.observation_size), rng.uniform(0.2, 4.0, cartpole.observation_size)
    stats = RunningStats(
        mean=jnp.asarray(obs_mean, jnp.float32), var=jnp.asarray(obs_var, jnp.float32), count=jnp.asarray(5.0)
    )
    ts = ts.replace(obs_stats=stats)
    batch = jax.jit(core.phase_advantages)(ts, traj)

    config = ts.config
    value_params = ref.to_numpy(ts.value_params)

    def v(x: jax.Array) -> np.ndarray:
        x = numpy_normalize(np.asarray(x, np.float64), stats)
        return ref.mlp_forward(value_params, x.reshape(-1, x.shape[-1]), config.value_activation)[0].reshape(
            x.shape[:2]
        )

    values, next_values = v(traj.obs), v(traj.next_obs)
    rewards, terminated, truncated = (np.asarray(a) for a in (traj.rewards, traj.terminated, traj.truncated))
    gae = ref.gae(rewards, values, next_values, terminated, truncated, config.gamma, config.gae_lambda)
    valid = np.asarray(traj.valid) > 0
    mean, std = gae[valid].mean(), gae[valid].std()
    assert abs(gae.mean() - mean) > 1.0  # the padding would move the statistics a long way
    expected = np.where(valid, (gae - mean) / std, 0.0)
    np.testing.assert_allclose(np.asarray(batch.advantages), env_major(expected), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(
        np.asarray(batch.value_targets)[env_major(valid)],
        env_major(gae + values)[env_major(valid)],
        rtol=1e-5,
        atol=1e-5,
    )
    np.testing.assert_array_equal(np.asarray(batch.weights), env_major(valid).astype(np.float32))
    obs = numpy_normalize(np.asarray(traj.obs, np.float64), stats)
    np.testing.assert_allclose(np.asarray(batch.obs), env_major(obs), rtol=1e-5, atol=1e-5)


def test_observation_statistics_count_only_the_valid_samples(cartpole):
    """``finish_iteration`` with ``normalize_observations`` merges the valid observations of each
    batch, and only those, into the running statistics: after two hand-built episodic batches with
    padding (``hand_trajectory``) they are NumPy's mean and population variance of the valid rows of
    both. float32 sums of ~50 values of size ~1: errors ~1e-6."""
    config = npg.Config(**SMALL, sampling="episodic", normalize_observations=True)
    ts = npg.init(jax.random.PRNGKey(0), cartpole, config)
    rng = np.random.default_rng(2)
    seen = []
    for _ in range(2):
        traj = hand_trajectory(cartpole.observation_size, rng)
        seen.append(np.asarray(traj.obs, np.float64)[np.asarray(traj.valid) > 0])
        zero = jnp.zeros(())
        ts, _ = core.finish_iteration(ts, ts, traj, loss=zero, kl=zero, metrics={})
    rows = np.concatenate(seen)
    assert float(ts.obs_stats.count) == len(rows)
    np.testing.assert_allclose(np.asarray(ts.obs_stats.mean), rows.mean(axis=0), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(np.asarray(ts.obs_stats.var), rows.var(axis=0), rtol=1e-5, atol=1e-5)


def test_normalised_observations_are_clipped_at_ten():
    """``RunningStats.normalize``: ``(obs - mean) / sqrt(var + 1e-8)`` clipped to [-10, 10] (the clip
    of Stable-Baselines3's ``VecNormalize`` and Brax), written out in NumPy for values inside,
    between 5 and 10 and beyond 10 standard deviations; the identity before any update."""
    mean, var = np.array([1.0, -2.0, 0.0, 3.0, 0.5, 0.0]), np.array([4.0, 0.25, 1.0, 9.0, 1.0, 2.0])
    stats = RunningStats(mean=jnp.asarray(mean), var=jnp.asarray(var), count=jnp.asarray(10.0))
    obs = np.array([[1.0 + 2 * 7.5, -2.0 - 0.5 * 6.0, 3.0, 3.0 + 3 * 12.0, -30.0, 0.4]])
    expected = np.clip((obs - mean) / np.sqrt(var + 1e-8), -10.0, 10.0)
    assert np.any(np.abs(expected) > 5.0) and np.any(np.abs(expected) == 10.0)
    for normalize in (stats.normalize, jax.jit(stats.normalize)):
        np.testing.assert_allclose(np.asarray(normalize(jnp.asarray(obs))), expected, rtol=1e-6)
    fresh = RunningStats.create(6)
    np.testing.assert_array_equal(np.asarray(fresh.normalize(jnp.asarray(obs))), obs.astype(np.float32))


# --------------------------------------------------------------------------------------------
# RNG streams and the mean policy's evaluation


def test_every_iteration_samples_with_a_fresh_key(cartpole):
    """``phase_sample`` advances the training key: two iterations of episodic sampling from the same
    parameters start from other resets and draw other actions (with a key left as it was, every
    iteration would sample the same episodes); the key for the iteration's later phases is a third,
    distinct stream."""
    ts = npg.init(jax.random.PRNGKey(0), cartpole, npg.Config(**SMALL, sampling="episodic"))
    sample = jax.jit(core.phase_sample)
    first, traj1, rest1 = sample(ts)
    second, traj2, rest2 = sample(first)
    keys = [np.asarray(k) for k in (ts.key, first.key, second.key, rest1, rest2)]
    assert len({k.tobytes() for k in keys}) == len(keys)
    assert not np.array_equal(np.asarray(traj1.obs[0]), np.asarray(traj2.obs[0]))  # other resets
    assert not np.array_equal(np.asarray(traj1.actions), np.asarray(traj2.actions))


EVAL_LIMIT = 100  # the time limit of the evaluated CartPole: eval_horizon 0 evaluates up to it
BALANCE = np.array([0.1, 0.5, 1.0, 1.0])  # CartPole's balancing direction (``_balance`` below)
OBS_SCALE = np.array([2.0, 0.5, 4.0, 0.25])  # the std of the observation statistics the policies act on


def numpy_normalize(obs: np.ndarray, stats: RunningStats) -> np.ndarray:
    """``(obs - mean) / sqrt(var + 1e-8)`` clipped to [-10, 10], in float64 (the identity before any update)."""
    if float(stats.count) == 0:
        return obs
    mean, var = np.asarray(stats.mean, np.float64), np.asarray(stats.var, np.float64)
    return np.clip((obs - mean) / np.sqrt(var + 1e-8), -10.0, 10.0)


def mean_policy_loop(env, params, obs_stats, reset_keys) -> tuple[np.ndarray, np.ndarray]:
    """Returns and lengths of single envs started from ``reset_keys`` and stepped one at a time with
    the mode of a categorical policy of one linear layer (``argmax`` of its logits, in NumPy, on the
    observations normalised in NumPy) until the episode ends."""
    reset, step = jax.jit(env.reset), jax.jit(env.step)
    numpy_params = ref.to_numpy(params)
    returns, lengths = [], []
    for key in reset_keys:
        state, total, length = reset(key), 0.0, 0
        while True:
            obs = numpy_normalize(np.asarray(state.obs, np.float64)[None], obs_stats)
            logits = ref.policy_forward("categorical", numpy_params, obs, "tanh")["logits"][0]
            state = step(state, jnp.int32(np.argmax(logits)))
            total, length = total + float(state.reward), length + 1
            if bool(state.done):
                break
        returns.append(total)
        lengths.append(length)
    return np.array(returns), np.array(lengths)


def test_evaluation_plays_the_mode_of_the_policy():
    """``core.evaluate`` (one seed) and ``core.evaluate_seeds_together`` (two seeds in one batch)
    against ``mean_policy_loop``: each seed's episodes, from the reset keys its key gives, played
    with the policy's mode on observations normalised by the seed's statistics, to the task's time
    limit (``eval_horizon`` 0), have the mean return and length the evaluation reports. The policies
    are linear: on the normalised observations seed 0's mode is a balancing controller, which keeps
    the pole up to the 100-step limit, seed 1's pushes the other way and drops it within a few
    steps; their logits differ by tenths, so that sampling from them picks the other action often
    and ends seed 0's episodes early, and acting on raw observations weighs them otherwise. (A logit
    gap within float32 rounding of 0 could make the float64 loop pick the other action; the small
    linear layer keeps the two computations within 1e-6.)"""
    env = envs.make("cartpole", max_episode_steps=EVAL_LIMIT)
    config = npg.Config(**{**SMALL, "policy_hidden": ()}, eval_envs=3, eval_horizon=0)
    ts = train.init_seeds(npg.init, [0, 1], env, config)
    w = np.stack([np.stack([-BALANCE, BALANCE], axis=1) * OBS_SCALE[:, None] * sign for sign in (1.0, -1.0)])
    stats = RunningStats(
        mean=jnp.zeros((2, 4)), var=jnp.asarray(np.tile(OBS_SCALE**2, (2, 1)), jnp.float32), count=jnp.full((2,), 10.0)
    )
    ts = ts.replace(params=[{"w": jnp.asarray(w, jnp.float32), "b": jnp.zeros((2, 2))}], obs_stats=stats)
    keys = jax.random.split(jax.random.PRNGKey(5), 2)
    together = jax.jit(core.evaluate_seeds_together)(ts, keys)
    alone = jax.jit(core.evaluate)(jax.tree.map(lambda x: x[0], ts), keys[0])
    expected = []
    for seed in (0, 1):
        params = jax.tree.map(lambda x, s=seed: x[s], ts.params)
        seed_stats = jax.tree.map(lambda x, s=seed: x[s], ts.obs_stats)
        reset_key, _ = jax.random.split(keys[seed])
        expected.append(mean_policy_loop(env, params, seed_stats, jax.random.split(reset_key, config.eval_envs)))
    assert np.all(expected[0][1] == EVAL_LIMIT) and np.all(expected[1][1] < 20), expected
    for seed, (returns, lengths) in enumerate(expected):
        np.testing.assert_allclose(float(together["episode_return"][seed]), returns.mean(), rtol=1e-6)
        np.testing.assert_allclose(float(together["episode_length"][seed]), lengths.mean(), rtol=1e-6)
    np.testing.assert_allclose(float(alone["episode_return"]), expected[0][0].mean(), rtol=1e-6)
    np.testing.assert_allclose(float(alone["episode_length"]), expected[0][1].mean(), rtol=1e-6)


# --------------------------------------------------------------------------------------------
# Wrappers: AutoReset, ClipAction, the time limit

LIMIT = 16
ROLLOUT_ENVS, ROLLOUT_STEPS = 3, 40


def random_act(env: envs.Env):
    """``act_fn`` of uniform random actions of a discrete task."""

    def act(params, obs, key):
        return jax.random.randint(key, (obs.shape[0],), 0, env.action_size), jnp.zeros(obs.shape[0])

    return act


def test_auto_reset_rollout_matches_a_loop_that_resets_by_hand():
    """A continuing ``rollout`` (``AutoReset``) of CartPole, 3 envs over 40 steps with a 16-step
    limit, against single envs without ``AutoReset``, stepped one at a time and reset by hand when
    an episode ends (from the key the ended episode carries, as ``AutoReset`` does; Gymnasium's
    vector envs reset the same way): every transition equal: ``obs``, the final observation of each
    ended episode in ``next_obs``, rewards, ``terminated`` and ``truncated`` (both of which occur),
    and the episode statistics where an episode ended. (An MJX task's automatic reset is checked in
    tests/test_envs.py.) The jitted single step and the vmapped one may round apart: to float32
    rounding, grown over an episode of at most 16 steps."""
    env = envs.make("cartpole", max_episode_steps=LIMIT)
    auto = envs.AutoReset(env)
    act = random_act(env)
    k_reset, k_roll = jax.random.split(jax.random.key(7))
    start = rollout_lib.reset_batch(auto, k_reset, ROLLOUT_ENVS)
    _, traj = jax.jit(lambda s, k: rollout_lib.rollout(auto, act, None, s, k, ROLLOUT_STEPS))(start, k_roll)

    reset, step = jax.jit(env.reset), jax.jit(env.step)
    states = [reset(k) for k in jax.random.split(k_reset, ROLLOUT_ENVS)]
    rows = {k: [] for k in ("obs", "next_obs", "rewards", "terminated", "truncated", "return", "length")}
    for key in jax.random.split(k_roll, ROLLOUT_STEPS):
        actions, _ = act(None, jnp.stack([s.obs for s in states]), key)
        stepped = [step(s, a) for s, a in zip(states, actions, strict=True)]
        rows["obs"].append([np.asarray(s.obs) for s in states])
        rows["next_obs"].append([np.asarray(s.obs) for s in stepped])
        rows["rewards"].append([float(s.reward) for s in stepped])
        rows["terminated"].append([bool(s.terminated) for s in stepped])
        rows["truncated"].append([bool(s.truncated) for s in stepped])
        rows["return"].append([float(s.metrics["episode_return"]) for s in stepped])
        rows["length"].append([float(s.metrics["episode_length"]) for s in stepped])
        states = [reset(s.info["rng"]) if bool(s.done) else s for s in stepped]
    loop = {k: np.array(v) for k, v in rows.items()}
    assert loop["terminated"].any() and loop["truncated"].any()
    for name in ("terminated", "truncated"):
        np.testing.assert_array_equal(np.asarray(getattr(traj, name)), loop[name], err_msg=name)
    for name in ("obs", "next_obs", "rewards"):
        np.testing.assert_allclose(np.asarray(getattr(traj, name)), loop[name], rtol=1e-5, atol=1e-5, err_msg=name)
    done = loop["terminated"] | loop["truncated"]
    np.testing.assert_array_equal(np.asarray(traj.metrics["episode_done"]) > 0, done)
    for name, metric in (("return", "episode_return"), ("length", "episode_length")):
        np.testing.assert_allclose(np.asarray(traj.metrics[metric])[done], loop[name][done], rtol=1e-6, err_msg=name)


def _balance(obs: np.ndarray) -> int:
    """A linear controller that keeps CartPole up for hundreds of steps."""
    return int(np.dot([0.1, 0.5, 1.0, 1.0], obs) > 0)


@pytest.mark.parametrize("limit", [1, LIMIT])
def test_time_limit_truncates_where_gymnasiums_does(limit):
    """jaxpg's CartPole with ``max_episode_steps=limit`` beside Gymnasium's ``CartPole-v1`` under
    its ``TimeLimit(limit)``, from the same state under a balancing controller: both truncate at the
    same step, the ``limit``-th, not terminated, and ``EpisodeStats`` reports an episode of that
    length."""
    env = envs.make("cartpole", max_episode_steps=limit)
    gym_env = gym.make("CartPole-v1", max_episode_steps=limit)
    gym_env.reset(seed=0)
    step = jax.jit(env.step)
    state = env.reset(jax.random.key(0))
    gym_env.unwrapped.state = np.asarray(state.data.state, np.float64)
    obs, length = np.asarray(state.obs), 0
    while True:
        length += 1
        action = _balance(obs)
        obs, _, terminated, truncated, _ = gym_env.step(action)
        state = step(state, jnp.int32(action))
        assert (bool(state.terminated), bool(state.truncated)) == (terminated, truncated), length
        if terminated or truncated or length > limit + 1:
            break
    assert (length, terminated, truncated) == (limit, False, True)
    assert float(state.metrics["episode_length"]) == limit and float(state.metrics["episode_done"]) == 1.0


def test_clip_action_clips_as_gymnasiums_clip_action():
    """``make``'s ``ClipAction`` clips each actuator's action to the task's range before the task
    sees it, as Gymnasium's ``ClipAction`` wrapper does: Hopper's control, and its control cost
    (charged on the action the task receives), for actions out of range are Gymnasium's under
    ``ClipAction`` (``info["reward_ctrl"]``). MuJoCo clamps the control to ``ctrlrange`` in its
    physics anyway; the cost term and ``data.ctrl`` show what the task received. The physics step is
    replaced by one that only stores the control: nothing is simulated."""
    env = envs.make("hopper", impl="jax")
    env.unwrapped.physics_step = lambda data, ctrl: data.replace(ctrl=ctrl)
    inner = gym.make("Hopper-v5")
    low, high = inner.action_space.low, inner.action_space.high  # the range ClipAction clips to
    gym_env = gym.wrappers.ClipAction(inner)  # (which then accepts any action)
    gym_env.reset(seed=0)
    assert np.all(low == env.action_low) and np.all(high == env.action_high)
    state = env.reset(jax.random.key(0))
    for action in (np.array([3.0, -2.0, 0.5]), np.array([-7.0, 0.25, 1.5])):
        _, _, _, _, info = gym_env.step(action)
        stepped = env.step(state, jnp.asarray(action, jnp.float32))
        np.testing.assert_array_equal(np.asarray(stepped.data.ctrl), np.clip(action, low, high).astype(np.float32))
        np.testing.assert_allclose(float(stepped.metrics["reward_ctrl"]), info["reward_ctrl"], rtol=1e-6)
