"""The algorithm core (``jaxpg.algos.core``): what every algorithm builds on, and that the
algorithms build on it rather than on each other.

* The import graph: every algorithm imports the core and at most the one shared piece of its
  family (``natural_gradient`` for NPG and TRPO, ``actor_critic`` for PPO and A2C; VPG and
  ``reinforce_points`` are REINFORCE with a baseline or other returns), and REINFORCE imports
  nothing but the core; any of them may read the presets table (``presets``, plain data that
  imports no algorithm).
* The sample budget against a NumPy loop, the end of an iteration (rollback on a non-finite
  update, on a KL beyond ``max_update_kl``, on a step the algorithm did not accept), the value-target
  statistics (outputs preserved), and the fields an algorithm does not use; under ``jit`` and without.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import inspect
import pkgutil

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxpg import algos, envs
from jaxpg.algos import core, npg, reinforce, trpo, vpg
from jaxpg.envs.cartpole import CartPole
from jaxpg.rollout import Trajectory

# The jaxpg.algos modules each module may import (besides jaxpg's non-algorithm modules).
ALLOWED_ALGOS_IMPORTS = {
    "jaxpg.algos.reinforce": {"core"},
    "jaxpg.algos.vpg": {"core", "reinforce"},
    "jaxpg.algos.reinforce_points": {"core", "reinforce"},
    "jaxpg.algos.npg": {"core", "natural_gradient"},
    "jaxpg.algos.trpo": {"core", "natural_gradient"},
    "jaxpg.algos.ppo": {"core", "actor_critic"},
    "jaxpg.algos.a2c": {"core", "actor_critic"},
    "jaxpg.algos.natural_gradient": {"core"},
    "jaxpg.algos.actor_critic": {"core"},
}
# Plain data any algorithm module may read: the presets package (its table's rows are their PRESETS).
DATA_MODULES = {"presets"}


def maybe_jit(fn, use_jit):
    return jax.jit(fn) if use_jit else fn


def algos_imports(module_name: str) -> set[str]:
    """The ``jaxpg.algos`` modules that ``module_name``'s source imports (first name below ``algos``)."""
    tree = ast.parse(inspect.getsource(importlib.import_module(module_name)))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            if node.module == "jaxpg.algos":
                found |= {alias.name for alias in node.names}
            elif node.module.startswith("jaxpg.algos."):
                found.add(node.module.split(".")[2])
        elif isinstance(node, ast.Import):
            found |= {a.name.split(".")[2] for a in node.names if a.name.startswith("jaxpg.algos.")}
    return found


def test_every_algorithm_is_covered():
    assert {f"jaxpg.algos.{name}" for name in algos.ALGORITHMS} <= set(ALLOWED_ALGOS_IMPORTS)


@pytest.mark.parametrize("module_name", sorted(ALLOWED_ALGOS_IMPORTS))
def test_algorithms_build_on_the_core_not_on_each_other(module_name):
    imported = algos_imports(module_name)
    assert "core" in imported, module_name
    assert imported <= ALLOWED_ALGOS_IMPORTS[module_name] | DATA_MODULES, (module_name, imported)


def test_reinforce_imports_only_the_core():
    assert algos_imports("jaxpg.algos.reinforce") - DATA_MODULES == {"core"}


def test_the_presets_import_no_algorithm():
    package = importlib.import_module("jaxpg.algos.presets")
    parts = [f"jaxpg.algos.presets.{m.name}" for m in pkgutil.iter_modules(package.__path__)]
    modules = ["jaxpg.algos.presets", *parts]
    assert len(modules) > 3
    for name in modules:
        assert algos_imports(name) <= {"presets"}, name


def test_the_core_imports_no_algorithm():
    for name in ("advantages", "batch", "config", "iteration", "placement", "sampling", "state", "value_fit"):
        assert algos_imports(f"jaxpg.algos.core.{name}") <= {"core"}, name


def jaxpg_imports(module_name: str) -> set[str]:
    """The ``jaxpg`` modules (``jaxpg.X``, first name below ``jaxpg``) that ``module_name``'s source
    imports anywhere, function-level imports included."""
    tree = ast.parse(inspect.getsource(importlib.import_module(module_name)))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module == "jaxpg":
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("jaxpg."):
            found.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            found |= {a.name.split(".")[1] for a in node.names if a.name.startswith("jaxpg.")}
    return found


def test_videos_draw_and_evaluation_rolls_out_with_no_import_cycle():
    """``video`` draws and writes frames; ``run.evaluation.policy_episodes`` rolls policies out (and records a
    policy's video through ``video``). The dependency goes one way only."""
    assert not {"evaluate", "run"} & jaxpg_imports("jaxpg.video")
    assert "video" in jaxpg_imports("jaxpg.run.evaluation.policy_episodes")


# -- Sampling ----------------------------------------------------------------------------------


@pytest.mark.parametrize("use_jit", [False, True])
@pytest.mark.parametrize("budget", [0, 1, 7, 12, 100])
def test_sample_budget_keeps_the_first_valid_samples_env_by_env(budget, use_jit):
    rng = np.random.default_rng(0)
    valid = (rng.random((6, 4)) < 0.7).astype(np.float32)  # [T, B]
    traj = Trajectory(
        obs=jnp.zeros((6, 4, 1)),
        actions=jnp.zeros((6, 4, 1)),
        log_probs=jnp.zeros((6, 4)),
        rewards=jnp.zeros((6, 4)),
        terminated=jnp.zeros((6, 4), bool),
        truncated=jnp.zeros((6, 4), bool),
        next_obs=jnp.zeros((6, 4, 1)),
        valid=jnp.asarray(valid),
        metrics={},
    )
    kept = maybe_jit(lambda t: core.apply_sample_budget(t, budget), use_jit)(traj).valid
    expected = valid.copy()
    if budget > 0:
        count = 0
        for b in range(4):
            for t in range(6):
                count += valid[t, b]
                if count > budget:
                    expected[t, b] = 0.0
    np.testing.assert_array_equal(np.asarray(kept), expected)


# -- The end of an iteration ------------------------------------------------------------------

TINY_NPG = npg.Config(num_envs=4, horizon=8, policy_hidden=(8,), value_hidden=(8,), value_batch_size=16, eval_envs=0)


@pytest.fixture(scope="module")
def sampled():
    """An NPG state after sampling one batch: ``(old, ts, traj, batch)``."""
    old = npg.init(jax.random.PRNGKey(0), envs.make("cartpole"), TINY_NPG)
    ts, traj, _ = core.phase_sample(old)
    return old, ts, traj, core.phase_advantages(ts, traj)


def moved(ts, scale):
    return ts.replace(params=jax.tree.map(lambda p: p * scale, ts.params))


@pytest.mark.parametrize("use_jit", [False, True])
def test_finish_iteration_keeps_a_sound_update_and_rolls_back_the_others(sampled, use_jit):
    old, ts, traj, _ = sampled
    new = moved(ts, 1.1)

    def finish(new, loss, kl, accepted):
        return core.finish_iteration(old, new, traj, loss=loss, kl=kl, metrics={"x": loss}, step_accepted=accepted)

    finish = maybe_jit(finish, use_jit)
    cases = {
        "sound": (new, 0.0, 0.01, True),
        "beyond max_update_kl": (new, 0.0, 2 * TINY_NPG.max_update_kl, True),
        "step not accepted": (new, 0.0, 0.01, False),
        "non-finite loss": (new, jnp.nan, 0.01, True),
        "non-finite params": (moved(ts, jnp.nan), 0.0, 0.01, True),
    }
    for name, (candidate, loss, kl, accepted) in cases.items():
        out, metrics = finish(candidate, jnp.float32(loss), jnp.float32(kl), accepted)
        rejected = name != "sound"
        assert float(metrics["update_rejected"]) == float(rejected), name
        want = old.params if rejected else candidate.params
        for a, b in zip(jax.tree.leaves(out.params), jax.tree.leaves(want), strict=True):
            np.testing.assert_array_equal(np.asarray(a), np.asarray(b), err_msg=name)
        assert int(out.failures) == int(name.startswith("non-finite")), name
        assert int(out.iteration) == int(old.iteration) + 1, name
        np.testing.assert_array_equal(np.asarray(out.key), np.asarray(ts.key), err_msg=name)  # sampling advanced
        assert float(metrics["kl"]) == pytest.approx(kl) and "return_stochastic" in metrics and "x" in metrics


def test_finish_iteration_updates_observation_statistics_when_asked(sampled):
    old, ts, traj, _ = sampled
    for normalize in (False, True):
        config = dataclasses.replace(TINY_NPG, normalize_observations=normalize)
        out, _ = core.finish_iteration(
            old.replace(config=config), ts.replace(config=config), traj, loss=0.0, kl=0.0, metrics={}
        )
        assert float(out.obs_stats.count) == (float(jnp.sum(traj.valid)) if normalize else 0.0)


# -- Value targets ------------------------------------------------------------------------------


@pytest.mark.parametrize("use_jit", [False, True])
def test_value_target_statistics_preserve_predictions_after_the_first_batch(sampled, use_jit):
    """``absorb_value_targets`` moves the statistics; the predictions in return units stay, except
    on the first batch, whose untrained outputs are left as they are (standardised from then on)."""
    _, ts, _, batch = sampled
    ts = ts.replace(config=dataclasses.replace(TINY_NPG, normalize_value_targets=True))
    batch = batch.replace(value_targets=100.0 + 20.0 * batch.value_targets)
    absorb = maybe_jit(core.absorb_value_targets, use_jit)
    first = absorb(ts, batch)
    assert float(first.value_stats.count) == float(jnp.sum(batch.weights))
    for a, b in zip(jax.tree.leaves(first.value_params), jax.tree.leaves(ts.value_params), strict=True):
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b))
    before = core.value_predictions(first, batch.obs)
    second = absorb(first, batch.replace(value_targets=batch.value_targets + 300.0))
    assert float(second.value_stats.mean[0]) > float(first.value_stats.mean[0]) + 100
    np.testing.assert_allclose(core.value_predictions(second, batch.obs), before, rtol=1e-4, atol=1e-3)


def test_vpg_fits_standardised_targets_with_the_core_value_fit():
    """VPG's baseline fit is the core's: with ``normalize_value_targets`` its statistics follow the
    targets, and its advantages use the de-standardised predictions."""
    config = vpg.Config(num_envs=4, horizon=16, value_hidden=(8,), normalize_value_targets=True, eval_envs=0)
    ts = vpg.init(jax.random.PRNGKey(1), envs.make("cartpole"), config)
    new, metrics = jax.jit(vpg.update)(ts)
    assert float(metrics["update_rejected"]) == 0.0
    assert float(new.value_stats.count) == config.samples_per_iteration
    sampled, traj, _ = core.phase_sample(ts)
    batch = vpg.phase_advantages(sampled, reinforce.phase_returns(sampled, traj))
    baseline = core.value_predictions(sampled, batch.obs)
    np.testing.assert_allclose(batch.advantages, (batch.value_targets - baseline) * batch.weights, rtol=1e-6)


# -- Configs ------------------------------------------------------------------------------------


def test_unused_fields_are_refused_unless_default():
    """A field an algorithm ignores has no flag (``jaxpg.cli``) and ``validate`` refuses a value
    other than its default."""
    cartpole = envs.make("cartpole")
    refused = [
        (reinforce.Config, "value_hidden", (8,)),
        (reinforce.Config, "normalize_value_targets", True),
    ]
    for config_cls, name, value in refused:
        assert name in config_cls.UNUSED_FIELDS
        with pytest.raises(ValueError, match=f"does not use {name}"):
            config_cls(num_envs=2, horizon=8, **{name: value}).validate(cartpole)
        config_cls(num_envs=2, horizon=8).validate(cartpole)
    assert vpg.Config.UNUSED_FIELDS == ()  # its baseline is a value network
    for name in algos.ALGORITHMS:
        config_cls = algos.get(name).Config
        assert set(config_cls.UNUSED_FIELDS) <= {f.name for f in dataclasses.fields(config_cls)}, name
        assert issubclass(config_cls, core.BaseConfig), name


def test_conv_torso_needs_image_observations():
    """A conv torso is refused with one line on a task without images, and built on one with them."""
    cartpole = envs.make("cartpole")
    with pytest.raises(ValueError, match="needs a discrete task with image observations; cartpole has none"):
        algos.get("ppo").Config(num_envs=2, horizon=8, conv_torso="nature").validate(cartpole)
    with pytest.raises(ValueError, match="unknown conv_torso 'resnet'"):
        algos.get("ppo").Config(num_envs=2, horizon=8, conv_torso="resnet").validate(cartpole)

    class ImageCartpole(CartPole):
        image_shape = (2, 2, 1)  # cartpole's 4 values read as a 2x2 image

    config = algos.get("a2c").Config(num_envs=2, horizon=8, conv_torso="mnih2013")
    config.validate(ImageCartpole())
    with pytest.raises(ValueError, match="a 2x2 image is too small"):  # the env's image reaches the torso
        core.make_networks(ImageCartpole(), config)


def test_trpo_has_no_npg_step_and_npg_names_its_delta():
    fields = {f.name for f in dataclasses.fields(trpo.Config)}
    assert "kl_delta" not in fields and "step_size" not in fields and "max_kl" in fields
    assert npg.Config().kl_delta == 0.05 and "step_size" not in {f.name for f in dataclasses.fields(npg.Config)}
