"""cartpole's presets: Kokoyi's REINFORCE (a seed's policy gradient) and A2C on two CPU cores."""

from __future__ import annotations

from jaxpg.algos.presets.row import Preset, Rows

ROWS: Rows = {
    # Seed 5: Kokoyi's policy gradient. Categorical policy 4 -> 128 (ReLU) -> 2, Adam lr 0.01,
    # gamma 0.99, returns normalised per episode, one update per episode.
    ("reinforce", "kokoyi"): Preset(
        tasks=("cartpole",),
        overrides=dict(
            sampling="episodic",
            num_envs=1,
            horizon=500,
            gamma=0.99,
            policy_hidden=(128,),
            policy_activation="relu",
            network_init="pytorch",
            optimizer="adam",
            lr=1e-2,
            return_normalization="episode",
        ),
    ),
    # Solves cartpole on two CPU cores and stays solved; rewards scaled by 0.1 so that the value
    # loss does not swamp the joint, clipped gradient.
    ("a2c", "cartpole"): Preset(
        tasks=("cartpole",),
        overrides=dict(
            num_envs=64,
            horizon=16,
            optimizer="adam",
            lr=1e-3,
            reward_scaling=0.1,
            gamma=0.99,
            gae_lambda=1.0,
            entropy_coef=0.01,
            value_coef=0.5,
            max_grad_norm=0.5,
        ),
    ),
}
