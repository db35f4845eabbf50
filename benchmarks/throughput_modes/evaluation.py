"""``throughput.py eval``: what one mean-policy evaluation costs, with and without its early stop."""

from __future__ import annotations

import argparse
import json
from collections.abc import Sequence
from typing import Any

import harness
import jax
import numpy as np

from jaxpg import envs

RAW = argparse.RawDescriptionHelpFormatter


EVAL_DOC = """What one mean-policy evaluation costs, per MJX implementation and device, with and without
stopping once every episode has ended.

A run's evaluation is ``eval_envs`` episodes of up to 1000 sequential env steps (``jaxpg.train.
evaluate_state``). At 16 envs a MuJoCo Warp step is a chain of small kernels, so the evaluation
costs about as much at 16 episodes as at 64 and is a fixed cost of every run (BENCHMARKS.md).
This times the evaluation of one policy, the mean policy from fresh resets as a run evaluates it
(``rollout.episode_totals_from``), each figure the median of ``--repeats`` synchronised calls
after the compiling one:

  early stop   as runs evaluate: the loop stops within 50 steps of the last episode's end;
  full         every episode stepped to the time limit (one chunk of 1000 steps: the work of the
               evaluation before it could stop early);

and the mean return and length reached (with the early stop, and the full evaluation's return),
so that a faster implementation or device can be checked to score the policy alike. The two
forms compute the same numbers (tested on the CPU); on a GPU MuJoCo Warp's steps are not
bit-reproducible from one program to another, so a hopping policy's 1000-step returns differ in
the last digits or more (docs/benchmarks_archive.md, sections AC and AP).

    python benchmarks/throughput.py eval RUN_DIR --impl warp jax --device default cpu --episodes 16 64
    python benchmarks/throughput.py eval --impl warp --episodes 16     # a fresh policy: episodes end early

Without ``RUN_DIR`` a freshly initialised policy of ``--task`` is evaluated (for Hopper the
``hopper`` preset's networks). On the CPU, small: ``--task inverted_pendulum --episodes 2
--impl jax``.
"""


def policy_to_evaluate(run_dir: str | None, task: str) -> tuple[str, dict[str, Any], Any, Any, Any]:
    """``(task, env_kwargs, policy, params, obs_stats)`` of ``run_dir``'s latest checkpoint, or of
    a fresh NPG policy for ``task`` (its ``hopper`` preset's networks for Hopper)."""
    if run_dir:
        from jaxpg.run.checkpoints import policy_io

        loaded = policy_io.load_policy(run_dir)
        return loaded.run.task, dict(loaded.run.env_kwargs), loaded.policy, loaded.params, loaded.obs_stats
    from jaxpg.algos import npg

    env = envs.make(task)
    overrides = npg.PRESETS["hopper"] if task == "hopper" else {}
    ts = npg.init(jax.random.PRNGKey(0), env, npg.Config(**overrides))
    return task, {}, ts.policy, ts.params, ts.obs_stats


def evaluation(env: Any, policy: Any, episodes: int, check_every: int) -> Any:
    """The jitted ``(params, obs_stats, key) -> {return, length, task_score}`` (``[episodes]``
    each) of the mean policy from fresh resets, checking every ``check_every`` steps whether all
    have ended."""
    from jaxpg import rollout as rollout_lib
    from jaxpg.algos.core import make_act

    horizon = int(env.max_episode_steps)

    def run(params: Any, obs_stats: Any, key: jax.Array) -> dict[str, jax.Array]:
        reset_key, steps_key = jax.random.split(key)
        state = rollout_lib.reset_batch(env, reset_key, episodes)
        act = make_act(policy, obs_stats, deterministic=True)
        return rollout_lib.episode_totals_from(env, act, params, state, steps_key, horizon, check_every)

    return jax.jit(run)


def eval_measure(
    task: str,
    env_kwargs: dict[str, Any],
    policy: Any,
    params: Any,
    obs_stats: Any,
    impl: str,
    device: str,
    episodes: int,
    repeats: int,
) -> dict[str, Any]:
    """One row: compile and median evaluation seconds of ``episodes`` episodes with ``impl`` on
    ``device`` (``"default"`` or ``"cpu"``), with the early stop and without, and the episodes'
    mean return and length."""

    target = jax.devices("cpu")[0] if device == "cpu" else jax.devices()[0]
    env = envs.make(task, **{**env_kwargs, "impl": impl})
    horizon = int(env.max_episode_steps)
    with jax.default_device(target):
        params_here, stats_here = jax.device_put((params, obs_stats), target)
        early = evaluation(env, policy, episodes, 50)
        full = evaluation(env, policy, episodes, horizon)
        compile_s, early_s, out = harness.time_calls(
            lambda i: early(params_here, stats_here, jax.random.PRNGKey(i)), repeats
        )
        out = jax.device_get(out)
        _, full_s, out_full = harness.time_calls(
            lambda i: full(params_here, stats_here, jax.random.PRNGKey(i)), repeats
        )
        out_full = jax.device_get(out_full)
    return {
        "task": task,
        "impl": impl,
        "device": target.device_kind if device != "cpu" else "cpu",
        "episodes": episodes,
        "horizon": horizon,
        "compile_s": compile_s,
        "eval_s": early_s,
        "eval_full_s": full_s,
        "ms_per_step": 1e3 * full_s / horizon,
        "return_mean": float(np.mean(out["return"])),
        "return_std": float(np.std(out["return"])),
        "return_full_mean": float(np.mean(out_full["return"])),
        "length_mean": float(np.mean(out["length"])),
        "length_max": float(np.max(out["length"])),
    }


def eval_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="throughput.py eval", description=EVAL_DOC, formatter_class=RAW)
    parser.add_argument("run_dir", nargs="?", help="a training run (default: a fresh policy of --task)")
    parser.add_argument("--task", default="hopper", help="without RUN_DIR: the task (default: hopper)")
    parser.add_argument("--impl", nargs="+", default=["warp", "jax"], choices=("warp", "jax"))
    parser.add_argument("--device", nargs="+", default=["default"], choices=("default", "cpu"))
    parser.add_argument("--episodes", nargs="+", type=int, default=[16])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", help="write the rows to this file")
    args = parser.parse_args(argv)
    task, env_kwargs, policy, params, obs_stats = policy_to_evaluate(args.run_dir, args.task)
    rows = []
    for device in args.device:
        for impl in args.impl:
            if impl == "warp" and device == "cpu":
                continue
            for episodes in args.episodes:
                row = eval_measure(task, env_kwargs, policy, params, obs_stats, impl, device, episodes, args.repeats)
                rows.append(row)
                print(f"# {json.dumps(row)}", flush=True)
    harness.write_json(args.json, rows)
    print(f"\n{task} {env_kwargs or ''}, {args.run_dir or 'fresh policy'}, median of {args.repeats} evaluations")
    print(
        "| impl | device | episodes | compile s | one evaluation s (early stop) | full s | ms per env step (full) "
        "| mean return | full: mean return | mean / max length |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['impl']} | {r['device']} | {r['episodes']} | {r['compile_s']:.1f} | {r['eval_s']:.3f} "
            f"| {r['eval_full_s']:.3f} | {r['ms_per_step']:.2f} | {r['return_mean']:.1f} ± {r['return_std']:.1f} "
            f"| {r['return_full_mean']:.1f} | {r['length_mean']:.0f} / {r['length_max']:.0f} |"
        )
