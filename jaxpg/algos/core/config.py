"""The configuration fields the core reads, in three frozen dataclasses that algorithms extend.

``BaseConfig`` holds what every algorithm has (sampling, networks, evaluation, the trust-region
guard); ``GAEConfig`` adds what ``core.phase_advantages`` reads (NPG, TRPO, PPO, A2C);
``ValueFitConfig`` adds what ``core.phase_value_fit`` reads (NPG, TRPO, VPG). An algorithm's
``Config`` extends one or both and adds its own fields; the core reads every field it needs as an
attribute, never with a fallback.

Two class attributes describe a ``Config`` to the command line and to saved runs:
``UNUSED_FIELDS`` names the fields the algorithm ignores (no flag; ``validate`` refuses a value
other than the default), and ``OLD_FIELD_NAMES`` maps the names that configs saved by earlier
versions used to the current ones (``None``: a field that is gone and changed no result), so that
old run directories still load (``jaxpg.run.rundir.config_io.config_from_dict``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

from jaxpg.envs import Env

POLICY_NAMES = ("gaussian", "state_std_gaussian")  # categorical is implied by a discrete env
NO_LOG_STD_FLOOR = -20.0  # log_std_min's default: no floor (a std of 2e-9; SB3's SAC clamps there)
EVAL_ACTIONS = ("mode", "clipped_mean")  # how the mean policy acts in evaluations (eval_action)


@dataclasses.dataclass(frozen=True)
class BaseConfig:
    """Fields common to all algorithms.

    Sampling: ``num_envs`` parallel envs each run ``horizon`` steps per iteration, so an
    iteration holds ``num_envs * horizon`` samples. ``sampling="continuing"`` carries the env
    state across iterations with automatic resets (Brax / PureJaxRL); ``"episodic"`` resets all
    envs every iteration and masks steps after each episode's end (LyceumAI / mjrl), and
    ``sample_budget`` > 0 then keeps only the first that many valid samples, env by env (as
    LyceumAI's sampler fills its budget).
    Networks: the policy (``policy``, ``policy_hidden``, ``policy_activation``, ``log_std_init``)
    and the value network (``value_hidden``, ``value_activation``), both initialised by the
    scheme ``network_init``; ``policy_head_scale`` then multiplies the policy's last layer (kernel
    and bias), e.g. 0.01 for an initial mean action near 0 whatever the observation (Andrychowicz
    et al. 2021, Tianshou, CleanRL). On a task whose observations are images (``Env.image_shape``),
    ``conv_torso`` (``networks.CONV_TORSOS``) puts convolutions before the hidden layers of both
    networks (each network has its own). ``normalize_value_targets`` makes the value network predict targets
    standardised by their running statistics (``TrainState.value_stats``), which the core keeps
    (``core.phase_value_fit``) and undoes (``core.value_predictions``).
    Evaluation (``jaxpg.train``, between compiled training calls, never inside ``update``): after
    every ``eval_every``-th iteration and after the last one, ``eval_envs`` episodes of the mean
    policy of up to ``eval_horizon`` steps (0: the env's limit); ``eval_envs=0`` turns it off.
    ``eval_action`` says how the mean policy of a Gaussian policy acts: ``"mode"``, its mean, which
    the task clips (``clip(mean)``); ``"clipped_mean"``, ``E[clip(a)]``, the mean of the actions the
    task executes under the Gaussian (``distributions.gaussian_clipped_mean``), which differs from
    ``clip(mean)`` when the std is wide against the action range. A run's saved setting is also what
    ``jaxpg.load_policy`` and ``python -m jaxpg.evaluate`` play by default.
    Exploration bounds (``core.log_std_bounds``): after every iteration a ``gaussian`` policy's
    learned log-std is held at or above ``log_std_min`` (-20, the default, or less: no floor) and, with
    ``anneal_log_std_iterations`` > 0, at or below a ceiling falling linearly from
    ``log_std_init`` to ``log_std_final`` over that many iterations.
    Trust-region guard: an update whose mean KL(old || new) over its batch exceeds
    ``max_update_kl`` is rolled back and counted in ``update_rejected`` (NPG first shrinks its
    step, see ``npg.update``); healthy updates move the policy by 0.001-0.1 nats. 0 turns it off.
    """

    num_envs: int = 64
    horizon: int = 128
    sampling: str = "continuing"
    sample_budget: int = 0
    gamma: float = 0.99
    normalize_observations: bool = False
    policy: str = "gaussian"  # gaussian | state_std_gaussian (categorical is implied by a discrete env)
    policy_hidden: tuple[int, ...] = (64, 64)
    policy_activation: str = "tanh"
    network_init: str = "glorot_uniform"
    policy_head_scale: float = 1.0
    conv_torso: str = "none"
    log_std_init: float = 0.0
    log_std_final: float = 0.0
    log_std_min: float = NO_LOG_STD_FLOOR
    anneal_log_std_iterations: int = 0
    value_hidden: tuple[int, ...] = (64, 64)
    value_activation: str = "tanh"
    normalize_value_targets: bool = False
    eval_envs: int = 8
    eval_every: int = 10
    eval_horizon: int = 0
    eval_action: str = "mode"
    max_update_kl: float = 1.0

    # The numeric fields an update may read as traced data (``core.hparams``); every subclass adds its own.
    TRACED_FIELDS: ClassVar[tuple[str, ...]] = (
        "gamma",
        "log_std_init",
        "log_std_final",
        "log_std_min",
        "anneal_log_std_iterations",
        "max_update_kl",
    )
    UNUSED_FIELDS: ClassVar[tuple[str, ...]] = ()
    # loop_unroll unrolled the learner's loops, which changed no number and, measured, no speed.
    OLD_FIELD_NAMES: ClassVar[dict[str, str | None]] = {"policy_init": "network_init", "loop_unroll": None}

    @property
    def has_log_std_bounds(self) -> bool:
        """Whether the policy's log-std is bounded at all: a floor above ``NO_LOG_STD_FLOOR`` or a
        falling ceiling (``core.log_std_bounds``)."""
        return self.log_std_min > NO_LOG_STD_FLOOR or self.anneal_log_std_iterations > 0

    def eval_action_bounds(self, env: Env) -> tuple[float, float] | None:
        """``(low, high)`` of ``env``'s actions when the mean policy acts with the clipped mean
        (``eval_action="clipped_mean"``), else ``None`` (it acts with its mode)."""
        if self.eval_action != "clipped_mean":
            return None
        return float(env.action_low), float(env.action_high)

    @property
    def samples_per_iteration(self) -> int:
        return self.num_envs * self.horizon

    def validate(self, env: Env) -> None:
        """Raise ``ValueError`` with one clear line for impossible settings (every field checked;
        every float field must be finite)."""
        from jaxpg.networks import ACTIVATIONS, CONV_TORSOS, KERNEL_INITS

        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, float) and not math.isfinite(value):
                raise ValueError(f"{field.name} must be a finite number, got {value}")
        for name in self.UNUSED_FIELDS:
            if getattr(self, name) != _default(type(self), name):
                raise ValueError(f"{type(self).__module__}.Config does not use {name}; leave it at its default")
        if self.num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {self.num_envs}")
        if self.horizon < 1:
            raise ValueError(f"horizon must be >= 1, got {self.horizon}")
        if self.sampling not in ("continuing", "episodic"):
            raise ValueError(f"sampling must be 'continuing' or 'episodic', got {self.sampling!r}")
        if self.sample_budget < 0:
            raise ValueError(f"sample_budget must be >= 0, got {self.sample_budget}")
        if not 0 <= self.gamma <= 1:
            raise ValueError(f"gamma must be in [0, 1], got {self.gamma}")
        if self.policy not in POLICY_NAMES:
            raise ValueError(f"unknown policy {self.policy!r}; expected one of {', '.join(POLICY_NAMES)}")
        for name in ("policy_activation", "value_activation"):
            if getattr(self, name) not in ACTIVATIONS:
                raise ValueError(f"unknown {name} {getattr(self, name)!r}; expected one of {', '.join(ACTIVATIONS)}")
        if self.network_init not in KERNEL_INITS:
            raise ValueError(f"unknown network_init {self.network_init!r}; expected one of {', '.join(KERNEL_INITS)}")
        if not self.policy_head_scale > 0:
            raise ValueError(f"policy_head_scale must be > 0, got {self.policy_head_scale}")
        if self.conv_torso not in CONV_TORSOS:
            raise ValueError(f"unknown conv_torso {self.conv_torso!r}; expected one of {', '.join(CONV_TORSOS)}")
        if self.conv_torso != "none" and (env.image_shape is None or not env.discrete):
            raise ValueError(
                f"conv_torso {self.conv_torso!r} needs a discrete task with image observations; {env.name} has none"
            )
        for name in ("policy_hidden", "value_hidden"):
            if any(int(size) < 1 for size in getattr(self, name)):
                raise ValueError(f"{name} must be positive layer sizes, got {' '.join(map(str, getattr(self, name)))}")
        if not math.isfinite(self.log_std_init):
            raise ValueError(f"log_std_init must be finite, got {self.log_std_init}")
        if self.anneal_log_std_iterations < 0:
            raise ValueError(f"anneal_log_std_iterations must be >= 0 (0: off), got {self.anneal_log_std_iterations}")
        self._validate_log_std_bounds(env)
        if self.eval_envs < 0 or self.eval_every < 1 or self.eval_horizon < 0:
            raise ValueError(
                f"eval_envs and eval_horizon must be >= 0 and eval_every >= 1, got "
                f"{self.eval_envs}, {self.eval_horizon}, {self.eval_every}"
            )
        if self.eval_action not in EVAL_ACTIONS:
            raise ValueError(f"eval_action must be one of {', '.join(EVAL_ACTIONS)}, got {self.eval_action!r}")
        if self.eval_action == "clipped_mean" and env.discrete:
            raise ValueError(f"eval_action clipped_mean needs a task with continuous actions; {env.name} has discrete")
        if not self.max_update_kl >= 0:
            raise ValueError(f"max_update_kl must be >= 0 (0: no check), got {self.max_update_kl}")

    def _validate_log_std_bounds(self, env: Env) -> None:
        """The log-std floor and falling ceiling (``core.log_std_bounds``) need a learned global
        log-std, a ceiling that falls, and an initial log-std within them (where the ceiling later
        falls below the floor, the floor wins)."""
        annealed = self.anneal_log_std_iterations > 0
        if not self.has_log_std_bounds:
            return
        if env.discrete or self.policy != "gaussian":
            raise ValueError(
                "log_std_min and anneal_log_std_iterations need the gaussian policy (a learned global log-std) "
                f"on a task with continuous actions; {env.name} with policy {self.policy!r} has none"
            )
        if annealed and self.log_std_final > self.log_std_init:
            raise ValueError(
                f"log_std_final ({self.log_std_final}) must be <= log_std_init ({self.log_std_init}): "
                "the ceiling only falls"
            )
        if self.log_std_min > self.log_std_init:
            raise ValueError(
                f"log_std_min ({self.log_std_min}) must be <= log_std_init ({self.log_std_init}): the policy starts "
                "within its bounds"
            )


def _default(config_cls: type, name: str) -> Any:
    """The default value of ``config_cls``'s field ``name``."""
    field = next(f for f in dataclasses.fields(config_cls) if f.name == name)
    return field.default if field.default is not dataclasses.MISSING else field.default_factory()


@dataclasses.dataclass(frozen=True)
class GAEConfig(BaseConfig):
    """Fields of advantages by GAE from the value function (``core.phase_advantages``).

    ``gae_lambda`` is GAE's lambda (1: Monte-Carlo advantages, 0: one-step TD errors);
    ``value_target`` is what the value network fits: ``"gae"`` (the lambda-returns) or
    ``"returns"`` (discounted returns, as LyceumAI fits); ``normalize_advantages`` standardises
    the advantages of each batch over its valid samples.
    """

    gae_lambda: float = 0.95
    normalize_advantages: bool = True
    value_target: str = "gae"

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("gae_lambda",)

    def validate(self, env: Env) -> None:
        super().validate(env)
        if not 0 <= self.gae_lambda <= 1:
            raise ValueError(f"gae_lambda must be in [0, 1], got {self.gae_lambda}")
        if self.value_target not in ("gae", "returns"):
            raise ValueError(f"value_target must be 'gae' or 'returns', got {self.value_target!r}")


@dataclasses.dataclass(frozen=True)
class ValueFitConfig(BaseConfig):
    """Fields of the value fit by minibatch regression (``core.phase_value_fit``).

    ``value_epochs`` passes over the batch, each in minibatches of ``value_minibatch_size``
    samples, with Adam at ``value_fit_lr``. ``value_minibatches`` > 0 cuts each epoch into that
    many minibatches whatever the batch size (the fit then takes the same number of steps at any
    ``num_envs`` and ``horizon``); otherwise minibatches hold ``value_batch_size`` samples (0: the
    whole batch). ``value_epoch_samples`` > 0 caps the samples one epoch visits (minibatches drawn
    with replacement from the batch when it holds more), so that the fit costs the same at any
    larger batch.
    """

    value_lr: float = 1e-3
    value_epochs: int = 3
    value_batch_size: int = 64
    value_minibatches: int = 0
    value_epoch_samples: int = 0

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("value_lr",)

    @property
    def value_samples_per_epoch(self) -> int:
        """Samples one value epoch visits: the iteration's, or ``value_epoch_samples`` if fewer."""
        if self.value_epoch_samples > 0:
            return min(self.value_epoch_samples, self.samples_per_iteration)
        return self.samples_per_iteration

    @property
    def value_minibatch_size(self) -> int:
        """Samples per value-fit minibatch (``value_minibatches`` wins over ``value_batch_size``)."""
        if self.value_minibatches > 0:
            return max(1, self.value_samples_per_epoch // self.value_minibatches)
        return self.value_batch_size or self.samples_per_iteration

    @property
    def value_fit_lr_field(self) -> str:
        """The field that holds the value fit's learning rate: ``value_lr``."""
        return "value_lr"

    @property
    def value_fit_lr(self) -> float:
        """The learning rate of the value fit's Adam: ``value_lr``."""
        return self.value_lr

    def validate(self, env: Env) -> None:
        super().validate(env)
        if not self.value_fit_lr > 0:
            raise ValueError(f"value_lr must be > 0 (the value fit's learning rate), got {self.value_lr}")
        if self.value_epochs < 1 or self.value_batch_size < 0:
            raise ValueError(
                f"value_epochs must be >= 1 and value_batch_size >= 0, got {self.value_epochs}, {self.value_batch_size}"
            )
        if self.value_minibatches < 0 or self.value_minibatches > self.samples_per_iteration:
            raise ValueError(
                f"value_minibatches must be in [0, {self.samples_per_iteration}] (the samples of an iteration), "
                f"got {self.value_minibatches}"
            )
        if self.value_epoch_samples < 0 or 0 < self.value_epoch_samples < self.value_minibatches:
            raise ValueError(
                f"value_epoch_samples must be 0 (all) or at least value_minibatches ({self.value_minibatches}), "
                f"got {self.value_epoch_samples}"
            )
        if self.value_minibatches == 0 and self.value_batch_size > self.samples_per_iteration:
            raise ValueError(
                f"value_batch_size {self.value_batch_size} exceeds the {self.samples_per_iteration} samples "
                f"of an iteration (num_envs {self.num_envs} x horizon {self.horizon})"
            )
