"""Returns, GAE and normalisation against plain NumPy loops over random episodes."""

from __future__ import annotations

import functools

import jax
import numpy as np
import pytest

from jaxpg import returns as R

T, B = 23, 6
GAMMA, LAM = 0.9, 0.8


def maybe_jit(fn, use_jit, **kwargs):
    return jax.jit(fn, **kwargs) if use_jit else fn


def random_batch(seed=0):
    """Episodes that end by termination, by truncation, and a last one still running."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(size=(T, B))
    terminated = u < 0.1
    truncated = (u >= 0.1) & (u < 0.2)
    truncated[5, 0] = terminated[5, 0] = True  # both flags: termination wins
    terminated[-1, 1], truncated[-1, 1] = True, False  # last row done in one column ...
    terminated[-1, 2] = truncated[-1, 2] = False  # ... and running on in another
    rewards = rng.normal(size=(T, B)).astype(np.float32)
    values = rng.normal(size=(T, B)).astype(np.float32)
    next_values = rng.normal(size=(T, B)).astype(np.float32)
    return rewards, values, next_values, terminated, truncated


def episode_end(t, b, done):
    """Index of the last step of the episode containing (t, b)."""
    while t < T - 1 and not done[t, b]:
        t += 1
    return t


def np_discounted_returns(rewards, terminated, truncated, gamma, next_values=None):
    """Direct sum ``sum_k gamma^(k-t) r_k`` to the episode's end plus the bootstrap term."""
    done = terminated | truncated
    out = np.zeros((T, B))
    for b in range(B):
        for t in range(T):
            end = episode_end(t, b, done)
            out[t, b] = sum(gamma ** (k - t) * float(rewards[k, b]) for k in range(t, end + 1))
            bootstrap = (truncated[end, b] and not terminated[end, b]) or not done[end, b]
            if next_values is not None and bootstrap:
                out[t, b] += gamma ** (end - t + 1) * float(next_values[end, b])
    return out


def np_gae(rewards, values, next_values, terminated, truncated, gamma, lam):
    done = terminated | truncated
    delta = rewards + gamma * np.where(terminated, 0.0, next_values) - values
    adv = np.zeros((T, B))
    for b in range(B):
        for t in range(T):
            end = episode_end(t, b, done)
            adv[t, b] = sum((gamma * lam) ** (k - t) * delta[k, b] for k in range(t, end + 1))
    return adv, adv + values


@pytest.mark.parametrize("parallel", [True, False])
@pytest.mark.parametrize("use_jit", [False, True])
def test_discounted_returns(use_jit, parallel):
    rewards, _, next_values, terminated, truncated = random_batch()
    fn = maybe_jit(functools.partial(R.discounted_returns, parallel=parallel), use_jit)
    got = fn(rewards, terminated, truncated, GAMMA)
    np.testing.assert_allclose(got, np_discounted_returns(rewards, terminated, truncated, GAMMA), rtol=1e-5, atol=1e-5)
    got = fn(rewards, terminated, truncated, GAMMA, next_values)
    ref = np_discounted_returns(rewards, terminated, truncated, GAMMA, next_values)
    np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-5)
    assert got.shape == (T, B)


@pytest.mark.parametrize("parallel", [True, False])
@pytest.mark.parametrize("use_jit", [False, True])
def test_gae(use_jit, parallel):
    rewards, values, next_values, terminated, truncated = random_batch(1)
    gae = functools.partial(R.gae, parallel=parallel)
    adv, targets = maybe_jit(gae, use_jit)(rewards, values, next_values, terminated, truncated, GAMMA, LAM)
    ref_adv, ref_targets = np_gae(rewards, values, next_values, terminated, truncated, GAMMA, LAM)
    np.testing.assert_allclose(adv, ref_adv, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(targets, ref_targets, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("length", [1, 2, 64, 100])
def test_reverse_linear_recurrence(length):
    """The associative form against the sequential loop, for lengths that are and are not powers
    of two, with trailing batch axes and a bootstrap value; under vmap and grad too."""
    rng = np.random.default_rng(length)
    x = rng.normal(size=(length, 3, 2)).astype(np.float32)
    c = rng.uniform(0.0, 1.0, size=(length, 3, 2)).astype(np.float32)
    c[rng.uniform(size=c.shape) < 0.1] = 0.0  # episode boundaries
    last = rng.normal(size=(3, 2)).astype(np.float32)
    want = np.zeros_like(x)
    y = last
    for t in reversed(range(length)):
        y = x[t] + c[t] * y
        want[t] = y
    np.testing.assert_allclose(jax.jit(R.reverse_linear_recurrence)(x, c, last), want, rtol=1e-5, atol=1e-5)
    no_last = R.reverse_linear_recurrence(x, c)
    np.testing.assert_allclose(no_last[-1], x[-1], rtol=1e-6)
    # vmap over the last axis gives the same as the unbatched call.
    stacked = jax.vmap(R.reverse_linear_recurrence, in_axes=(2, 2, 1), out_axes=2)(x, c, last)
    np.testing.assert_allclose(stacked, want, rtol=1e-5, atol=1e-5)
    # d y_0 / d x_t = prod_{k<t} c_k (the recurrence is linear in x).
    grad = jax.grad(lambda xs: R.reverse_linear_recurrence(xs, c, last)[0, 0, 0])(x)
    np.testing.assert_allclose(grad[:, 0, 0], np.concatenate([[1.0], np.cumprod(c[:-1, 0, 0])]), rtol=1e-5, atol=1e-6)


def test_gae_limits():
    """lambda = 0 gives the TD errors; lambda = 1 with consistent values gives bootstrapped returns."""
    rewards, values, next_values, terminated, truncated = random_batch(2)
    adv, _ = R.gae(rewards, values, next_values, terminated, truncated, GAMMA, 0.0)
    np.testing.assert_allclose(
        adv, rewards + GAMMA * np.where(terminated, 0, next_values) - values, rtol=1e-5, atol=1e-6
    )
    done = terminated | truncated
    consistent = np.where(done[:-1], next_values[:-1], values[1:])
    next_values = np.concatenate([consistent, next_values[-1:]])
    _, targets = R.gae(rewards, values, next_values, terminated, truncated, GAMMA, 1.0)
    returns = R.discounted_returns(rewards, terminated, truncated, GAMMA, next_values)
    np.testing.assert_allclose(targets, returns, rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("use_jit", [False, True])
def test_normalize(use_jit):
    rng = np.random.default_rng(3)
    x = rng.normal(3.0, 2.0, size=(T, B)).astype(np.float32)
    fn = maybe_jit(R.normalize, use_jit)
    np.testing.assert_allclose(fn(x), (x - x.mean()) / (x.std() + 1e-8), rtol=1e-4, atol=1e-5)
    mask = rng.uniform(size=(T, B)) < 0.6
    sel = x[mask].astype(np.float64)
    ref = np.where(mask, (x - sel.mean()) / (sel.std() + 1e-8), 0.0)
    np.testing.assert_allclose(fn(x, mask), ref, rtol=1e-4, atol=1e-5)
    np.testing.assert_allclose(fn(x, mask.astype(np.float32)), ref, rtol=1e-4, atol=1e-5)


def np_normalize_per_episode(values, terminated, truncated, valid, eps=1e-8):
    done = terminated | truncated
    out = np.zeros((T, B))
    for b in range(B):
        start = 0
        while start < T:
            end = episode_end(start, b, done)
            idx = [t for t in range(start, end + 1) if valid[t, b] > 0]
            if idx:
                seg = values[idx, b].astype(np.float64)
                out[idx, b] = (seg - seg.mean()) / (seg.std() + eps)
            start = end + 1
    return out


@pytest.mark.parametrize("use_jit", [False, True])
def test_normalize_per_episode(use_jit):
    rewards, _, _, terminated, truncated = random_batch(4)
    returns = np.asarray(R.discounted_returns(rewards, terminated, truncated, 0.99))
    fn = maybe_jit(R.normalize_per_episode, use_jit)
    ones = np.ones((T, B), np.float32)
    np.testing.assert_allclose(
        fn(returns, terminated, truncated),
        np_normalize_per_episode(returns, terminated, truncated, ones),
        rtol=1e-4,
        atol=1e-4,
    )
    valid = (np.random.default_rng(5).uniform(size=(T, B)) < 0.8).astype(np.float32)
    np.testing.assert_allclose(
        fn(returns, terminated, truncated, valid),
        np_normalize_per_episode(returns, terminated, truncated, valid),
        rtol=1e-4,
        atol=1e-4,
    )


def test_episode_ids_and_vmap():
    _, _, _, terminated, truncated = random_batch(6)
    ids = np.asarray(R.episode_ids(terminated, truncated))
    done = terminated | truncated
    for b in range(B):
        expected = np.concatenate([[0], np.cumsum(done[:-1, b])])
        np.testing.assert_array_equal(ids[:, b], expected)
    # Several seeds at once: vmap over a leading axis.
    rewards = np.stack([random_batch(s)[0] for s in range(3)])
    term = np.stack([random_batch(s)[3] for s in range(3)])
    trunc = np.stack([random_batch(s)[4] for s in range(3)])
    batched = jax.vmap(functools.partial(R.discounted_returns, gamma=GAMMA))(rewards, term, trunc)
    for s in range(3):
        np.testing.assert_allclose(
            batched[s], np_discounted_returns(rewards[s], term[s], trunc[s], GAMMA), rtol=1e-5, atol=1e-5
        )


@pytest.mark.parametrize("use_jit", [False, True])
def test_normalize_per_episode_constant_episodes_are_zero(use_jit):
    """An episode whose (valid) values are all one number has no spread: NumPy's float64 mean of
    identical float32 numbers is exact, so the reference gives exactly 0 there. In float32 a
    segment sum over a few entries of 0.1 or 3.7 misses ``n * v`` by a rounding error, and
    ``(v - mean) / (std + eps)`` with ``std`` ~1e-7 would turn that into values of size 1; the
    library must give 0 too. The episodes of column 0 (values of size 1, spread 1) keep their
    normalised values: float32 sums of <= 23 terms of size 1 differ from float64 by ~1e-6, well
    within the rtol/atol 1e-4 of ``test_normalize_per_episode``."""
    _, _, _, terminated, truncated = random_batch(7)
    ids = np.asarray(R.episode_ids(terminated, truncated))
    levels = np.asarray([0.1, 3.7, -42.1, 100.3, 0.3, 1e4 / 3], np.float32)
    values = levels[(ids + np.arange(B)[None, :]) % len(levels)]  # constant within each episode
    values[:, 0] = np.random.default_rng(8).normal(size=T).astype(np.float32)  # column 0 has spread
    fn = maybe_jit(R.normalize_per_episode, use_jit)
    ones = np.ones((T, B), np.float32)
    want = np_normalize_per_episode(values, terminated, truncated, ones)
    assert np.all(want[:, 1:] == 0.0) and np.abs(want[:, 0]).max() > 0.5
    np.testing.assert_allclose(fn(values, terminated, truncated), want, rtol=1e-4, atol=1e-4)
    # Valid entries all equal, the invalid ones elsewhere: still no spread among what counts.
    valid = (np.random.default_rng(9).uniform(size=(T, B)) < 0.7).astype(np.float32)
    noisy = np.where(valid > 0, values, np.random.default_rng(10).normal(size=(T, B))).astype(np.float32)
    want = np_normalize_per_episode(noisy, terminated, truncated, valid)
    np.testing.assert_allclose(fn(noisy, terminated, truncated, valid), want, rtol=1e-4, atol=1e-4)
