"""The algorithm core: what every jaxpg algorithm builds on and none writes again.

An iteration of any algorithm is ``update(ts) -> (ts, metrics)``, pure and jittable, made of
these pieces and the algorithm's own step:

  1. ``phase_sample``: sample ``[horizon, num_envs]`` transitions with the stochastic policy,
     within the sample budget (``sampling``);
  2. ``phase_advantages``: value predictions, GAE advantages and value targets, advantage
     normalisation, flattened into the training ``Batch`` (``advantages``, ``batch``); REINFORCE
     builds its ``Batch`` from Monte-Carlo returns instead;
  3. the algorithm's policy step (a natural-gradient step, a line search, a first-order step on
     a loss), measured by ``mean_kl`` and ``mean_entropy`` (``batch``);
  4. ``phase_value_fit``: fit the value network to the value targets, standardised when
     ``normalize_value_targets`` (``value_fit``), for algorithms that fit one separately;
  5. ``finish_iteration``: roll back a non-finite update or one outside the trust region, hold a
     Gaussian policy's log-std within its floor and falling ceiling (``log_std_bounds``), update
     the observation statistics, count the iteration and assemble the metrics (``iteration``).

``hparams`` lets an update read its numeric hyperparameters as traced data (``run_config``),
so that one program trains many configurations.
``TrainState`` and ``init_state`` (``state``) are the state every algorithm carries and how its
``init`` builds it; ``BaseConfig``, ``GAEConfig`` and ``ValueFitConfig`` (``config``) are the
fields the core reads, which every algorithm's ``Config`` extends. ``evaluate`` runs episodes of
the mean policy (``jaxpg.train`` calls it between compiled training calls).

The submodules hold one concept each; this package re-exports their public names, so that an
algorithm writes ``from jaxpg.algos import core`` and ``core.phase_sample(ts)``.
"""

from jaxpg.algos.core.advantages import AdvantageFn, gae_advantages, phase_advantages, value_predictions
from jaxpg.algos.core.batch import Batch, flatten_batch, mean_entropy, mean_kl, weighted_mean
from jaxpg.algos.core.config import POLICY_NAMES, BaseConfig, GAEConfig, ValueFitConfig
from jaxpg.algos.core.hparams import (
    derived,
    divide,
    hyperparameters,
    is_traced,
    program_key,
    run_config,
    traced_fields,
    with_hyperparameters,
)
from jaxpg.algos.core.iteration import PhaseRunner, accept_if_finite, finish_iteration, run_inline
from jaxpg.algos.core.log_std_bounds import clip_log_std, log_std_ceiling
from jaxpg.algos.core.placement import shard_state
from jaxpg.algos.core.reward_normalization import RewardNormalizer, normalize_rewards, normalize_trajectory_rewards
from jaxpg.algos.core.sampling import (
    REPLICATED,
    apply_sample_budget,
    env_batch_mask,
    evaluate,
    evaluate_seeds_together,
    make_act,
    phase_sample,
    sample,
    sampling_metrics,
    split_over_envs,
)
from jaxpg.algos.core.state import (
    RunningStats,
    TrainState,
    clip_gradients,
    init_state,
    make_networks,
    memory_lower_bound,
    sampler_env,
)
from jaxpg.algos.core.value_fit import (
    absorb_value_targets,
    phase_value_fit,
    standardise_value_targets,
    standardised_targets,
    value_optimizer,
)

__all__ = [
    "POLICY_NAMES",
    "PhaseRunner",
    "REPLICATED",
    "AdvantageFn",
    "BaseConfig",
    "Batch",
    "GAEConfig",
    "RewardNormalizer",
    "RunningStats",
    "TrainState",
    "ValueFitConfig",
    "absorb_value_targets",
    "accept_if_finite",
    "derived",
    "divide",
    "hyperparameters",
    "is_traced",
    "program_key",
    "run_config",
    "traced_fields",
    "with_hyperparameters",
    "apply_sample_budget",
    "clip_log_std",
    "clip_gradients",
    "env_batch_mask",
    "evaluate",
    "evaluate_seeds_together",
    "finish_iteration",
    "flatten_batch",
    "gae_advantages",
    "init_state",
    "log_std_ceiling",
    "make_act",
    "make_networks",
    "mean_entropy",
    "mean_kl",
    "memory_lower_bound",
    "normalize_rewards",
    "normalize_trajectory_rewards",
    "phase_advantages",
    "phase_sample",
    "phase_value_fit",
    "run_inline",
    "sample",
    "sampler_env",
    "sampling_metrics",
    "shard_state",
    "split_over_envs",
    "standardise_value_targets",
    "standardised_targets",
    "value_optimizer",
    "value_predictions",
    "weighted_mean",
]
