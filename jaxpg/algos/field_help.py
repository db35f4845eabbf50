"""What each ``Config`` field of the algorithms means, in one line, and the values a string field
accepts: the command line's ``--help`` shows both, and a test checks that every field of every
algorithm has its line.

A field means the same in every algorithm that has it; where the accepted values differ between
algorithms (``optimizer``), the algorithm's ``Config.FIELD_CHOICES`` says which.
"""

from __future__ import annotations

from jaxpg.networks import ACTIVATIONS, CONV_TORSOS, KERNEL_INITS

FIELD_HELP: dict[str, str] = {
    # sampling and evaluation (every algorithm)
    "num_envs": "parallel envs; an iteration has num_envs x horizon samples",
    "horizon": "env steps per env per iteration",
    "sampling": "continuing: env states carry over with automatic resets; episodic: every env restarts each "
    "iteration and steps after an episode's end are masked",
    "sample_budget": "episodic sampling: keep at most this many valid samples, env by env (0: all)",
    "gamma": "discount factor",
    "normalize_observations": "standardise observations by running statistics",
    "eval_envs": "mean-policy evaluation episodes, run between compiled calls (0: no evaluation)",
    "eval_every": "iterations between mean-policy evaluations (one always runs after the last iteration)",
    "eval_horizon": "steps of an evaluation episode (0: the task's time limit)",
    "eval_action": "how the mean policy acts in evaluations: mode (clip(mean)) or clipped_mean (E[clip(a)] under "
    "the Gaussian, the mean of the actions the clipped task executes)",
    "max_update_kl": "roll back an update whose mean KL(old || new) exceeds this (0: never)",
    # networks
    "policy": "policy distribution (categorical is implied by a discrete task)",
    "policy_hidden": "hidden layer sizes of the policy network",
    "policy_activation": "activation of the hidden layers of the policy network",
    "network_init": "initialisation of the weights and biases of the policy and value networks",
    "policy_head_scale": "multiply the policy network's last layer by this at initialisation (0.01: initial mean "
    "actions near 0)",
    "conv_torso": "convolutions before the hidden layers of both networks, on a task with image observations: "
    "mnih2013 (16 8x8/4, 32 4x4/2) or nature (32 8x8/4, 64 4x4/2, 64 3x3/1)",
    "log_std_init": "initial log standard deviation of a Gaussian policy",
    "log_std_final": "where the falling log-std ceiling ends (see anneal_log_std_iterations)",
    "log_std_min": "hold a gaussian policy's learned log-std at or above this (-20: no floor)",
    "anneal_log_std_iterations": "cap a gaussian policy's log-std by a ceiling falling linearly from log_std_init "
    "to log_std_final over this many iterations (0: off)",
    "value_hidden": "hidden layer sizes of the value network",
    "value_activation": "activation of the hidden layers of the value network",
    # advantages and value fit
    "gae_lambda": "GAE lambda (1: Monte-Carlo advantages, 0: one-step TD errors)",
    "normalize_advantages": "standardise the advantages of each batch",
    "value_target": "what the value network fits: gae (lambda-returns) or returns (discounted returns)",
    "normalize_value_targets": "fit the value network to standardised targets (running statistics, outputs "
    "preserved when they move)",
    "value_lr": "learning rate of the value fit (Adam; VPG: 0 takes the policy's lr)",
    "value_epochs": "passes over the batch of the value fit per iteration",
    "value_batch_size": "samples per minibatch of the value fit (0: the whole batch)",
    "value_minibatches": "minibatches per value-fit epoch, whatever the batch size (0: use value_batch_size)",
    "value_epoch_samples": "at most this many samples per value-fit epoch, drawn from larger batches (0: all)",
    "reward_scaling": "multiply rewards by this before advantages and value targets",
    "normalize_rewards": "divide rewards by a running std of the discounted return, clipped to [-10, 10], before "
    "reward_scaling (SB3's VecNormalize, Gymnasium's NormalizeReward)",
    # natural gradient and trust region
    "kl_delta": "NPG's normalised step: the step's KL in the Fisher metric is kl_delta / 2; its measured KL may "
    "reach kl_delta",
    "cg_iters": "conjugate-gradient iterations for the natural direction F^-1 g",
    "cg_damping": "damping added to the Fisher matrix (F + damping I)",
    "fisher_samples": "samples of the batch drawn for the Fisher-vector products of the solve (0: all)",
    "fvp": "Fisher-vector product: gauss_newton (J'MJ with the analytic Fisher of the distribution) or "
    "kl_hessian (Hessian of the mean KL)",
    "max_kl": "TRPO's bound on the mean KL of an update",
    "backtracks": "TRPO's line-search steps (each shrinks the step by backtrack_ratio)",
    "backtrack_ratio": "TRPO's step shrink factor per line-search step",
    "accept_ratio": "TRPO accepts a step whose improvement is at least this share of the expected one",
    # first-order optimisation
    "optimizer": "optimizer of the policy (and, for actor-critics, the value) parameters",
    "lr": "learning rate",
    "weight_decay": "decoupled weight decay (adamw)",
    "rmsprop_decay": "RMSprop's decay of the squared-gradient average",
    "rmsprop_eps_in_sqrt": "RMSprop divides by sqrt(average + eps) (optax, MXNet) or, false, by sqrt(average) + eps "
    "(PyTorch)",
    "eps": "optimizer epsilon",
    "adam_eps": "Adam's epsilon",
    "max_grad_norm": "clip the global gradient norm to this (0: no clipping)",
    "anneal_kl_iterations": "anneal NPG's kl_delta linearly to 0 over this many iterations (0: constant)",
    "anneal_lr_iterations": "anneal the learning rate linearly to 0 over this many iterations (0: constant)",
    "return_normalization": "how returns are standardised before the gradient: per episode, per batch or not",
    "entropy_coef": "weight of the entropy bonus",
    "value_coef": "weight of the value loss in the joint actor-critic loss",
    # PPO
    "num_epochs": "PPO epochs over each batch",
    "num_minibatches": "PPO minibatches per epoch",
    "clip_eps": "PPO's clipping of the probability ratio",
    "value_clip_eps": "clip value predictions to this distance from the old ones (0: no clipping)",
    "normalize_minibatch_advantages": "standardise each minibatch's advantages before its step (SB3, CleanRL, "
    "Tianshou, Brax)",
    "recompute_advantages": "recompute advantages and value targets with the current value network before every "
    "epoch after the first (Tianshou's recompute_advantage)",
}

# Values a string field accepts, where they are the same for every algorithm.
FIELD_CHOICES: dict[str, tuple[str, ...]] = {
    "sampling": ("continuing", "episodic"),
    "eval_action": ("mode", "clipped_mean"),
    "policy": ("gaussian", "state_std_gaussian"),
    "policy_activation": tuple(ACTIVATIONS),
    "value_activation": tuple(ACTIVATIONS),
    "network_init": KERNEL_INITS,
    "conv_torso": tuple(CONV_TORSOS),
    "fvp": ("gauss_newton", "kl_hessian"),
    "value_target": ("gae", "returns"),
    "return_normalization": ("episode", "batch", "none"),
}


def field_help(name: str) -> str:
    """The one-line meaning of Config field ``name`` (``""`` if it has none)."""
    return FIELD_HELP.get(name, "")


def field_choices(config_cls: type, name: str) -> tuple[str, ...] | None:
    """The values ``config_cls``'s string field ``name`` accepts, or ``None`` when free."""
    own = getattr(config_cls, "FIELD_CHOICES", {})
    return own.get(name) or FIELD_CHOICES.get(name)
