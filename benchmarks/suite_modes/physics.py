"""``suite.py physics``: each seed's policy replayed under Gymnasium's physics and jaxpg's fast fidelity."""

from __future__ import annotations

import argparse
import multiprocessing
import os
import statistics
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import harness

from suite_modes.verdicts import score_text

RAW = argparse.RawDescriptionHelpFormatter


PHYSICS_DOC = """Does a policy trained in jaxpg's fast physics lose return to Gymnasium's physics?

Every training seed's final mean policy (``jaxpg.load_policy``) of each RUN_DIR plays ``--episodes``
episodes of the task's Gymnasium env, built as ``python -m jaxpg.evaluate RUN --gymnasium`` builds
it (episode i reset with seed i), on MuJoCo's CPU, with the model's physics set to each variant:

  gymnasium        the model file's own settings (Hopper-v5: RK4, a Newton solve of up to 100
                   iterations and 50 line-search iterations);
  fast             jaxpg's fast fidelity (``jaxpg.envs.mjx_env``): Euler, 4 and 8 iterations;
  euler            Euler, the file's solver settings;
  rk4_fast_solver  the file's integrator, the fast fidelity's solver iterations.

The same simulator (MuJoCo, not MJX) runs every variant, so a difference is the physics settings'
alone. ``--actions`` chooses how the policy acts: ``run`` (the default), as the run's own
evaluations played it (its ``eval_action``, as ``python -m jaxpg.evaluate`` plays it); ``mode``
(``clip(mean)``); ``clipped_mean`` (``E[clip(a)]`` under the Gaussian, ``python -m jaxpg.evaluate
--mean-action clipped_mean``); with several, every variant is played each way. Prints each
seed's mean return and the episodes that ended early per variant (and action), then a summary of
each; ``--json`` gets every episode's return.

    python benchmarks/suite.py physics RUN_DIR --episodes 20 --workers 2 --json physics.json
    python benchmarks/suite.py physics RUN_DIR --variants gymnasium --actions mode clipped_mean --episodes 10
"""
ACTIONS = ("run", "mode", "clipped_mean")
PHYSICS_VARIANTS = ("gymnasium", "fast", "euler", "rk4_fast_solver")


def set_physics(model: Any, variant: str) -> None:
    """Give ``model.opt`` (a Gymnasium env's ``MjModel``) the integrator and solver iterations of ``variant``."""
    import mujoco

    from jaxpg.envs import mjx_env

    if variant in ("fast", "euler"):
        model.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    if variant in ("fast", "rk4_fast_solver"):
        model.opt.iterations = mjx_env.FAST_SOLVER_ITERATIONS
        model.opt.ls_iterations = mjx_env.FAST_LS_ITERATIONS


def mujoco_name(integrator: int) -> str:
    """MuJoCo's name of an integrator: ``"EULER"``, ``"RK4"``, ..."""
    import mujoco

    return mujoco.mjtIntegrator(integrator).name.removeprefix("mjINT_")


def play_physics(job: tuple[str, int, str, str, int]) -> dict[str, Any]:
    """``job = (run_dir, seed, variant, action, episodes)``: the episodes of ``jaxpg.evaluate
    --gymnasium`` (``replay.evaluate_gymnasium``) under ``variant``'s physics, the policy acting by
    ``action`` (``ACTIONS``); their returns and how many ended before the time limit (a fall)."""
    import jaxpg
    from jaxpg.run.evaluation import replay

    run_dir, seed, variant, action, episodes = job
    policy = jaxpg.load_policy(run_dir, seed=seed, clipped_mean=None if action == "run" else action == "clipped_mean")
    task, env_kwargs = policy.run.task, policy.run.env_kwargs
    returns, lengths, _ = replay.evaluate_gymnasium(
        policy, task, env_kwargs, episodes, configure_model=lambda model: set_physics(model, variant)
    )
    env = replay.gymnasium_reference_env(task, env_kwargs)  # what the variant makes of the model, and the limit
    set_physics(env.unwrapped.model, variant)
    opt, limit = env.unwrapped.model.opt, env.spec.max_episode_steps
    env.close()
    physics = f"{mujoco_name(opt.integrator)} {int(opt.iterations)}/{int(opt.ls_iterations)} iterations"
    return {"run_dir": run_dir, "seed": seed, "variant": variant, "action": action, "returns": returns.tolist(),
            "early": int((lengths < limit).sum()), "mean": float(returns.mean()), "opt": physics}  # fmt: skip


def played_line(result: dict[str, Any], done: int, total: int) -> str:
    """One progress line for a finished ``play_physics`` job: ``[done/total] RUN seed S, VARIANT,
    ACTION: MEAN (E early)``."""
    where = f"{Path(result['run_dir']).name} seed {result['seed']}, {result['variant']}, {result['action']}"
    return f"[{done}/{total}] {where}: {score_text(result['mean'])} ({result['early']} early)"


def physics_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="suite.py physics", description=PHYSICS_DOC, formatter_class=RAW)
    parser.add_argument("run_dirs", nargs="+", metavar="RUN_DIR")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per seed and variant (default: 20)")
    parser.add_argument("--variants", nargs="+", choices=PHYSICS_VARIANTS, default=list(PHYSICS_VARIANTS))
    parser.add_argument(
        "--actions", nargs="+", choices=ACTIONS, default=["run"], help="how the policy acts (default: as the run does)"
    )
    parser.add_argument("--workers", type=int, default=2, help="processes playing side by side (default: 2)")
    parser.add_argument("--bar", type=float, default=3000.0, help="the score counted in the summary (default: 3000)")
    parser.add_argument("--json", default=None)
    args = parser.parse_args(argv)
    os.environ["JAX_PLATFORMS"] = "cpu"  # inherited by the workers: the policies run on the CPU
    from jaxpg.run.checkpoints import policy_io

    seeds = {run_dir: policy_io.load_run_config(run_dir).seeds for run_dir in args.run_dirs}
    plays = [(v, a) for v in args.variants for a in args.actions]
    jobs = [(r, s, v, a, args.episodes) for r in args.run_dirs for s in seeds[r] for v, a in plays]
    results = []
    with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
        for result in pool.imap(play_physics, jobs, chunksize=1):  # in the jobs' order, each as it is done
            results.append(result)
            print(played_line(result, len(results), len(jobs)), file=sys.stderr, flush=True)
    name = {(v, a): v if len(args.actions) == 1 else f"{v}, {a}" for v, a in plays}
    by = {(r["run_dir"], r["seed"], name[r["variant"], r["action"]]): r for r in results}
    unique = len({Path(r).name for r in seeds}) == len(seeds)
    rows = [
        {"run": Path(r).name if unique else r, "seed": s, **{n: by[r, s, n] for n in name.values()}}
        for r in seeds
        for s in seeds[r]
    ]
    columns = [("run", lambda row: row["run"]), ("seed", lambda row: row["seed"])]
    columns += [(v, lambda row, v=v: f"{score_text(row[v]['mean'])} ({row[v]['early']} early)") for v in name.values()]
    print(harness.table(rows, columns))
    for v in name.values():
        means = [row[v]["mean"] for row in rows]
        early = sum(row[v]["early"] for row in rows)
        median = score_text(statistics.median(means))
        print(f"{v}: median {median}, {sum(m >= args.bar for m in means)} of {len(means)} "
              f"seeds >= {args.bar:g}, {early} of {len(means) * args.episodes} episodes ended early")  # fmt: skip
    harness.write_json(args.json, results, argv=list(argv))
