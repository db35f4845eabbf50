"""The presets table (``jaxpg.algos.presets``): key presets hold the values they held when each
algorithm module kept its own ``PRESETS`` dict (written out here as literals, so that a change to
the table shows up as a failing test), every row builds a valid ``Config`` for each task it was
made for, the modules' ``PRESETS`` are read-only views of the table, and ``algos.preset`` refuses a
preset off its tasks."""

from __future__ import annotations

import dataclasses
import functools
import json
from pathlib import Path

import pytest

from jaxpg import algos, envs
from jaxpg.algos import presets
from jaxpg.run.command import task_options
from jaxpg.run.rundir.config_io import RunConfig

LYCEUM = dict(
    sampling="episodic",
    num_envs=11,
    horizon=1000,
    sample_budget=10240,
    gamma=0.995,
    gae_lambda=0.97,
    policy="gaussian",
    policy_hidden=(32, 32),
    policy_activation="tanh",
    network_init="glorot_uniform",
    log_std_init=0.0,
    value_hidden=(128, 128),
    value_activation="relu",
    value_lr=1e-3,
    value_epochs=3,
    value_batch_size=64,
    value_target="returns",
    normalize_observations=False,
)
MINPY = dict(
    num_envs=16,
    horizon=5,
    optimizer="rmsprop",
    lr=7e-4,
    rmsprop_decay=0.99,
    eps=1e-5,
    gamma=0.99,
    gae_lambda=1.0,
    entropy_coef=0.01,
    value_coef=0.5,
    max_grad_norm=0.5,
)
ATARI_NETWORKS = dict(
    conv_torso="nature",
    policy_hidden=(512,),
    policy_activation="relu",
    value_hidden=(512,),
    value_activation="relu",
    network_init="orthogonal",
    eval_envs=0,
)

# (algorithm, preset) -> (overrides, tasks): the values of the per-module dicts the table replaced.
EXPECTED = {
    ("npg", "hopper"): (
        dict(
            num_envs=256,
            horizon=64,
            kl_delta=0.07,
            normalize_observations=True,
            log_std_init=0.0,
            value_hidden=(128, 128),
            value_epochs=10,
            value_minibatches=16,
            value_epoch_samples=16384,
            fisher_samples=16384,
            normalize_value_targets=True,
            eval_envs=16,
            eval_every=120,
        ),
        ("hopper",),
    ),
    ("npg", "hopper_1m"): (
        dict(
            num_envs=256,
            horizon=32,
            kl_delta=0.07,
            normalize_observations=True,
            log_std_init=1.0,
            log_std_min=1.0,
            log_std_final=1.0,
            anneal_log_std_iterations=120,
            eval_action="clipped_mean",
            value_hidden=(128, 128),
            value_epochs=10,
            value_minibatches=16,
            value_epoch_samples=16384,
            fisher_samples=16384,
            normalize_value_targets=True,
            eval_envs=16,
            eval_every=120,
        ),
        ("hopper",),
    ),
    ("npg", "walker2d_1m"): (
        dict(
            num_envs=256,
            horizon=32,
            kl_delta=0.07,
            normalize_observations=True,
            log_std_init=0.75,
            value_hidden=(128, 128),
            value_epochs=10,
            value_minibatches=16,
            value_epoch_samples=16384,
            fisher_samples=16384,
            normalize_value_targets=True,
            eval_envs=16,
            eval_every=120,
        ),
        ("walker2d",),
    ),
    ("npg", "half_cheetah_1m"): (
        dict(
            num_envs=256,
            horizon=32,
            kl_delta=0.15,
            normalize_observations=True,
            log_std_init=-0.5,
            value_hidden=(128, 128),
            value_epochs=10,
            value_minibatches=16,
            value_epoch_samples=16384,
            fisher_samples=16384,
            normalize_value_targets=True,
            eval_envs=16,
            eval_every=120,
        ),
        ("half_cheetah",),
    ),
    ("npg", "swimmer_1m"): (
        dict(
            num_envs=256,
            horizon=32,
            kl_delta=0.07,
            normalize_observations=True,
            log_std_init=0.0,
            value_hidden=(128, 128),
            value_epochs=10,
            value_minibatches=16,
            value_epoch_samples=16384,
            fisher_samples=16384,
            normalize_value_targets=True,
            eval_envs=16,
            eval_every=120,
            gamma=0.9999,
        ),
        ("swimmer",),
    ),
    ("npg", "reacher_1m"): (
        dict(
            num_envs=64,
            horizon=32,
            kl_delta=0.07,
            normalize_observations=True,
            log_std_init=-0.5,
            value_hidden=(128, 128),
            value_epochs=10,
            value_minibatches=16,
            value_epoch_samples=16384,
            fisher_samples=16384,
            normalize_value_targets=True,
            eval_envs=16,
            eval_every=120,
        ),
        ("reacher",),
    ),
    ("npg", "pusher_1m"): (
        dict(
            num_envs=64,
            horizon=32,
            kl_delta=0.07,
            normalize_observations=True,
            log_std_init=0.0,
            value_hidden=(128, 128),
            value_epochs=10,
            value_minibatches=16,
            value_epoch_samples=16384,
            fisher_samples=16384,
            normalize_value_targets=True,
            eval_envs=16,
            eval_every=120,
        ),
        ("pusher",),
    ),
    ("npg", "pendulum_cpu"): (
        dict(
            num_envs=32,
            horizon=128,
            gamma=0.99,
            kl_delta=0.03,
            policy_hidden=(32, 32),
            value_hidden=(64, 64),
            value_batch_size=512,
        ),
        ("inverted_pendulum",),
    ),
    ("npg", "lyceum"): ({**LYCEUM, "kl_delta": 0.05}, None),
    ("trpo", "lyceum"): ({**LYCEUM, "max_kl": 0.05}, None),
    ("a2c", "minpy"): (MINPY, None),
    ("a2c", "atari"): ({**MINPY, "value_coef": 0.25, **ATARI_NETWORKS}, ("atari_pong", "pong")),
    ("a2c", "pong"): (
        dict(
            policy_hidden=(200,),
            policy_activation="relu",
            value_hidden=(200,),
            value_activation="relu",
            horizon=8,
            optimizer="adam",
            lr=1e-3,
            gamma=0.99,
            gae_lambda=0.95,
            entropy_coef=0.01,
            value_coef=0.5,
            max_grad_norm=0.5,
            eval_envs=0,
        ),
        ("pong", "atari_pong"),
    ),
    ("ppo", "hopper_gpu"): (
        dict(
            num_envs=8192,
            horizon=32,
            num_minibatches=8,
            num_epochs=4,
            lr=3e-4,
            max_grad_norm=0.0,
            entropy_coef=1e-3,
            gamma=0.99,
            gae_lambda=0.95,
            reward_scaling=10.0,
            normalize_observations=True,
            policy_hidden=(32, 32, 32, 32),
            policy_activation="swish",
            value_hidden=(256, 256, 256, 256, 256),
            value_activation="swish",
            network_init="orthogonal",
            eval_envs=32,
            eval_every=50,
        ),
        ("hopper",),
    ),
    ("ppo", "walker2d_fast"): (
        dict(
            num_envs=8192,
            horizon=32,
            num_minibatches=8,
            num_epochs=4,
            lr=0.0003,
            max_grad_norm=0.0,
            entropy_coef=0.001,
            gamma=0.99,
            gae_lambda=0.95,
            reward_scaling=10.0,
            normalize_observations=True,
            policy_hidden=(32, 32, 32, 32),
            policy_activation="swish",
            value_hidden=(256, 256, 256, 256, 256),
            value_activation="swish",
            network_init="orthogonal",
            eval_envs=128,
            eval_every=60,
        ),
        ("walker2d",),
    ),
    ("ppo", "half_cheetah_fast"): (
        dict(
            num_envs=8192,
            horizon=32,
            num_minibatches=8,
            num_epochs=4,
            lr=0.0003,
            max_grad_norm=0.0,
            entropy_coef=0.0,
            gamma=0.99,
            gae_lambda=0.95,
            reward_scaling=1.0,
            normalize_observations=True,
            policy_hidden=(32, 32, 32, 32),
            policy_activation="swish",
            value_hidden=(256, 256, 256, 256, 256),
            value_activation="swish",
            network_init="orthogonal",
            eval_envs=128,
            eval_every=60,
        ),
        ("half_cheetah",),
    ),
    ("ppo", "ant_fast"): (
        dict(
            num_envs=16384,
            horizon=10,
            num_minibatches=32,
            num_epochs=4,
            lr=0.0003,
            max_grad_norm=0.0,
            entropy_coef=0.01,
            gamma=0.97,
            gae_lambda=0.95,
            reward_scaling=10.0,
            normalize_observations=True,
            policy_hidden=(32, 32, 32, 32),
            policy_activation="swish",
            value_hidden=(256, 256, 256, 256, 256),
            value_activation="swish",
            network_init="orthogonal",
            eval_envs=128,
            eval_every=150,
        ),
        ("ant",),
    ),
    ("ppo", "humanoid_fast"): (
        dict(
            num_envs=2048,
            horizon=160,
            num_minibatches=32,
            num_epochs=8,
            lr=0.0003,
            max_grad_norm=0.0,
            entropy_coef=0.001,
            gamma=0.97,
            gae_lambda=0.95,
            reward_scaling=0.1,
            normalize_observations=True,
            policy_hidden=(32, 32, 32, 32),
            policy_activation="swish",
            value_hidden=(256, 256, 256, 256, 256),
            value_activation="swish",
            network_init="orthogonal",
            eval_envs=128,
            eval_every=30,
        ),
        ("humanoid",),
    ),
    ("ppo", "pusher_fast"): (
        dict(
            num_envs=8192,
            horizon=32,
            num_minibatches=8,
            num_epochs=4,
            lr=0.0003,
            max_grad_norm=0.0,
            entropy_coef=0.0,
            gamma=0.95,
            gae_lambda=0.95,
            reward_scaling=10.0,
            normalize_observations=True,
            policy_hidden=(32, 32, 32, 32),
            policy_activation="swish",
            value_hidden=(256, 256, 256, 256, 256),
            value_activation="swish",
            network_init="orthogonal",
            eval_envs=128,
            eval_every=30,
        ),
        ("pusher",),
    ),
    ("a2c", "ant_1m"): (
        dict(
            network_init="orthogonal",
            policy_head_scale=0.01,
            num_envs=16,
            horizon=5,
            optimizer="rmsprop",
            lr=7e-4,
            rmsprop_decay=0.99,
            eps=1e-5,
            rmsprop_eps_in_sqrt=False,
            anneal_lr_iterations=12500,
            gamma=0.99,
            gae_lambda=0.95,
            entropy_coef=0.01,
            value_coef=0.5,
            max_grad_norm=0.5,
            policy_hidden=(64, 64),
            value_hidden=(64, 64),
            policy_activation="tanh",
            value_activation="tanh",
            log_std_init=-0.5,
            normalize_observations=True,
            normalize_value_targets=True,
            normalize_advantages=False,
            eval_envs=16,
            eval_every=2500,
        ),
        ("ant",),
    ),
    ("ppo", "humanoid_1m"): (
        dict(
            num_envs=16,
            horizon=128,
            gamma=0.99,
            gae_lambda=0.95,
            normalize_observations=True,
            policy_hidden=(64, 64),
            value_hidden=(64, 64),
            policy_activation="tanh",
            value_activation="tanh",
            log_std_init=-0.5,
            num_epochs=10,
            num_minibatches=32,
            lr=3e-4,
            anneal_lr_iterations=488,
            max_grad_norm=0.5,
            entropy_coef=0.0,
            reward_scaling=1.0,
            eval_envs=16,
            eval_every=122,
            network_init="orthogonal",
            policy_head_scale=0.01,
        ),
        ("humanoid",),
    ),
    ("trpo", "walker2d_1m"): (
        dict(
            network_init="orthogonal",
            policy_head_scale=0.01,
            num_envs=16,
            horizon=64,
            max_kl=0.01,
            backtracks=10,
            backtrack_ratio=0.8,
            cg_iters=10,
            cg_damping=0.1,
            gamma=0.99,
            gae_lambda=0.95,
            normalize_advantages=True,
            normalize_observations=True,
            normalize_value_targets=True,
            value_lr=1e-3,
            value_epochs=20,
            value_batch_size=0,
            policy_hidden=(64, 64),
            value_hidden=(64, 64),
            policy_activation="tanh",
            value_activation="tanh",
            log_std_init=-0.5,
            eval_envs=8,
            eval_every=245,
        ),
        ("walker2d",),
    ),
    ("trpo", "swimmer_1m"): (
        dict(
            network_init="orthogonal",
            policy_head_scale=0.01,
            num_envs=2,
            horizon=1024,
            max_kl=0.01,
            backtracks=10,
            backtrack_ratio=0.8,
            cg_iters=25,
            cg_damping=0.1,
            gamma=0.9999,
            gae_lambda=0.95,
            normalize_advantages=True,
            normalize_observations=True,
            normalize_value_targets=True,
            value_lr=1e-3,
            value_epochs=20,
            value_batch_size=128,
            policy_hidden=(64, 64),
            value_hidden=(64, 64),
            policy_activation="tanh",
            value_activation="tanh",
            log_std_init=0.5,
            eval_envs=8,
            eval_every=61,
        ),
        ("swimmer",),
    ),
    ("trpo", "swimmer_fast"): (
        dict(
            network_init="orthogonal",
            policy_head_scale=0.01,
            num_envs=16,
            horizon=128,
            max_kl=0.01,
            backtracks=10,
            backtrack_ratio=0.8,
            cg_iters=25,
            cg_damping=0.1,
            gamma=0.9999,
            gae_lambda=0.95,
            normalize_advantages=True,
            normalize_observations=True,
            normalize_value_targets=True,
            value_lr=1e-3,
            value_epochs=20,
            value_batch_size=128,
            policy_hidden=(64, 64),
            value_hidden=(64, 64),
            policy_activation="tanh",
            value_activation="tanh",
            log_std_init=0.5,
            eval_envs=8,
            eval_every=50,
        ),
        ("swimmer",),
    ),
    ("trpo", "reacher_1m"): (
        dict(
            network_init="orthogonal",
            policy_head_scale=0.01,
            num_envs=2,
            horizon=1024,
            max_kl=0.01,
            backtracks=10,
            backtrack_ratio=0.8,
            cg_iters=25,
            cg_damping=0.1,
            gamma=0.99,
            gae_lambda=0.95,
            normalize_advantages=True,
            normalize_observations=True,
            normalize_value_targets=True,
            value_lr=1e-3,
            value_epochs=20,
            value_batch_size=128,
            policy_hidden=(64, 64),
            value_hidden=(64, 64),
            policy_activation="tanh",
            value_activation="tanh",
            log_std_init=-0.5,
            eval_envs=8,
            eval_every=61,
        ),
        ("reacher",),
    ),
    ("trpo", "reacher_fast"): (
        dict(
            network_init="orthogonal",
            policy_head_scale=0.01,
            num_envs=512,
            horizon=64,
            max_kl=0.01,
            backtracks=10,
            backtrack_ratio=0.8,
            cg_iters=25,
            cg_damping=0.1,
            gamma=0.99,
            gae_lambda=0.95,
            normalize_advantages=True,
            normalize_observations=True,
            normalize_value_targets=True,
            value_lr=1e-3,
            value_epochs=20,
            value_batch_size=1024,
            policy_hidden=(64, 64),
            value_hidden=(64, 64),
            policy_activation="tanh",
            value_activation="tanh",
            log_std_init=-0.5,
            eval_envs=8,
            eval_every=50,
        ),
        ("reacher",),
    ),
    ("vpg", "lightning"): (
        dict(
            sampling="continuing",
            num_envs=10,
            horizon=250,
            gamma=0.9,
            policy="gaussian",
            policy_hidden=(64, 64),
            policy_activation="tanh",
            network_init="pytorch",
            log_std_init=0.0,
            value_hidden=(64, 64),
            value_activation="tanh",
            optimizer="adam",
            lr=3.9e-3,
            value_lr=3.9e-3,
            value_epochs=1,
            value_batch_size=0,
            return_normalization="batch",
        ),
        ("inverted_pendulum",),
    ),
    # SB3 RL Zoo's HalfCheetah PPO, with its networks' PyTorch initialisation (ortho_init=False)
    ("ppo", "half_cheetah_1m"): (
        dict(
            num_envs=16,
            horizon=32,
            num_minibatches=8,
            num_epochs=20,
            lr=2.0633e-05,
            clip_eps=0.1,
            gae_lambda=0.92,
            gamma=0.98,
            max_grad_norm=0.8,
            value_coef=0.58096,
            entropy_coef=0.000401762,
            log_std_init=-2.0,
            policy_hidden=(256, 256),
            value_hidden=(256, 256),
            policy_activation="relu",
            value_activation="relu",
            normalize_observations=True,
            reward_scaling=0.05,
            network_init="pytorch",
            eval_envs=16,
            eval_every=500,
        ),
        ("half_cheetah",),
    ),
}

# What every algorithm's presets were called, in the order its module listed them.
EXPECTED_NAMES = {
    "npg": [
        "pendulum_cpu",
        "hopper",
        "hopper_1m",
        "walker2d_1m",
        "half_cheetah_1m",
        "swimmer_1m",
        "reacher_1m",
        "pusher_1m",
        "hopper_gpu",
        "lyceum",
    ],
    "trpo": ["lyceum", "walker2d_1m", "swimmer_1m", "reacher_1m", "swimmer_fast", "reacher_fast"],
    "reinforce": ["gymnasium_tutorial", "kokoyi"],
    "reinforce_points": [],
    "vpg": ["lightning"],
    "a2c": ["pong", "minpy", "ant_1m", "humanoid_1m", "cartpole", "atari"],
    "ppo": [
        "brax_hopper",
        "brax_hopper_short",
        "pendulum",
        "atari",
        "hopper_gpu",
        "walker2d_fast",
        "half_cheetah_fast",
        "ant_fast",
        "ant_1m",
        "humanoid_1m",
        "half_cheetah_1m",
        "humanoid_fast",
        "pusher_fast",
    ],
}

# The iterations a command-line run of a preset takes by default (presets that set them).
EXPECTED_ITERATIONS = {
    ("npg", "hopper_1m"): 120,
    ("npg", "walker2d_1m"): 120,
    ("npg", "half_cheetah_1m"): 120,
    ("npg", "swimmer_1m"): 120,
    ("npg", "reacher_1m"): 480,
    ("npg", "pusher_1m"): 480,
    ("ppo", "walker2d_fast"): 660,
    ("ppo", "half_cheetah_fast"): 560,
    ("ppo", "ant_fast"): 1370,
    ("trpo", "walker2d_1m"): 976,
    ("trpo", "swimmer_1m"): 488,
    ("trpo", "reacher_1m"): 488,
    ("trpo", "swimmer_fast"): 488,
    ("trpo", "reacher_fast"): 488,
    ("a2c", "ant_1m"): 12500,
    ("a2c", "humanoid_1m"): 12500,
    ("ppo", "ant_1m"): 488,
    ("ppo", "humanoid_1m"): 488,
    ("ppo", "half_cheetah_1m"): 1953,
    ("ppo", "humanoid_fast"): 250,
    ("ppo", "pusher_fast"): 260,
}

# Tasks an any-task preset is checked against.
ANY_TASK_CHECKS = ("inverted_pendulum", "cartpole", "hopper")


@functools.cache
def env(task: str, options: tuple[tuple[str, object], ...] = ()) -> envs.Env:
    return envs.make(task, **dict(options))


@pytest.mark.parametrize("key", sorted(EXPECTED), ids="/".join)
def test_key_presets_keep_their_values(key):
    algo, name = key
    overrides, tasks = EXPECTED[key]
    row = presets.TABLE[key]
    assert dict(row.overrides) == overrides and row.tasks == tasks
    for value, expected in zip(row.overrides.values(), (overrides[k] for k in row.overrides), strict=True):
        assert type(value) is type(expected)  # 1 stays an int, 1.0 a float
    assert algos.preset(algo, name) == overrides
    assert dict(algos.get(algo).PRESETS[name]) == overrides


def test_presets_keep_their_iteration_counts():
    """A preset's iterations are part of what it was measured with (the *_1m presets stay within
    1 M env steps by them); every other preset leaves the command's default."""
    assert {
        key: row.iterations for key, row in presets.TABLE.items() if row.iterations is not None
    } == EXPECTED_ITERATIONS


def test_every_algorithm_keeps_its_preset_names():
    assert set(EXPECTED_NAMES) == set(algos.ALGORITHMS)
    for algo, names in EXPECTED_NAMES.items():
        assert sorted(algos.get(algo).PRESETS) == sorted(names), algo  # in the table's order, task by task
        assert algos.preset_names(algo) == sorted(names)
    assert {a for a, _ in presets.TABLE} <= set(algos.ALGORITHMS)


@pytest.mark.parametrize("key", list(presets.TABLE), ids="/".join)
def test_every_preset_builds_a_valid_config_for_its_tasks(key):
    algo, name = key
    row = presets.TABLE[key]
    config = algos.get(algo).Config(**algos.preset(algo, name))
    assert row.tasks is None or (row.tasks and set(row.tasks) <= set(envs.names())), row.tasks
    task_only = {k: v for k, v in row.env_kwargs.items() if k not in task_options.PRESET_ENV_SETTINGS}
    for task in row.tasks or ANY_TASK_CHECKS:
        assert task_options.check_options(task, task_only) == task_only
        config.validate(env(task, tuple(row.env_kwargs.items())))
        assert algos.preset(algo, name, task) == dict(row.overrides)
        assert name in algos.preset_names(algo, task)


def test_presets_that_set_task_options():
    """Only the 1 M-step presets of Ant and Humanoid set a task option (the observation without
    the contact forces, as Ant-v3's effectively was), Humanoid's with its actions in [-1, 1], Ant's
    A2C in Gymnasium's physics, and the lookup hands out a copy."""
    no_contact_forces = {"include_cfrc_ext_in_observation": False}
    humanoid = {**no_contact_forces, "action_scaling": True}
    assert {key: dict(row.env_kwargs) for key, row in presets.TABLE.items() if row.env_kwargs} == {
        ("a2c", "ant_1m"): {**no_contact_forces, "fidelity": "gymnasium"},
        ("ppo", "ant_1m"): no_contact_forces,
        ("a2c", "humanoid_1m"): humanoid,
        ("ppo", "humanoid_1m"): humanoid,
    }
    copy = algos.preset_env_kwargs("ppo", "ant_1m")
    copy["include_cfrc_ext_in_observation"] = True
    assert algos.preset_env_kwargs("ppo", "ant_1m") == {"include_cfrc_ext_in_observation": False}
    assert algos.preset_env_kwargs("ppo", "ant_fast") == {} == algos.preset_env_kwargs("ppo", "nope")


def test_module_presets_are_read_only_views_of_the_table():
    from jaxpg.algos import a2c, npg

    assert npg.PRESETS["hopper"] == presets.TABLE[("npg", "hopper")].overrides
    with pytest.raises(TypeError):
        npg.PRESETS["mine"] = {}
    with pytest.raises(TypeError):
        a2c.PRESETS["pong"]["lr"] = 1.0
    with pytest.raises(TypeError):
        presets.TABLE[("npg", "mine")] = presets.Preset({})
    # The ways code and notebooks read them still work.
    assert dict(**a2c.PRESETS["pong"], num_envs=64)["num_envs"] == 64
    assert npg.Config(**{**npg.PRESETS["hopper"], "num_envs": 8}).kl_delta == 0.07
    # algos.preset hands out a copy to change at will.
    copy = algos.preset("npg", "hopper")
    copy["kl_delta"] = 1.0
    assert npg.PRESETS["hopper"]["kl_delta"] == 0.07


def test_lookup_refuses_unknown_names_and_other_tasks():
    assert algos.preset("a2c", "minpy", "hopper") == algos.get("a2c").PRESETS["minpy"]  # any task
    assert algos.preset_names("ppo", "atari_pong") == ["atari"]
    assert algos.preset_names("npg", "hopper") == ["hopper", "hopper_1m", "hopper_gpu", "lyceum"]
    with pytest.raises(ValueError, match="ppo's preset 'atari' was made for atari_pong, pong, not hopper"):
        algos.preset("ppo", "atari", "hopper")
    with pytest.raises(ValueError, match="unknown preset .nope. for npg; known presets: half_cheetah_1m, hopper, "):
        algos.preset("npg", "nope")
    with pytest.raises(
        ValueError, match=r"unknown preset 'walker2d_fast' for npg \('walker2d_fast' is a preset of ppo: --algo ppo\)"
    ):
        algos.preset("npg", "walker2d_fast", "walker2d")
    with pytest.raises(ValueError, match="unknown algorithm 'sac'"):
        algos.preset("sac", "hopper")
    with pytest.raises(ValueError, match="unknown algorithm 'sac'"):
        algos.preset_names("sac")


@pytest.mark.parametrize("key", [k for k in EXPECTED_ITERATIONS if k[1].endswith("_fast")], ids="/".join)
def test_fast_presets_evaluate_about_ten_times_in_blocks_of_ten(key):
    """A fast preset pays for each evaluation in wall clock (every 20 iterations cost 32-38 % of
    the training loop), so it evaluates 8-12 times a run; its evaluations fall on the command
    line's blocks of 10 iterations (no extra, shorter compiled block)."""
    row = presets.TABLE[key]
    every = row.overrides["eval_every"]
    assert 8 <= row.iterations // every + (row.iterations % every > 0) <= 12
    run = RunConfig(task=row.tasks[0], algo=key[0], config=dict(row.overrides), seeds=[0], iterations=row.iterations)
    assert run.block_size == 10


SNAPSHOT = Path(__file__).with_name("preset_snapshot.json")


def resolved_presets() -> dict[str, dict]:
    """Every preset of every algorithm as a run resolves it: the algorithm's whole ``Config`` built
    from the preset's overrides, its tasks, default iterations and task options, as JSON values."""
    out = {}
    for algo in sorted(algos.ALGORITHMS):
        module = algos.get(algo)
        for name in algos.preset_names(algo):
            config = module.Config(**algos.preset(algo, name))
            out[f"{algo}/{name}"] = json.loads(
                json.dumps(
                    {
                        "config": dataclasses.asdict(config),
                        "tasks": presets.TABLE[(algo, name)].tasks,
                        "iterations": algos.preset_iterations(algo, name),
                        "env_kwargs": algos.preset_env_kwargs(algo, name),
                    }
                )
            )
    return out


def test_every_preset_resolves_to_its_recorded_config():
    """All algorithms x all presets resolve to the configs recorded in ``preset_snapshot.json``
    (written from the table as it stood before it was split by task), value for value."""
    recorded = json.loads(SNAPSHOT.read_text())
    now = resolved_presets()
    assert sorted(now) == sorted(recorded)
    for key, value in recorded.items():
        assert now[key] == value, key
