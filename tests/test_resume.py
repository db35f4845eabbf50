"""``--resume`` continues a run bit for bit, whatever state the algorithm carries: observation
statistics (``--normalize-observations``), value-target statistics (``--normalize-value-targets``)
and the value fit's Adam state (NPG), one Adam state over policy and value (PPO).

Each configuration trains 4 iterations straight and 2 + 2 with a resume in between, in this
process (the three runs share their compiled programs); the two final ``TrainState``s are
compared leaf by leaf, and so are the metrics. The reference is the uninterrupted run: a resume
must reproduce it, not merely something close.
"""

from __future__ import annotations

from pathlib import Path

import jax
import numpy as np
import pytest
import test_cli

from jaxpg.run.checkpoints import policy_io
from jaxpg.run.command import main
from jaxpg.run.outputs import metrics_log

COMMON = [
    "--env", "inverted_pendulum", "--num-envs", "8", "--horizon", "32", "--eval-envs", "2", "--eval-horizon", "32",
    "--max-episode-steps", "50", "--checkpoint-every", "2", "--log-every", "2", "--no-progress",
    "--normalize-observations",
]  # fmt: skip
CONFIGURATIONS = {
    "npg-normalised-values": ["--algo", "npg", "--normalize-value-targets"],
    "ppo-adam": ["--algo", "ppo", "--num-minibatches", "4", "--num-epochs", "2"],
}


def leaves_with_paths(tree) -> dict[str, np.ndarray]:
    """``{path: array}`` of every leaf of a pytree, the path as ``jax.tree_util.keystr`` writes it."""
    flat, _ = jax.tree_util.tree_flatten_with_path(tree)
    return {jax.tree_util.keystr(path): np.asarray(leaf) for path, leaf in flat}


def assert_same_state(got, want) -> None:
    """Every leaf equal, bit for bit (NaN where NaN): both runs ran the same compiled programs on
    the same inputs on this CPU, which is deterministic, so no tolerance applies."""
    got, want = leaves_with_paths(got), leaves_with_paths(want)
    assert got.keys() == want.keys()
    differing = [
        path
        for path in want
        if got[path].dtype != want[path].dtype or not np.array_equal(got[path], want[path], equal_nan=True)
    ]
    assert not differing, f"leaves that differ after the resume: {differing}"


@pytest.mark.parametrize("name", CONFIGURATIONS)
def test_resume_is_bit_exact_with_every_kind_of_state(name: str, tmp_path: Path) -> None:
    flags = [*COMMON, *CONFIGURATIONS[name]]
    straight, split = tmp_path / "straight", tmp_path / "split"
    assert main.main([*flags, "--iterations", "4", "--run-dir", str(straight)]) == 0
    assert main.main([*flags, "--iterations", "2", "--run-dir", str(split)]) == 0
    assert main.main(["--resume", str(split), "--iterations", "4"]) == 0

    test_cli.same_run(metrics_log.read_metrics(split), metrics_log.read_metrics(straight), stopped_at={2})
    for step in (2, 4):
        want, _ = policy_io.restore_train_state(straight, step)
        got, _ = policy_io.restore_train_state(split, step)
        assert_same_state(got, want)

    # The state under test is really there (a reset could not pass for a match): the statistics
    # have absorbed samples and moved off their initial values, the optimizer has moments.
    final, _ = policy_io.restore_train_state(straight, 4)
    assert float(final.obs_stats.count) > 0 and np.any(np.asarray(final.obs_stats.mean) != 0)
    if name.startswith("npg"):
        assert float(final.value_stats.count) > 0 and np.any(np.asarray(final.value_stats.mean) != 0)
    optimizer = final.value_opt_state if name.startswith("npg") else final.opt_state
    moments = [leaf for leaf in jax.tree.leaves(optimizer) if np.asarray(leaf).dtype == np.float32]
    assert moments and any(np.any(np.asarray(m) != 0) for m in moments)
