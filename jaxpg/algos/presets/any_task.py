"""The presets made for no task in particular: LyceumAI's NPG and TRPO settings, and MinPy's A2C."""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from jaxpg.algos.presets.recipes import A2C_MINPY
from jaxpg.algos.presets.row import Preset, Rows

# LyceumAI's NaturalPolicyGradient on HopperV2 (Summers et al., L4DC 2020): its sampling, networks
# and value fit, which its NPG and TRPO presets both use.
LYCEUM_SETTINGS: Mapping[str, Any] = MappingProxyType(
    dict(
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
)

ROWS: Rows = {
    # LyceumAI's NaturalPolicyGradient on HopperV2, and the same settings for TRPO.
    ("npg", "lyceum"): Preset(overrides=dict(**LYCEUM_SETTINGS, kl_delta=0.05)),
    ("trpo", "lyceum"): Preset(overrides=dict(**LYCEUM_SETTINGS, max_kl=0.05)),
    # MinPy's parallel A2C.
    ("a2c", "minpy"): Preset(overrides=A2C_MINPY),
}
