"""Atari Pong on the ROM (``jaxpg.envs.atari``): Karpathy's preprocessing against a NumPy reference
on ALE frames, the task's frames against Gymnasium's ``ALE/Pong-v5``, games that end and restart,
the one-line error without the ``atari`` extra, a short training run through
``experiments/atari_pong.py`` and ``python -m jaxpg.evaluate RUN --ale`` on its tiny policy."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxpg import rollout
from jaxpg.envs import AutoReset, EpisodeStats
from jaxpg.run.evaluation import evaluate_cli, replay

ROOT = Path(__file__).resolve().parents[1]
ale_py = pytest.importorskip("ale_py")

from script_loader import load_script  # noqa: E402

from jaxpg.envs import atari  # noqa: E402


def karpathy_prepro(frame):
    """Karpathy's ``prepro`` as written in "Pong from pixels", on one 210x160x3 frame."""
    frame = frame[35:195]
    frame = frame[::2, ::2, 0].astype(np.float64)
    frame[frame == 144] = 0
    frame[frame == 109] = 0
    frame[frame != 0] = 1
    return frame.astype(np.float32).ravel()


def ale_frames(actions, sticky=False, seed=0):
    """``[T + 1, 210, 160, 3]`` frames of ``ALE/Pong-v5`` from its reset, and the rewards ``[T]``."""
    env = atari.make_ale_env(sticky=sticky)
    frames = [env.reset(seed=seed)[0]]
    rewards = []
    for a in actions:
        frame, reward, terminated, truncated, _ = env.step(int(a))
        frames.append(frame)
        rewards.append(reward)
        assert not (terminated or truncated)
    env.close()
    return np.stack(frames), np.asarray(rewards)


@pytest.fixture(scope="module")
def frames():
    # Long enough for points to be scored (the score digits change above the cropped court).
    actions = np.random.default_rng(0).integers(0, 6, size=400)
    frames, rewards = ale_frames(actions)
    assert np.any(rewards != 0)
    return frames


@pytest.mark.parametrize("backend", ["numpy", "jax", "jit"])
def test_preprocessing_matches_karpathys_on_ale_frames(frames, backend):
    expected = np.stack([karpathy_prepro(f) for f in frames])
    assert expected.shape == (len(frames), 6400)
    assert 0 < expected.sum(axis=1).min()  # paddles and ball survive the background's removal
    if backend == "numpy":
        got = atari.preprocess(frames)
    elif backend == "jax":
        got = atari.preprocess(jnp.asarray(frames))
    else:
        got = jax.jit(atari.preprocess)(jnp.asarray(frames))
    assert got.dtype == np.float32
    np.testing.assert_array_equal(np.asarray(got), expected)
    np.testing.assert_array_equal(np.asarray(atari.preprocess(frames[7])), expected[7])  # one frame


def test_frames_are_ale_pong_v5s_single_and_batched():
    """The task's observations are the differences of ALE/Pong-v5's preprocessed frames under the
    same actions: one env stepped alone, and three stepped together in one vmapped call."""
    steps = 150
    actions = np.random.default_rng(1).integers(0, 2, size=(steps, 3))
    env = atari.AtariPong(sticky=False)
    to_ale = atari.ACTION_SETS["updown"]

    step_one = jax.jit(env.step)
    state = env.reset(jax.random.PRNGKey(0))
    np.testing.assert_array_equal(np.asarray(state.obs), 0.0)
    single = []
    for a in actions[:, 0]:
        state = step_one(state, jnp.asarray(a, jnp.int32))
        single.append(np.asarray(state.obs))

    @jax.jit
    def run(key, acts):
        def body(s, a):
            s = jax.vmap(env.step)(s, a)
            return s, (s.obs, s.reward)

        return jax.lax.scan(body, rollout.reset_batch(env, key, 3), acts)[1]

    batched, rewards = jax.device_get(run(jax.random.PRNGKey(0), jnp.asarray(actions, jnp.int32)))
    for b in range(3):
        reference, ale_rewards = ale_frames(np.asarray(to_ale)[actions[:, b]], seed=b)
        diffs = np.diff(atari.preprocess(reference), axis=0)
        np.testing.assert_array_equal(batched[:, b], diffs)
        np.testing.assert_array_equal(rewards[:, b], ale_rewards)
        if b == 0:
            np.testing.assert_array_equal(np.stack(single), diffs)
    assert set(env.pools) == {1, 3}


def test_a_game_ends_at_21_and_the_next_one_starts():
    """Standing still loses 0:21 in 764 steps (ALE/Pong-v5 without sticky actions); AutoReset's
    next observation is zeros and the host game restarts with it."""
    env = AutoReset(EpisodeStats(atari.AtariPong(sticky=False)))
    steps = 800

    @jax.jit
    def run(key):
        def body(s, _):
            s = jax.vmap(env.step)(s, jnp.zeros(2, jnp.int32))
            return s, (s.terminated, s.metrics["episode_return"], s.metrics["task_score"], s.obs, s.reward)

        return jax.lax.scan(body, rollout.reset_batch(env, key, 2), None, length=steps)[1]

    terminated, ep_return, metric, obs, reward = jax.device_get(run(jax.random.PRNGKey(0)))
    end = np.flatnonzero(terminated[:, 0])
    assert list(end) == [763] and np.all(terminated[:, 1] == terminated[:, 0])
    assert ep_return[763, 0] == -21 and metric[763, 0] == -21
    np.testing.assert_array_equal(obs[763], 0.0)  # the new game's first observation
    assert np.sum(reward[764:] != 0) == 0 and metric[-1, 0] == 0  # the new game's first point is far off
    # The new game plays as the first did: same frames at the same steps of the game.
    np.testing.assert_array_equal(obs[764:steps], obs[: steps - 764])


def test_reset_restarts_the_host_games():
    env = atari.AtariPong(sticky=False)
    step = jax.jit(jax.vmap(env.step))
    reset = jax.jit(lambda k: rollout.reset_batch(env, k, 2))
    up = jnp.zeros(2, jnp.int32)
    first = [step(reset(jax.random.PRNGKey(0)), up)]
    for _ in range(70):
        first.append(step(first[-1], up))
    again = step(reset(jax.random.PRNGKey(1)), up)
    np.testing.assert_array_equal(np.asarray(again.obs), np.asarray(first[0].obs))
    assert not np.array_equal(np.asarray(first[-1].obs), np.asarray(first[0].obs))


def test_without_ale_one_line_names_the_install(monkeypatch, tmp_path, capsys):
    import jaxpg.envs as envs

    monkeypatch.setitem(sys.modules, "ale_py", None)  # `import ale_py` raises ImportError
    for make in (atari.AtariPong, lambda: envs.make("atari_pong")):
        with pytest.raises(ImportError) as info:
            make()
        assert str(info.value).count("\n") == 0 and "pip install 'jaxpg[atari]'" in str(info.value)
    assert evaluate_cli.main([str(tmp_path), "--ale"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and "jaxpg[atari]" in err[0]


def test_ale_action_sets():
    assert replay.ale_action_set("atari_pong", {}) == "updown"
    assert replay.ale_action_set("atari_pong", {"action_set": "stay"}) == "stay"
    assert replay.ale_action_set("pong", {"stay_action": True}) == "stay"
    with pytest.raises(ValueError, match="80x80"):
        replay.ale_action_set("pong", {"size": 40})
    with pytest.raises(ValueError, match="not a Pong task"):
        replay.ale_action_set("hopper", {})


def load_experiment():
    return load_script("experiments/atari_pong.py")


@pytest.mark.parametrize(
    "algo, flags",
    [
        ("a2c", ["--horizon", "8", "--value-hidden", "8"]),
        ("reinforce_points", ["--horizon", "32"]),
        # PPO's Atari preset with a small convolutional torso: the conv parameters go through the
        # checkpoint and load_policy to the evaluation on ALE.
        ("ppo", ["--horizon", "8", "--value-hidden", "8", "--num-minibatches", "2", "--conv-torso", "mnih2013"]),
    ],
)
def test_short_training_run_and_evaluation_on_ale(algo, flags, tmp_path, capsys):
    """Two iterations of a tiny network on 2 games, then its policy plays ALE/Pong-v5."""
    from jaxpg.run.command.main import main

    run_dir = tmp_path / algo
    argv = ["--algo", algo, "--num-envs", "2", "--iterations", "2", "--log-every", "1", "--policy-hidden", "8"]
    argv += [*flags, "--run-dir", str(run_dir), "--no-progress"]
    assert main(argv, load_experiment().EXPERIMENT) == 0
    assert f"python -m jaxpg.evaluate {run_dir} --ale --episodes 10" in capsys.readouterr().out
    config = json.loads((run_dir / "config.json").read_text())
    assert config["task"] == "atari_pong" and config["algo"] == algo and config["config"]["policy_hidden"] == [8]
    records = [json.loads(line) for line in (run_dir / "metrics.jsonl").read_text().splitlines()]
    assert [r["iteration"] for r in records] == [1, 2]
    assert all(np.isfinite(r["loss"]) and r["wall_time_s"] > 0 for r in records)
    assert records[-1]["env_steps"] == 2 * 2 * int(flags[1])
    capsys.readouterr()

    assert evaluate_cli.main([str(run_dir), "--ale", "--episodes", "2", "--no-sticky", "--sample"]) == 0
    out = capsys.readouterr().out
    assert "2 games of ALE/Pong-v5 (repeat_action_probability=0)" in out and "sampled actions" in out
    score = float(out.split("mean score:")[1].split()[0])
    assert -21 <= score <= 21


def test_several_seeds_in_one_program_are_refused():
    from jaxpg.run.command import planning
    from jaxpg.run.command.flags import UsageError

    with pytest.raises(UsageError, match="one seed per command"):
        planning.plan(["--seeds", "0", "1", "--num-envs", "2"], load_experiment().EXPERIMENT)


def test_evaluate_ale_refuses_other_tasks(tmp_path, capsys):
    from jaxpg.run.command.main import main

    run_dir = tmp_path / "cartpole"
    argv = ["--task", "cartpole", "--algo", "a2c", "--iterations", "1", "--num-envs", "2", "--horizon", "4"]
    assert main([*argv, "--eval-envs", "0", "--run-dir", str(run_dir), "--no-progress"]) == 0
    capsys.readouterr()
    assert evaluate_cli.main([str(run_dir), "--ale", "--episodes", "1"]) == 2
    assert "not a Pong task" in capsys.readouterr().err
