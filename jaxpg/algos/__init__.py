"""Policy-gradient algorithms. Each algorithm module defines ``Config``, ``init(key, env, config)``,
``update(train_state) -> (train_state, metrics)`` and ``PRESETS`` (named ``Config`` overrides),
built on the algorithm core (``jaxpg.algos.core``) and at most one module its family shares
(``natural_gradient``: NPG and TRPO; ``actor_critic``: PPO and A2C)."""

from __future__ import annotations

import importlib
from types import ModuleType

# name -> module, imported on first use.
ALGORITHMS: dict[str, str] = {
    "npg": "jaxpg.algos.npg",
    "trpo": "jaxpg.algos.trpo",
    "reinforce": "jaxpg.algos.reinforce",
    "reinforce_points": "jaxpg.algos.reinforce_points",
    "vpg": "jaxpg.algos.vpg",
    "a2c": "jaxpg.algos.a2c",
    "ppo": "jaxpg.algos.ppo",
}


def get(name: str) -> ModuleType:
    """The algorithm module ``name``; ``ValueError`` listing the known ones otherwise."""
    if name not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {name!r}; known algorithms: {', '.join(sorted(ALGORITHMS))}")
    return importlib.import_module(ALGORITHMS[name])
