"""From flags to a ``Plan``: every check that can fail is made here, before anything is compiled
or written (a fresh run or a resumed one)."""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import re
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import jax

from jaxpg import envs
from jaxpg.run.checkpoints import checkpointer, policy_io
from jaxpg.run.command import preset_choice, task_options
from jaxpg.run.command.command_line import (
    CONFIG_PREFIX,
    ENV_PREFIX,
    Experiment,
    algo_module,
    build_parser,
    flag_name,
)
from jaxpg.run.command.flags import UsageError
from jaxpg.run.command.plan import Plan
from jaxpg.run.command.pre_flags import PreFlags, parse_pre_flags
from jaxpg.run.command.preset_choice import ResolvedPreset
from jaxpg.run.command.startup_times import StartupTimes
from jaxpg.run.host.memory import check_memory
from jaxpg.run.outputs import metrics_log
from jaxpg.run.rundir import config_io, directory, layout, replacing, run_lock
from jaxpg.run.rundir.config_io import RunConfig

CHECKPOINTS_PER_RUN = 20
"""A long run's default checkpoint period keeps it to about this many periodic checkpoints."""


def default_checkpoint_every(every: int, iterations: int, log_every: int) -> int:
    """The checkpoint period of a run without ``--checkpoint-every``: ``every`` (the command's
    default, 50), or for a long run of short iterations (A2C's 12,500 within 1 M env steps) a
    ``CHECKPOINTS_PER_RUN``-th of its ``iterations``, rounded up to a multiple of ``log_every`` so
    that blocks stay ``log_every`` long. Each checkpoint holds the whole training state (tens of MB
    with many seeds) and takes a large part of a second to write."""
    share = math.ceil(iterations / CHECKPOINTS_PER_RUN)
    if share <= every:
        return every
    return math.ceil(share / log_every) * log_every


def _check_task(task: str, experiment: Experiment) -> None:
    if ":" in task and not experiment.tasks:
        return  # brax:NAME, playground:NAME, module:Class: checked when made (jaxpg.envs.brax_task)
    allowed = experiment.tasks or tuple(envs.names())
    if task not in envs.names() or task not in allowed:
        raise UsageError(f"unknown task {task!r}; known tasks: {', '.join(allowed)}")


def _make_env(task: str, env_kwargs: dict[str, Any]) -> Any:
    try:
        return envs.make_shared(task, **env_kwargs)
    except TypeError as e:
        given = ", ".join(flag_name(k) for k in env_kwargs if k != "batch")
        raise UsageError(f"task {task!r} does not accept {given or 'these settings'} ({e})") from None
    except ValueError as e:  # e.g. --action-scaling on a discrete task
        raise UsageError(str(e)) from None
    except ImportError as e:  # a task whose simulator is an optional package (atari_pong: ale-py)
        raise UsageError(
            str(e).strip().splitlines()[0] if str(e).strip() else f"task {task!r} cannot be imported"
        ) from None


def _explicit_config(args: argparse.Namespace) -> dict[str, Any]:
    return {k[len(CONFIG_PREFIX) :]: v for k, v in vars(args).items() if k.startswith(CONFIG_PREFIX) and v is not None}


def _explicit_env(args: argparse.Namespace) -> dict[str, Any]:
    return {k[len(ENV_PREFIX) :]: v for k, v in vars(args).items() if k.startswith(ENV_PREFIX) and v is not None}


def _task_options(args: argparse.Namespace, task: str, preset_env: dict[str, Any]) -> dict[str, Any]:
    """The task options of the preset (among its ``preset_env``), then those of ``--env-kwargs``
    (``UsageError`` for one given twice, unknown to the task, or of the wrong type), converted to
    the task's types."""
    given = dict(args.env_kwargs or ())
    if len(given) < len(args.env_kwargs or ()):
        keys = [key for key, _ in args.env_kwargs]
        twice = sorted({key for key in keys if keys.count(key) > 1})
        raise UsageError(f"--env-kwargs gives {', '.join(twice)} more than once")
    options = {k: v for k, v in preset_env.items() if k not in task_options.PRESET_ENV_SETTINGS}
    try:
        return task_options.check_options(task, {**options, **given})
    except ValueError as e:
        raise UsageError(f"--env-kwargs: {e}") from None


def _wrapper_settings(args: argparse.Namespace, preset_env: dict[str, Any]) -> dict[str, Any]:
    """``jaxpg.envs.make``'s wrapper options (``action_scaling``): the preset's (among its
    ``preset_env``), then the flag's; kept in the run's ``env_kwargs`` only when on, so that a run
    without them reads as before."""
    settings = {k: preset_env[k] for k in task_options.WRAPPER_SETTINGS if k in preset_env}
    if args.action_scaling is not None:
        settings["action_scaling"] = args.action_scaling
    return {k: v for k, v in settings.items() if v}


def _default_run_dir(task: str, algo: str) -> Path:
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{task}-{algo}-{stamp}"


def _check_fresh_run_dir(run_dir: Path, overwrite: bool) -> None:
    """A new run may go into ``run_dir`` if it is missing or empty; with ``--overwrite``, also if it
    is a jaxpg run that no live process writes (``directory.check_replaceable``)."""
    if not run_dir.exists():
        return
    if not run_dir.is_dir():
        raise UsageError(f"run directory {str(run_dir)!r} exists and is not a directory")
    if not any(run_dir.iterdir()):
        return
    if not overwrite:
        raise UsageError(replacing.exists_message(run_dir))
    directory.check_replaceable(run_dir)
    run_lock.check_unlocked(run_dir)


def _device_count() -> int:
    return jax.device_count()


def _check_sharding(config: Any, explicit: bool | None) -> bool:
    """Whether the env batch is split over ``jax.devices()`` (all devices of all processes):
    by default when there are several; ``UsageError`` if ``--num-envs`` does not divide."""
    count, processes = jax.device_count(), jax.process_count()
    shard = (count > 1) if explicit is None else explicit
    if processes > 1 and not shard:
        raise UsageError(f"--no-shard cannot train with {processes} processes: the env batch is split over them")
    where = f"{count} devices ({processes} processes)" if processes > 1 else f"{count} devices"
    if shard and config.num_envs % count:
        raise UsageError(
            f"--num-envs {config.num_envs} is not divisible by the {where} the env batch is sharded over "
            "(use a multiple, or --no-shard)"
        )
    return shard and count > 1


def _with_preset_hint(message: str, preset: ResolvedPreset, explicit: dict[str, Any]) -> str:
    """``message`` (a ``Config.validate`` error) with the preset's part in it: the fields it names
    that ``--preset`` set and no flag changed, e.g. ``(--preset hopper_1m sets --log-std-final 1.0)``."""
    if preset.name is None:
        return message
    values = preset.config
    named = [k for k in values if k not in explicit and re.search(rf"\b{k}\b", message)]
    if not named:
        return message
    return f"{message} (--preset {preset.name} sets " + ", ".join(f"{flag_name(k)} {values[k]}" for k in named) + ")"


def plan_fresh(args: argparse.Namespace, experiment: Experiment, module: Any, algo: str) -> Plan:
    task = args.task or experiment.task
    _check_task(task, experiment)
    args = argparse.Namespace(**{**vars(args), "preset": experiment.preset_name(algo, args.preset)})
    config_cls = module.Config
    values = experiment.config_defaults(algo, config_cls)
    preset = preset_choice.resolve(algo, args.preset, task)  # the preset table, read once for the run
    values.update(preset.config)
    values.update(_explicit_config(args))
    types = config_io.field_types(config_cls)
    config = config_cls(**{k: config_io.coerce(types[k], v) for k, v in values.items()})
    preset_env = preset.env_kwargs
    env_kwargs = {**experiment.env_kwargs, **_task_options(args, task, preset_env), **_explicit_env(args)}
    env_kwargs.update(_wrapper_settings(args, preset_env))
    for key in ("fidelity", "impl", "max_episode_steps"):
        value = getattr(args, key)
        if value is None and key in task_options.PRESET_SIMULATION_SETTINGS:
            value = preset_env.get(key)
        if value is not None:
            env_kwargs[key] = value
    if args.max_episode_steps is not None and args.max_episode_steps < 1:
        raise UsageError(f"--max-episode-steps must be >= 1, got {args.max_episode_steps}")
    num_seeds = len(args.seeds) if args.seeds else 1
    shard = _check_sharding(config, args.shard)
    # With the batch split, each device steps (and the physics sizes its buffers for) its own share.
    shares = _device_count() if shard else 1
    per_device = max(-(-config.num_envs // shares), -(-config.eval_envs // shares))
    env_kwargs["batch"] = per_device * num_seeds
    env = _make_env(task, env_kwargs)
    try:
        config.validate(env)
    except ValueError as e:
        raise ValueError(_with_preset_hint(str(e), preset, _explicit_config(args))) from None
    check_memory(config, env, num_seeds, shares)
    seeds = list(args.seeds) if args.seeds else [experiment.seed if args.seed is None else args.seed]
    if len(set(seeds)) != len(seeds):
        raise UsageError(f"--seeds must be distinct, got {' '.join(map(str, seeds))}")
    if len(seeds) > 1 and not getattr(env.unwrapped, "vmap_seeds", True):
        raise UsageError(f"task {task!r} steps its games on the host: train one seed per command (--seed)")
    log_every = experiment.log_every if args.log_every is None else args.log_every
    if log_every < 1:
        raise UsageError(f"--log-every must be >= 1, got {log_every}")
    iterations = args.iterations
    if iterations is None:
        iterations = experiment.iterations if preset.iterations is None else preset.iterations
    if iterations < 1:
        # It would leave a run directory without a checkpoint: nothing to resume or evaluate.
        raise UsageError(f"--iterations must be >= 1 for a new run, got {iterations}")
    run = RunConfig(
        task=task,
        algo=algo,
        config=config_io.config_to_dict(config),
        seeds=seeds,
        iterations=iterations,
        env_kwargs=env_kwargs,
        log_every=log_every,
        checkpoint_every=(
            default_checkpoint_every(experiment.checkpoint_every, iterations, log_every)
            if args.checkpoint_every is None
            else args.checkpoint_every
        ),
        keep_checkpoints=3 if args.keep_checkpoints is None else args.keep_checkpoints,
        video_every=experiment.video_every if args.video_every is None else args.video_every,
        preset=args.preset,
    )
    run.shard = shard
    if args.run_dir is not None and not args.run_dir.strip():
        raise UsageError("--run-dir is empty; name a directory (or leave the flag out for runs/<task>-<algo>-<time>)")
    run_dir = Path(args.run_dir) if args.run_dir is not None else _default_run_dir(task, algo)
    layout.check_path(run_dir, "--run-dir")
    inside = directory.enclosing_run(run_dir)
    if inside is not None:
        raise UsageError(
            f"--run-dir {str(run_dir)!r} is inside the jaxpg run {str(inside)!r}; a run directory goes beside "
            "other runs, never inside one"
        )
    _check_fresh_run_dir(run_dir, bool(args.overwrite))
    return Plan(run=run, run_dir=run_dir, module=module, env=env, config=config, overwrite=bool(args.overwrite))


def plan_resume(args: argparse.Namespace, run: RunConfig, run_dir: Path) -> Plan:
    fixed = [flag_name(k) for k in (*_explicit_config(args), *_explicit_env(args))]
    for key in (
        "seed",
        "seeds",
        "preset",
        "fidelity",
        "impl",
        "max_episode_steps",
        "action_scaling",
        "env_kwargs",
        "run_dir",
        "overwrite",
    ):
        if getattr(args, key) is not None:
            fixed.append(flag_name(key))
    if args.task is not None and args.task != run.task:
        fixed.append("--task")
    if args.algo is not None and args.algo != run.algo:
        fixed.append("--algo")
    if fixed:
        raise UsageError(
            f"--resume continues {str(run_dir)!r} with its saved settings; drop {' '.join(fixed)} "
            "(only --iterations, --minutes, --checkpoint-every, --keep-checkpoints, --log-every, --video-every "
            "may change)"
        )
    module = algo_module(run.algo)
    config = run.algo_config()
    run.config = config_io.config_to_dict(config)  # saved again under the current field names
    run.check_env_kwargs()  # the rules of --env-kwargs and the simulation flags, before the env is built
    env = _make_env(run.task, run.env_kwargs)
    config.validate(env)
    for key in ("iterations", "checkpoint_every", "keep_checkpoints", "log_every", "video_every"):
        if getattr(args, key) is not None:
            setattr(run, key, getattr(args, key))
    if run.log_every < 1:
        raise UsageError(f"--log-every must be >= 1, got {run.log_every}")
    # --iterations at or below the iterations done is "nothing to do", not an error.
    problems = config_io.schedule_problems({k: v for k, v in dataclasses.asdict(run).items() if k != "iterations"})
    if problems:
        raise UsageError(problems[0])
    run.shard = _check_sharding(config, args.shard if args.shard is not None else (run.shard or None))
    check_memory(config, env, len(run.seeds), _device_count() if run.shard else 1)
    directory.check_entry_types(run_dir)
    run_lock.check_unlocked(run_dir)
    no_checkpoint = UsageError(
        f"cannot resume {str(run_dir)!r}: it has no checkpoints (it stopped before its first one, so there is "
        "nothing to resume); start it again with --overwrite"
    )
    if not (run_dir / layout.CHECKPOINT_DIR).is_dir():
        raise no_checkpoint
    checkpoints = checkpointer.Checkpointer(run_dir / layout.CHECKPOINT_DIR, keep=None)
    step = checkpoints.latest_step()
    if step is None:
        raise no_checkpoint
    later: list[int] = []
    if args.from_step is not None:
        steps = checkpoints.steps()
        if args.from_step not in steps:
            checkpoints.close()
            raise UsageError(
                f"--from-step {args.from_step}: {str(run_dir)!r} has no checkpoint of that iteration; its "
                f"checkpoints: {', '.join(map(str, steps))}"
            )
        step = args.from_step
        later = [s for s in steps if s > step]
    metrics_path = run_dir / layout.METRICS_FILE
    damaged = metrics_log.damaged_metrics_line(metrics_path) if metrics_path.is_file() else None
    if damaged is not None:
        raise UsageError(
            f"cannot resume {str(run_dir)!r}: line {damaged} of its metrics.jsonl is not a JSON record "
            "(a resume would drop it); repair or delete that line, then resume"
        )
    logged = max((int(r.get("iteration", 0)) for r in metrics_log.read_metrics(metrics_path)), default=0)
    if logged < step:
        state = "is missing" if not metrics_path.exists() else f"ends at iteration {logged}"
        earlier = [s for s in checkpoints.steps() if s <= logged]
        instead = (
            f"restore metrics.jsonl, or continue from the earlier checkpoint {earlier[-1]} with --from-step "
            f"{earlier[-1]} (the later checkpoints go)"
            if earlier
            else "restore metrics.jsonl or start a new run"
        )
        checkpoints.close()
        raise UsageError(
            f"cannot resume {str(run_dir)!r}: its metrics.jsonl {state} but its checkpoint is at iteration "
            f"{step}; {instead}"
        )
    target = policy_io.abstract_train_state(run, env)
    state = checkpoints.restore(target, step, expect=policy_io.checkpoint_expectations(run))
    checkpoints.close()
    return Plan(
        run=run,
        run_dir=run_dir,
        module=module,
        env=env,
        config=config,
        start=step,
        state=state,
        later_checkpoints=later,
    )


def _field_default(field: dataclasses.Field) -> Any:
    if field.default is not dataclasses.MISSING:
        return field.default
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return None


def plan(argv: Sequence[str], experiment: Experiment, pre: PreFlags | None = None) -> Plan:
    """Parse and check everything; raises ``UsageError``/``ValueError`` with one line. ``pre``:
    the flags of ``argv`` already read before the full parse (read here when not given)."""
    times = StartupTimes.start()
    pre = parse_pre_flags(argv, experiment) if pre is None else pre
    resume_run = None
    if pre.resume is not None:
        layout.check_path(pre.resume, "--resume")
        resume_run = RunConfig.load(pre.resume)
        algo = resume_run.algo
    else:
        algo = pre.algo or experiment.algo
    module = algo_module(algo)
    config_cls = module.Config
    defaults = {f.name: _field_default(f) for f in dataclasses.fields(config_cls)}
    defaults.update(experiment.config_defaults(algo, config_cls))
    if resume_run is None:  # plan_fresh checks the preset against the task
        defaults.update(preset_choice.defaults_of(algo, experiment.preset_name(algo, pre.preset)))
    if resume_run is not None:
        defaults.update(config_io.current_field_names(config_cls, resume_run.config))
    parser = build_parser(experiment, algo, config_cls, defaults)
    args = parser.parse_args(argv)
    if args.from_step is not None and args.resume is None:
        raise UsageError("--from-step N goes with --resume RUN_DIR (it picks the checkpoint to continue from)")
    if args.resume is not None:
        result = plan_resume(args, resume_run, Path(args.resume))
    else:
        result = plan_fresh(args, experiment, module, algo)
    if args.minutes is not None and not args.minutes > 0:
        raise UsageError(f"--minutes must be > 0, got {args.minutes:g}")
    result.time_limit_s = None if args.minutes is None else 60.0 * args.minutes
    result.profile = bool(args.profile)
    result.progress = args.progress
    result.command = list(argv)
    times.planned = time.perf_counter()
    result.startup = times
    return result
