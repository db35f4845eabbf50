"""A2C (or PPO) runs of ``benchmarks/pong.py`` through the command line, and the running reward from their metrics."""

from __future__ import annotations

import importlib.util
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from jaxpg import algos
from jaxpg.run.command import command_line
from jaxpg.run.command import plan as plan_lib
from jaxpg.run.outputs import metrics_log
from jaxpg.run.rundir import config_io, layout
from jaxpg.run.training import session

ROOT = Path(__file__).resolve().parents[2]
RUNNING_DECAY = 0.99  # running reward: EMA over games, as in the seed
EXPERIMENTS = {"pong": "experiments/pong.py", "atari_pong": "experiments/atari_pong.py"}
NO_LIMIT = 10**9  # iterations of a run that stops at its time limit


def load_experiment(task: str) -> command_line.Experiment:
    """The ``EXPERIMENT`` of the experiment script that trains ``task``."""
    path = ROOT / EXPERIMENTS[task]
    spec = importlib.util.spec_from_file_location(f"{task}_experiment", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.EXPERIMENT


# ---------------------------------------------------------------------------------------------
# A2C runs through the command line, and the running reward from their metrics.


def run_name(num_envs: int, horizon: int | None, lr: float | None, seed: int, algo: str = "a2c") -> str:
    """The run directory's name under ``--run-dir``: ``envs16-seed0``, with ``-tmax5`` and ``-lr0.002``
    where they are not the experiment's, and the algorithm in front when it is not A2C
    (``ppo-envs16-seed0``)."""
    tmax = "" if horizon is None else f"-tmax{horizon}"
    prefix = "" if algo == "a2c" else f"{algo}-"
    return f"{prefix}envs{num_envs}{tmax}{'' if lr is None else f'-lr{lr:g}'}-seed{seed}"


def experiment_horizon(task: str, algo: str) -> int:
    """Env steps per iteration and env of ``algo`` in the experiment that trains ``task``."""
    config = load_experiment(task).config.get(algo, {})
    return config.get("horizon", algos.get(algo).Config().horizon)


def run_argv(
    run_dir: Path,
    task: str,
    num_envs: int,
    seed: int = 0,
    lr: float | None = None,
    horizon: int | None = None,
    seconds: float | None = None,
    iterations: int | None = None,
    size: int | None = None,
    call_steps: int = 2048,
    algo: str = "a2c",
) -> list[str]:
    """The experiment's command line of one ``algo`` run (A2C: MinPy's comparison; PPO, the
    experiment's default on the ROM): ``iterations``, or ``seconds`` of training.

    A compiled call (a block, between metrics reaching the host) covers about ``call_steps`` env
    steps (1 to 256 iterations): one iteration at GPU-sized batches, many at small ones, where a
    call's latency would otherwise dominate. Checkpoints only at the end.
    """
    samples = num_envs * (horizon or experiment_horizon(task, algo))
    per_call = min(max(round(call_steps / samples), 1), 256)
    argv = ["--algo", algo, "--num-envs", str(num_envs), "--seed", str(seed), "--run-dir", str(run_dir)]
    argv += ["--log-every", str(per_call), "--checkpoint-every", "0", "--no-progress"]
    argv += ["--iterations", str(iterations or NO_LIMIT)]
    if iterations is None:
        argv += ["--minutes", repr(seconds / 60.0)]
    for flag, value in (("--lr", lr), ("--horizon", horizon), ("--size", size)):
        if value is not None:
            argv += [flag, repr(value) if isinstance(value, float) else str(value)]
    return argv


def train_run(plan: plan_lib.Plan) -> None:
    """Run one planned command line (``jaxpg.run.training.session.execute``); ``RuntimeError`` if it does not
    finish with status 0."""
    status = session.execute(plan)
    if status != 0:
        raise RuntimeError(f"the run {' '.join(plan.command)} ended with status {status}")


def running_reward(records: Sequence[dict[str, Any]], block: int, decay: float = RUNNING_DECAY) -> list[dict]:
    """The seed's running reward along a run's ``metrics.jsonl`` records (one seed).

    An iteration in which ``k`` games ended with mean final score ``m`` counts as ``k`` games of
    score ``m``: ``running = decay^k running + (1 - decay^k) m`` (the first game's score first).
    ``wall_s`` counts from the end of iteration ``block`` (the first compiled block, which
    compiles); the records of that block are left out. Each row: ``wall_s``, ``env_steps``,
    ``iteration``, ``running_reward`` (NaN before the first game ended), ``mean_reward`` (per
    step), ``games`` (so far).
    """
    block = min(block, records[-1]["iteration"])
    start = next(r["wall_time_s"] for r in records if r["iteration"] == block)
    running, games, rows = math.nan, 0, []
    for r in records:
        k, score = int(r.get("episodes") or 0), r.get("return_stochastic")
        if k > 0 and score is not None:
            running = score if math.isnan(running) else decay**k * running + (1.0 - decay**k) * score
            games += k
        if r["iteration"] > block:
            rows.append(
                {
                    "wall_s": r["wall_time_s"] - start,
                    "env_steps": r["env_steps"],
                    "iteration": r["iteration"],
                    "running_reward": running,
                    "mean_reward": r["mean_reward"],
                    "games": games,
                }
            )
    return rows


def summarize(run_dir: Path, thresholds: Sequence[float]) -> dict:
    """One run's results: its settings, seconds of its first block (compilation included),
    wall-clock seconds
    and env steps at which the running reward first exceeded each threshold (``None`` where it never
    did), the final running reward, and the curve at most twice a second."""
    run = config_io.RunConfig.load(run_dir)
    records = metrics_log.read_metrics(run_dir / layout.METRICS_FILE)
    curve = running_reward(records, run.block_size)
    block = min(run.block_size, records[-1]["iteration"])
    first_block = next(r["wall_time_s"] for r in records if r["iteration"] == block)
    reached = {}
    for threshold in thresholds:
        first = next((r for r in curve if r["running_reward"] > threshold), None)
        reached[str(threshold)] = (
            None if first is None else {"seconds": first["wall_s"], "env_steps": first["env_steps"]}
        )
    kept, last_kept = [], -math.inf
    for r in curve:
        if r["wall_s"] - last_kept >= 0.5 or r is curve[-1]:
            kept.append({k: None if isinstance(v, float) and math.isnan(v) else v for k, v in r.items()})
            last_kept = r["wall_s"]
    last = curve[-1] if curve else {"running_reward": math.nan, "games": 0, "env_steps": 0, "wall_s": 0.0}
    return {
        "run_dir": str(run_dir),
        "algo": run.algo,
        "num_envs": run.config["num_envs"],
        "seed": run.seeds[0],
        "lr": run.config["lr"],
        "horizon": run.config["horizon"],
        "first_block_s": first_block,
        "reached": reached,
        "final_running_reward": last["running_reward"],
        "games": last["games"],
        "env_steps": last["env_steps"],
        "wall_s": last["wall_s"],
        "curve": kept,
    }
