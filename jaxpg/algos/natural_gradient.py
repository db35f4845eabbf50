"""What NPG and TRPO share: the vanilla policy gradient of the importance-weighted surrogate and
the natural direction ``F^-1 g``, solved by conjugate gradient on Fisher-vector products
(Kakade 2001; Schulman et al. 2015), and the settings those read.

Both algorithms then differ only in how far they step along the direction: NPG's normalised step
(``jaxpg.algos.npg``), TRPO's line search (``jaxpg.algos.trpo``). Vectors here are flat,
``[num_params]`` (``jax.flatten_util.ravel_pytree`` of the policy parameters).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from jaxpg import linalg
from jaxpg.algos import core
from jaxpg.envs import Env


@dataclasses.dataclass(frozen=True)
class NaturalGradientConfig(core.GAEConfig, core.ValueFitConfig):
    """The fields of NPG and TRPO besides their step: GAE advantages, the value fit (LyceumAI's:
    3 epochs of minibatch Adam at 1e-3) and the Fisher solve.

    ``cg_iters`` conjugate-gradient iterations solve ``(F + cg_damping I) x = g``; ``fvp`` selects
    the Fisher-vector product (``"gauss_newton"``: J'MJ with the distribution's analytic Fisher
    metric, or ``"kl_hessian"``: the Hessian of the mean KL; ``jaxpg.linalg``). ``fisher_samples``
    > 0 builds the products of the solve from that many samples of the batch, drawn afresh each
    iteration (Schulman et al. 2015 used 10 % of the batch), so that the solve stops growing with
    the batch; the gradient and the KL checks still use every sample.
    """

    gamma: float = 0.995
    gae_lambda: float = 0.97
    cg_iters: int = 10
    cg_damping: float = 1e-4
    fvp: str = "gauss_newton"
    fisher_samples: int = 0

    TRACED_FIELDS: ClassVar[tuple[str, ...]] = ("cg_damping",)

    def validate(self, env: Env) -> None:
        super().validate(env)
        if self.fvp not in ("gauss_newton", "kl_hessian"):
            raise ValueError(f"fvp must be 'gauss_newton' or 'kl_hessian', got {self.fvp!r}")
        if self.cg_iters < 1:
            raise ValueError(f"cg_iters must be >= 1, got {self.cg_iters}")
        if not self.cg_damping >= 0:
            raise ValueError(f"cg_damping must be >= 0, got {self.cg_damping}")
        if self.fisher_samples < 0:
            raise ValueError(f"fisher_samples must be >= 0 (0: all), got {self.fisher_samples}")


def init(key: jax.Array, env: Env, config: NaturalGradientConfig) -> core.TrainState:
    """A fresh ``TrainState`` for NPG or TRPO: networks, the value fit's optimizer, env batch (the
    policy steps in closed form and has no optimizer state)."""
    return core.init_state(key, env, config, value_optimizer=core.value_optimizer(config))


def surrogate(ts: core.TrainState, params: Any, batch: core.Batch) -> jax.Array:
    """``[]`` importance-weighted surrogate ``E[pi(a|s) / pi_old(a|s) * A]`` over the valid
    samples; its gradient at the sampling parameters is the vanilla policy gradient."""
    ratio = jnp.exp(ts.policy.log_prob(params, batch.obs, batch.actions) - batch.log_probs)
    return core.weighted_mean(ratio * batch.advantages, batch.weights)


def policy_gradient(ts: core.TrainState, batch: core.Batch) -> Any:
    """The vanilla policy gradient ``g`` at ``ts.params``, a pytree like the parameters."""
    return jax.grad(surrogate, argnums=1)(ts, ts.params, batch)


def phase_gradient(ts: core.TrainState, batch: core.Batch) -> jax.Array:
    """The vanilla policy gradient ``g`` at ``ts.params``, flat ``[num_params]``."""
    return ravel_pytree(policy_gradient(ts, batch))[0]


def fisher_operator(ts: core.TrainState, obs: jax.Array, weights: jax.Array) -> Callable[[Any], Any]:
    """``v -> (F + cg_damping I) v`` on pytrees like the parameters, ``F`` the policy's Fisher
    matrix at ``ts.params`` averaged over the states ``obs [M, obs_dim]`` weighted by
    ``weights [M]`` (``config.fvp`` says how)."""
    damping = core.run_config(ts).cg_damping
    return linalg.make_fisher_vector_product(
        ts.policy, ts.params, obs, weights=weights, damping=damping, mode=ts.config.fvp
    )


def fisher_vector_product(ts: core.TrainState, obs: jax.Array, weights: jax.Array) -> Callable[[jax.Array], jax.Array]:
    """``fisher_operator`` on flat vectors: ``v [num_params] -> (F + cg_damping I) v [num_params]``."""
    return flat_operator(fisher_operator(ts, obs, weights), ts.params)


def flat_operator(operator: Callable[[Any], Any], params: Any) -> Callable[[jax.Array], jax.Array]:
    """``operator`` (pytrees shaped like ``params`` in and out) on flat ``[num_params]`` vectors."""
    _, unravel = ravel_pytree(params)
    return lambda v: ravel_pytree(operator(unravel(v)))[0]


FISHER_STREAM = 0x666973  # folded into the state's key to draw the Fisher subsample


def fisher_subsample(ts: core.TrainState, batch: core.Batch) -> tuple[jax.Array, jax.Array]:
    """The states and weights the solve's Fisher-vector products average over: all ``N`` of the
    batch, or ``config.fisher_samples`` of them drawn uniformly with replacement (a fresh draw each
    iteration, from the state's key) when that is fewer. Returns ``obs [M, obs_dim]``, ``weights [M]``."""
    n, m = batch.obs.shape[0], ts.config.fisher_samples
    if m <= 0 or m >= n:
        return batch.obs, batch.weights
    rows = jax.random.randint(jax.random.fold_in(ts.key, FISHER_STREAM), (m,), 0, n)
    return batch.obs[rows], batch.weights[rows]


def phase_natural_gradient(ts: core.TrainState, batch: core.Batch, grad: jax.Array) -> linalg.CGResult:
    """The natural direction ``x = F^-1 g [num_params]`` by ``config.cg_iters`` conjugate-gradient
    iterations on ``fisher_vector_product`` over ``fisher_subsample``'s states."""
    fvp = fisher_vector_product(ts, *fisher_subsample(ts, batch))
    return linalg.conjugate_gradient(fvp, grad, ts.config.cg_iters)
