"""Learning tests: every algorithm, with its defaults or a named preset exactly as shipped, learns its
CPU task, for two seeds (REINFORCE: three of four).

How a test trains and judges (``learn``): seeds 0 and 1 (REINFORCE: 0-3) train together in one
vmapped program (``train.init_seeds``, ``train.train(seeds=True)``, one compiled block of
``eval_every`` iterations), the mean (deterministic) policy of each seed is evaluated every
``eval_every`` iterations on ``eval_envs`` fresh episodes, and the test passes as soon as, for every
seed (REINFORCE: three of the four), the mean of its last
``LAST`` evaluations reaches the bar; it fails if that has not happened by the iteration cap. So a
single lucky evaluation is not enough, and a policy that collapses again after solving the task
pulls its mean down. Only the evaluation settings (``eval_envs``, ``eval_every``) differ from what
ships; the docstrings state each test's budget and the iterations the seeds needed when measured.

Compilation dominates the cost on 2 CPU cores: one training block and one evaluation program per
test, both vmapped over the seeds; measured 15-55 s of CPU time per test (``learn`` prints it).
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from jaxpg import envs
from jaxpg import train as train_lib
from jaxpg.algos import a2c, npg, ppo, reinforce, trpo, vpg

SEEDS = (0, 1)
LAST = 3  # evaluations averaged per seed


@pytest.fixture(scope="module")
def pendulum():
    return envs.make("inverted_pendulum")


@pytest.fixture(scope="module")
def cartpole():
    return envs.make("cartpole")


def learn(
    algo, env, config, max_iterations: int, bar: float, seeds: tuple[int, ...] = SEEDS, need: int | None = None
) -> tuple[np.ndarray, int]:
    """Train ``seeds`` in one vmapped program, ``config.eval_every`` iterations per compiled call,
    until ``need`` seeds (default: all) have a mean of their last ``LAST`` mean-policy evaluations at
    ``bar`` or more, or ``max_iterations`` have run. Returns the evaluations ``[num_evaluations,
    num_seeds]`` and the iterations run."""
    every = config.eval_every
    assert max_iterations % every == 0
    cpu_start = time.process_time()
    ts = train_lib.init_seeds(algo.init, list(seeds), env, config)
    evaluations: list[np.ndarray] = []

    def record(ts, metrics, first):
        rows = metrics["evaluated"][:, 0] > 0
        evaluations.extend(metrics["return_mean_policy"][rows])

    done = 0
    while done < max_iterations and not passed(np.array(evaluations), bar, need):
        ts = train_lib.train(algo.update, ts, every, block_size=every, seeds=True, callbacks=[record])
        done += every
    table = np.array(evaluations)
    print(f"{algo.__name__}: mean-policy returns every {every} iterations (rows), seeds {seeds} (columns):")
    print(np.array2string(table, precision=0, suppress_small=True, max_line_width=200))
    cpu = time.process_time() - cpu_start
    print(f"last {LAST} means {table[-LAST:].mean(0).round(1).tolist()} after {done} iterations, {cpu:.0f} s CPU")
    return table, done


def passed(evaluations: np.ndarray, bar: float, need: int | None = None) -> bool:
    """Whether ``need`` seeds (default: all) have their last ``LAST`` evaluations' mean >= ``bar``."""
    if len(evaluations) < LAST:
        return False
    means = evaluations[-LAST:].mean(0)
    return int(np.sum(means >= bar)) >= (means.size if need is None else need)


def assert_learned(evaluations: np.ndarray, bar: float, need: int | None = None) -> None:
    assert passed(evaluations, bar, need), f"last {LAST} mean-policy returns per seed {evaluations[-LAST:].T.tolist()}"


@pytest.mark.slow
def test_npg_learns_inverted_pendulum(pendulum):
    """NPG, preset ``pendulum_cpu`` (32 envs x 128 steps, policy 32x32, normalised step 0.03):
    the last 3 mean-policy evaluations (8 episodes, every 5 iterations) average >= 950 of 1000 for
    both seeds within 60 iterations (246 k env steps per seed). Measured (seeds 0-3 in one
    program): first evaluated at 1000 after 20, 15, 20 and 10 iterations (seed 1 dipped to 244 at
    20), all four at 1000 from 25 to 60."""
    config = npg.Config(**npg.PRESETS["pendulum_cpu"], eval_envs=8, eval_every=5)
    evaluations, _ = learn(npg, pendulum, config, max_iterations=60, bar=950.0)
    assert_learned(evaluations, 950.0)


@pytest.mark.slow
def test_trpo_learns_inverted_pendulum(pendulum):
    """TRPO with its defaults (64 envs x 128 steps, policy 64x64, max_kl 0.01, 10 backtracks):
    the last 3 mean-policy evaluations (8 episodes, every 5 iterations) average >= 950 of 1000 for
    both seeds within 60 iterations (492 k env steps per seed). Measured: seeds 0 and 1 first
    evaluated at 1000 after 30 and 20 iterations and stayed there to 60; the test stops at 40."""
    config = trpo.Config(eval_envs=8, eval_every=5)
    evaluations, _ = learn(trpo, pendulum, config, max_iterations=60, bar=950.0)
    assert_learned(evaluations, 950.0)


# REINFORCE's seeds learn CartPole at very different speeds, and which seed is slow depends on float
# rounding (the trajectories part early): seed 0 first evaluated at 500 after 55 iterations with
# XLA:CPU's pool of two threads, but with one thread its last-3 mean reached 475 only after 120
# (seeds 1-7: 20-60). So its test trains four seeds and asks three to learn.
REINFORCE_SEEDS = (0, 1, 2, 3)


@pytest.mark.slow
def test_reinforce_learns_cartpole(cartpole):
    """REINFORCE with its defaults (32 episodes of up to 500 steps per iteration, policy 64x64 tanh,
    Adam 1e-2, returns normalised per episode): for 3 of seeds 0-3 the last 3 mean-policy evaluations
    (8 episodes, every 5 iterations) average >= 475 of 500 within 150 iterations (at most 2.4 M env
    steps per seed). Measured (seeds 0-7 in one program, one-thread pool, 2026-11-28): the last-3
    mean first reached 475 after 120, 20, 35, 60, 40, 30, 35 and 35 iterations, so the test stops at 60.
    A broken REINFORCE learns on no seed."""
    config = reinforce.Config(eval_envs=8, eval_every=5)
    evaluations, _ = learn(reinforce, cartpole, config, max_iterations=150, bar=475.0, seeds=REINFORCE_SEEDS, need=3)
    assert_learned(evaluations, 475.0, need=3)


@pytest.mark.slow
def test_vpg_learns_inverted_pendulum(pendulum):
    """VPG with its defaults (16 envs x 128 steps of continuing sampling, policy and baseline 64x64,
    Adam 3.9e-3, gamma 0.99, batch-normalised returns): the last 3 mean-policy evaluations (8
    episodes, every 10 iterations) average >= 950 of 1000 for both seeds within 200 iterations
    (410 k env steps per seed). Measured: seeds 0 and 1 first evaluated at 1000 after 80 and 70
    iterations, seed 0 dipped once to 334 (iteration 100), both at 1000 from 110 to 150; the test
    stops at 130."""
    config = vpg.Config(eval_envs=8, eval_every=10)
    evaluations, _ = learn(vpg, pendulum, config, max_iterations=200, bar=950.0)
    assert_learned(evaluations, 950.0)


@pytest.mark.slow
def test_a2c_learns_cartpole(cartpole):
    """A2C, preset ``cartpole`` (64 envs x t_max 16, n-step returns, rewards scaled by 0.1, Adam
    1e-3, entropy 0.01, grad norm 0.5): the last 3 mean-policy evaluations (8 episodes, every 20
    iterations) average >= 475 of 500 for both seeds within 800 iterations (819 k env steps per
    seed). Measured: here seeds 0 and 1 were evaluated at >= 498 from iteration 300 and the test
    stopped at 360; evaluated every 50 iterations, seeds 0-3 returned 500 at every evaluation from
    iteration 400 to 2000."""
    config = a2c.Config(**a2c.PRESETS["cartpole"], eval_envs=8, eval_every=20)
    evaluations, _ = learn(a2c, cartpole, config, max_iterations=800, bar=475.0)
    assert_learned(evaluations, 475.0)


@pytest.mark.slow
def test_ppo_learns_inverted_pendulum(pendulum):
    """PPO, preset ``pendulum`` (32 envs x 32 steps, 10 epochs x 8 minibatches, Adam 1e-3, GAE
    0.95): the last 3 mean-policy evaluations (8 episodes, every 5 iterations) average >= 950 of
    1000 for both seeds within 80 iterations (82 k env steps per seed). Measured: both seeds first
    evaluated at 1000 after 20 iterations, seed 0 dipped once to 212 (iteration 30), both at 1000
    from 35 to 80; the test stops at 45."""
    config = ppo.Config(**ppo.PRESETS["pendulum"], eval_every=5)
    evaluations, _ = learn(ppo, pendulum, config, max_iterations=80, bar=950.0)
    assert_learned(evaluations, 950.0)
