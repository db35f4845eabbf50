"""inverted_pendulum's presets: NPG on a 2-core CPU, PPO on the CPU, and the seeds' own
REINFORCE (Gymnasium's tutorial) and VPG (PyTorch Lightning's)."""

from __future__ import annotations

from jaxpg.algos.presets.row import Preset, Rows

ROWS: Rows = {
    # NPG on a 2-core CPU: 4096 samples an iteration, a small KL bound that keeps the solved policy
    # solved.
    ("npg", "pendulum_cpu"): Preset(
        tasks=("inverted_pendulum",),
        overrides=dict(
            num_envs=32,
            horizon=128,
            gamma=0.99,
            kl_delta=0.03,
            policy_hidden=(32, 32),
            value_hidden=(64, 64),
            value_batch_size=512,
        ),
    ),
    # The Gymnasium REINFORCE tutorial. Shared tanh trunk 16 -> 32, linear mean and softplus-std
    # heads, AdamW lr 1e-4, gamma 0.99, one update per episode, raw (unnormalised) returns,
    # PyTorch's default initialisation.
    ("reinforce", "gymnasium_tutorial"): Preset(
        tasks=("inverted_pendulum",),
        overrides=dict(
            sampling="episodic",
            num_envs=1,
            horizon=1000,
            gamma=0.99,
            policy="state_std_gaussian",
            policy_hidden=(16, 32),
            policy_activation="tanh",
            network_init="pytorch",
            optimizer="adamw",
            lr=1e-4,
            weight_decay=0.01,
            return_normalization="none",
        ),
    ),
    # The PyTorch Lightning VPG. Policy 64 -> 64 tanh with a global log-std, baseline of the same
    # shape, Adam lr 3.9e-3, discount 0.9, 2500 samples per epoch (here 10 envs x 250 steps of
    # continuing sampling, the data set carried across episode ends), advantages = normalised
    # returns - baseline, baseline fitted to the normalised returns with one full-batch step per
    # epoch; 100 epochs in the seed.
    ("vpg", "lightning"): Preset(
        tasks=("inverted_pendulum",),
        overrides=dict(
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
    ),
    # PPO that solves inverted_pendulum on the CPU.
    ("ppo", "pendulum"): Preset(
        tasks=("inverted_pendulum",),
        overrides=dict(
            num_envs=32,
            horizon=32,
            num_minibatches=8,
            num_epochs=10,
            lr=1e-3,
            gamma=0.99,
            gae_lambda=0.95,
            eval_envs=8,
        ),
    ),
}
