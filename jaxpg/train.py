"""The training loop: many iterations per compiled call, evaluation and host callbacks between calls.

``update`` (from any ``jaxpg.algos`` module) is ``lax.scan``-ned over ``block_size`` iterations in
one jitted program; after each block the host receives the block's metrics (``[block_size]``
arrays, or ``[block_size, num_seeds]`` when training several seeds) and calls the callbacks
(logging, checkpoints, progress bars). Several seeds train in one program by ``vmap``-ing ``init``
and ``update`` (``init_seeds`` / ``seeds=True``).

The mean policy is evaluated by a separate jitted function (``evaluate_state``) between compiled
training calls, after every ``config.eval_every``-th iteration and after the last one, as Brax's
evaluator runs between epochs: the training program never contains the evaluation rollout, so
iterations that are not evaluated pay nothing for it. Its metrics (``EVAL_METRICS``) are NaN on
the other iterations, and ``evaluated`` (1 or 0) says which iterations were evaluated. The
evaluation program is compiled on a background thread while the training calls run (started after
the first call, once the physics kernels are loaded), so a run pays only for the evaluation rollouts.
"""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Callable, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from jaxpg import mesh
from jaxpg.algos import core
from jaxpg.algos.core import TrainState
from jaxpg.envs import compile_options

UpdateFn = Callable[[TrainState], tuple[TrainState, dict[str, jax.Array]]]
Callback = Callable[[TrainState, dict[str, np.ndarray], int], None]
EvaluateFn = Callable[[TrainState], dict[str, jax.Array]]
# XLA compile options, (name, value) pairs: see jaxpg.envs.compile_options.
CompileOptions = tuple[tuple[str, Any], ...]

EVAL_METRICS = ("return_mean_policy", "episode_length_mean_policy", "task_score_mean_policy")
# Folded into the training key to seed evaluations: they never consume or change training's draws.
EVAL_STREAM = 0x65766C


class TrainingDiverged(RuntimeError):
    """Raised when updates keep producing non-finite parameters or losses."""


def init_seeds(init: Callable[..., TrainState], seeds: Sequence[int], env: Any, config: Any) -> TrainState:
    """One ``TrainState`` per seed, stacked on a leading ``[num_seeds]`` axis (``vmap`` of ``init``)."""
    keys = jnp.stack([jax.random.PRNGKey(s) for s in seeds])
    return jax.vmap(lambda k: init(k, env, config))(keys)


def scan_updates(update: UpdateFn, train_state: TrainState, num_iterations: int) -> tuple[TrainState, dict]:
    """Pure: ``num_iterations`` updates as one ``lax.scan``; metrics stacked ``[num_iterations]``."""
    return jax.lax.scan(lambda ts, _: update(ts), train_state, None, length=num_iterations)


@functools.lru_cache(maxsize=32)
def compiled_block(update: UpdateFn, block_size: int, seeds: bool, options: CompileOptions = ()) -> Callable:
    """The jitted ``train_state -> (train_state, metrics)`` for one block (cached per update/size).

    With ``seeds`` the block is ``vmap``-ed over the leading seed axis and metrics come back as
    ``[block_size, num_seeds]``. The input state's buffers are donated. ``options``: XLA compile
    options, those of the env's programs (``compile_options.compiler_options(env)``).
    """
    step = jax.vmap(update) if seeds else update
    block = functools.partial(scan_updates, step, num_iterations=block_size)
    return compile_options.jit(block, None, options, donate_argnums=0)


@jax.jit
def own_buffers(tree: Any) -> Any:
    """A copy of ``tree`` whose every leaf has its own device buffer, committed to its device the
    way a jitted call's outputs are. ``train`` starts from it: its compiled blocks donate their
    input state, which XLA refuses when two leaves share a buffer (a state built eagerly can, e.g.
    an observation stored twice), and a block's first call on uncommitted leaves would compile a
    second program for the committed outputs of the next call."""
    return jax.tree.map(jnp.copy, tree)


def evaluate_state(train_state: TrainState) -> dict[str, jax.Array]:
    """Mean-policy evaluation of ``train_state``: ``config.eval_envs`` fresh episodes of the mode
    of the policy (``core.evaluate``), keyed by the training key folded with ``EVAL_STREAM``.

    Returns ``[]`` scalars named as in ``EVAL_METRICS``. Pure and jittable; ``train`` runs it
    between compiled training calls, never inside ``update``.
    """
    return _eval_metrics(core.evaluate(train_state, jax.random.fold_in(train_state.key, EVAL_STREAM)))


def _eval_metrics(summary: dict[str, jax.Array]) -> dict[str, jax.Array]:
    """``core.evaluate``'s summary under the names of ``EVAL_METRICS``."""
    return {
        "return_mean_policy": summary["episode_return"],
        "episode_length_mean_policy": summary["episode_length"],
        "task_score_mean_policy": summary["episode_task_score"],
    }


@functools.lru_cache(maxsize=32)
def compiled_evaluate(evaluate: EvaluateFn, seeds: bool, options: CompileOptions = ()) -> Callable:
    """The jitted ``evaluate`` (over the leading seed axis with ``seeds``: see ``evaluate_seeds``),
    compiled with the XLA compile ``options`` (as ``compiled_block``'s)."""
    return compile_options.jit(functools.partial(evaluate_seeds, evaluate) if seeds else evaluate, None, options)


def evaluate_seeds(evaluate: EvaluateFn, train_state: TrainState) -> dict[str, jax.Array]:
    """``evaluate`` of each seed of ``train_state`` (leading seed axis): metrics ``[num_seeds]``.

    A ``vmap`` over the seeds, except with MuJoCo Warp. Warp's contact buffer is one per batch of
    envs, shared by the seeds, and the evaluation's loop stops when its episodes have ended: under
    a ``vmap`` over seeds that loop's condition is per seed, which would give the shared buffer a
    seed axis that MJX's Warp step rejects. There the default evaluation (``evaluate_state``) runs
    every seed's episodes as one flat batch in one loop (``core.evaluate_seeds_together``: the
    same episodes); any other ``evaluate``, or a mesh that splits the envs, evaluates the seeds one
    after another (``lax.map``). Both leave out the env states (an evaluation starts fresh
    episodes).
    """
    if getattr(train_state.env, "impl", None) != "warp":
        return jax.vmap(evaluate)(train_state)
    train_state = train_state.replace(env_state=())
    if evaluate is evaluate_state and mesh.context_env_shards() == 1:
        keys = jax.vmap(jax.random.fold_in, in_axes=(0, None))(train_state.key, EVAL_STREAM)
        return _eval_metrics(core.evaluate_seeds_together(train_state, keys))
    return jax.lax.map(evaluate, train_state)


class _EarlyCompile:
    """Compiles a jitted function for given shapes and shardings (``jax.ShapeDtypeStruct``s) on a
    background thread.

    Calling it waits for the compilation and runs the compiled program; it falls back to the jitted
    function itself if the compilation failed (whose call then raises the error where it is seen)
    or the arguments do not fit the shapes.
    """

    def __init__(self, jitted: Callable, specs: Any) -> None:
        self._jitted = jitted
        self._compiled: Callable | None = None
        self._thread = threading.Thread(target=self._compile, args=(specs,), daemon=True)
        self._thread.start()

    def _compile(self, specs: Any) -> None:
        try:
            self._compiled = self._jitted.lower(specs).compile()
        except Exception:  # noqa: BLE001 - the jitted function raises it again when called
            self._compiled = None

    def wait(self) -> None:
        """Block until the background compilation has finished (or failed)."""
        self._thread.join()

    def __call__(self, *args: Any) -> Any:
        """The compiled program on ``args`` (the jitted function if it failed or they do not fit it)."""
        self.wait()
        if self._compiled is not None:
            try:
                return self._compiled(*args)
            except TypeError:  # other shapes or shardings than the example's: compile them the usual way
                pass
        return self._jitted(*args)


@functools.lru_cache(maxsize=32)
def _early_compile(jitted: Callable, spec_leaves: tuple, treedef: Any) -> _EarlyCompile:
    return _EarlyCompile(jitted, jax.tree.unflatten(treedef, spec_leaves))


def early_evaluator(evaluate: EvaluateFn, seeds: bool, example: TrainState) -> Callable:
    """``compiled_evaluate(evaluate, seeds)`` compiled for ``example``'s shapes and shardings on a
    background thread, once per process (a later ``train`` call, e.g. a resumed run's next segment,
    reuses the program). Calling the result waits for the compilation."""
    specs = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=x.sharding), example)
    leaves, treedef = jax.tree.flatten(specs)
    options = compile_options.compiler_options(example.env)
    return _early_compile(compiled_evaluate(evaluate, seeds, options), tuple(leaves), treedef)


def _calls(first: int, n: int, eval_every: int) -> list[int]:
    """Sizes of the compiled calls for iterations ``first + 1 .. first + n``: one call, split after
    every multiple of ``eval_every`` (0: no evaluation) so that the evaluation runs between calls."""
    sizes: list[int] = []
    done = first
    while done < first + n:
        stop = first + n
        if eval_every > 0:
            stop = min(stop, (done // eval_every + 1) * eval_every)
        sizes.append(stop - done)
        done = stop
    return sizes


def _with_evaluations(metrics: dict[str, np.ndarray], evaluations: dict[int, tuple[dict, float]]) -> dict:
    """Add the ``EVAL_METRICS`` columns (NaN where not evaluated), ``evaluated`` (1 / 0) and
    ``eval_seconds`` (host wall time of the evaluation, 0 elsewhere) to a block's metrics;
    ``evaluations`` maps a row index to ``(evaluation metrics, seconds)``."""
    shape = next(iter(metrics.values())).shape
    out = dict(metrics)
    out["evaluated"] = np.zeros(shape, np.float32)
    out["eval_seconds"] = np.zeros(shape, np.float32)
    for name in EVAL_METRICS:
        out[name] = np.full(shape, np.nan, np.float32)
    for row, (values, seconds) in evaluations.items():
        out["evaluated"][row] = 1.0
        out["eval_seconds"][row] = seconds
        for name in EVAL_METRICS:
            out[name][row] = np.asarray(values[name])
    return out


def train(
    update: UpdateFn,
    train_state: TrainState,
    num_iterations: int,
    block_size: int = 10,
    callbacks: Sequence[Callback] = (),
    seeds: bool = False,
    max_consecutive_failures: int = 10,
    evaluate: EvaluateFn | None = evaluate_state,
    eval_every: int | None = None,
    final_eval: bool = True,
    before_first_call: Callable[[], None] | None = None,
) -> TrainState:
    """Run ``num_iterations`` more iterations from ``train_state``.

    Args:
      update: an algorithm's ``update``.
      train_state: from the algorithm's ``init`` (or ``init_seeds`` with ``seeds=True``).
      num_iterations: how many iterations to run; the last block may be shorter (one extra compile).
      block_size: iterations per block, i.e. how often the host sees metrics; a block is one
        compiled ``lax.scan``, split only where an evaluation falls inside it.
      callbacks: ``callback(train_state, metrics, first_iteration)`` after each block, where
        ``metrics`` maps names to NumPy arrays ``[n]`` (``[n, num_seeds]`` with seeds) and
        ``first_iteration`` is the 0-based index of the block's first iteration.
      seeds: ``train_state`` has a leading seed axis.
      max_consecutive_failures: raise ``TrainingDiverged`` once this many updates in a row were
        rejected as non-finite.
      evaluate: the evaluation run between calls (default ``evaluate_state``; ``None``: none). Wrap
        it like ``update`` (e.g. ``jaxpg.mesh.on_mesh``) when training on a mesh.
      eval_every: evaluate after every iteration whose 1-based count is a multiple of this
        (default: ``config.eval_every``; evaluation is off when ``config.eval_envs`` is 0).
      final_eval: also evaluate after the last of the ``num_iterations``.
      before_first_call: called once, after the first block's program is compiled (with MuJoCo
        Warp, the evaluation's program too) and before it runs (e.g.
        ``jaxpg.envs.warp_kernels.KernelBuild.wait``: MuJoCo Warp's kernels, built on other
        threads while XLA compiled, must be ready before a program launches them).
    Returns the final ``TrainState``.
    """
    config = train_state.config
    if evaluate is None or getattr(config, "eval_envs", 0) == 0:
        eval_every, final_eval = 0, False
    elif eval_every is None:
        eval_every = config.eval_every
    # Donation needs every leaf in its own buffer (states built eagerly can alias, e.g. an
    # observation stored twice), and a jitted copy also commits the leaves to their device the way
    # the block's outputs are, so the second block reuses the first block's compilation.
    train_state = own_buffers(train_state)
    start = int(np.max(jax.device_get(train_state.iteration)))
    # MuJoCo Warp captures its physics step into CUDA graphs while a program runs, and an XLA
    # compilation on another thread during a capture breaks it (CUDA error 901 or 904, which ends
    # the run): with Warp, nothing compiles while a program may run.
    warp = getattr(train_state.env, "impl", None) == "warp"
    options = compile_options.compiler_options(train_state.env)  # the same for every block
    evaluates = bool(eval_every or final_eval)
    evaluator: Any = None
    compiled_sizes: set[int] = set()
    done = 0
    try:
        while done < num_iterations:
            n = min(block_size, num_iterations - done)
            first = start + done
            chunks, evaluations, position = [], {}, first
            for size in _calls(first, n, eval_every):
                block = compiled_block(update, size, seeds, options)
                if evaluates and evaluator is None and warp:
                    evaluator = early_evaluator(evaluate, seeds, train_state)  # compiled beside the block
                if size not in compiled_sizes and (warp or before_first_call is not None):
                    if warp:
                        jax.block_until_ready(train_state)
                    block.lower(train_state).compile()  # the call below runs this very program
                    if evaluator is not None:
                        evaluator.wait()
                compiled_sizes.add(size)
                if before_first_call is not None:
                    before_first_call()
                    before_first_call = None
                train_state, chunk = block(train_state)
                if evaluates and evaluator is None:
                    evaluator = early_evaluator(evaluate, seeds, train_state)  # compiled while the block runs
                chunks.append(chunk)
                position += size
                is_last = done + n == num_iterations and position == first + n
                if (eval_every and position % eval_every == 0) or (final_eval and is_last):
                    jax.block_until_ready(train_state)  # time the evaluation alone, not the training queued before it
                    t0 = time.perf_counter()
                    values = jax.device_get(evaluator(train_state))
                    evaluations[position - first - 1] = (values, time.perf_counter() - t0)
            metrics = jax.tree.map(lambda *xs: np.concatenate([np.asarray(x) for x in xs]), *jax.device_get(chunks))
            if evaluate is not None:
                metrics = _with_evaluations(metrics, evaluations)
            for callback in callbacks:
                callback(train_state, metrics, first)
            failures = int(np.max(jax.device_get(train_state.failures)))
            if failures >= max_consecutive_failures:
                raise TrainingDiverged(
                    f"{failures} consecutive updates produced non-finite parameters or losses "
                    f"(iteration {first + n}); stopping instead of training on NaNs"
                )
            done += n
    finally:
        if evaluator is not None:
            evaluator.wait()  # never leave a compilation running: exiting under one aborts the process
    return train_state
