"""The command line of jaxpg: train any algorithm on any task into a run directory.

    python -m jaxpg.cli --env inverted_pendulum --algo npg --iterations 50
    python -m jaxpg.cli --env hopper --preset lyceum --seeds 1 2 3 5 8 --run-dir runs/hopper
    python -m jaxpg.cli --resume runs/hopper --iterations 400

The experiment scripts (``experiments/*.py``) are this command with other defaults
(``main(argv, Experiment(...))``). Every field of the algorithm's ``Config`` is a flag
(``policy_hidden`` -> ``--policy-hidden 64 64``, booleans as ``--x/--no-x``); precedence, lowest
first: ``Config`` defaults, the experiment's defaults, ``--preset``, explicit flags.

A run directory (see ``jaxpg.runlog``) gets ``config.json``, ``metrics.jsonl``, TensorBoard
events, ``curves.png``, Orbax ``checkpoints/`` and ``videos/``. An existing run directory is only
replaced with ``--overwrite`` or continued with ``--resume``; a resumed run continues from its
latest checkpoint and produces the same metrics, bit for bit on the same device, as a run that
was never interrupted (the iteration where an earlier process ended also holds that process's
final evaluation of the mean policy: every run evaluates its last iteration).

Bad input (unknown task or algorithm, impossible sizes, a run directory that exists, a resume of
a missing or foreign directory, an unusable checkpoint) is reported as one ``error: ...`` line on
stderr with exit status 2, before anything is compiled or written.

Several devices and processes (``jaxpg.distributed``): ``--num-envs`` is split over every device
(``--shard``, on when there are several). Several processes run one command each, adding
``--coordinator-address HOST:PORT --num-processes K --process-id I`` (or the ``JAX_*`` variables);
``start_processes`` joins them before anything else touches JAX, a coordinator that cannot be
reached is an ``error:`` line with status 2, and process 0 alone writes the run directory.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import datetime
import functools
import json
import os
import shutil
import signal
import sys
import time
import typing
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from jaxpg import runlog
from jaxpg.runlog import RunConfig


class UsageError(ValueError):
    """Bad command-line input; reported as one ``error:`` line with exit status 2."""


@dataclasses.dataclass(frozen=True)
class Experiment:
    """What an experiment script fixes on top of the generic command line.

    Attributes:
      task: default task; tasks: the tasks the script accepts (``None``: every registered one).
      algo: default algorithm.
      iterations, seed, log_every, checkpoint_every, video_every: defaults of those flags.
      config: ``Config`` overrides per algorithm name (``"*"``: for every algorithm that has the
        field); applied below ``--preset`` and explicit flags.
      env_kwargs: default keyword arguments of ``jaxpg.envs.make``.
      prog, description, epilog: help text (the epilog should hold the GPU command that reaches
        the headline result).
    """

    task: str = "inverted_pendulum"
    tasks: tuple[str, ...] | None = None
    algo: str = "npg"
    iterations: int = 50
    seed: int = 0
    log_every: int = 10
    checkpoint_every: int = 50
    video_every: int = 0
    config: dict[str, dict[str, Any]] = dataclasses.field(default_factory=dict)
    env_kwargs: dict[str, Any] = dataclasses.field(default_factory=dict)
    prog: str | None = None
    description: str | None = None
    epilog: str | None = None

    def config_defaults(self, algo: str, config_cls: type) -> dict[str, Any]:
        names = {f.name for f in dataclasses.fields(config_cls)}
        out = {k: v for k, v in self.config.get("*", {}).items() if k in names}
        out.update(self.config.get(algo, {}))
        return out


# --------------------------------------------------------------------------- argument parsing


class Parser(argparse.ArgumentParser):
    """argparse that raises ``UsageError`` instead of printing the usage and exiting."""

    def error(self, message: str) -> typing.NoReturn:
        raise UsageError(message)


def _algo_module(name: str) -> Any:
    from jaxpg import algos

    if name not in algos.ALGORITHMS:
        raise UsageError(f"unknown algorithm {name!r}; known algorithms: {', '.join(sorted(algos.ALGORITHMS))}")
    try:
        return algos.get(name)
    except ModuleNotFoundError as e:
        if e.name == algos.ALGORITHMS[name]:
            raise UsageError(f"algorithm {name!r} is not available yet in this jaxpg ({e.name} is missing)") from None
        raise


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def _show(value: Any) -> str:
    if isinstance(value, tuple | list):
        return " ".join(map(str, value)) if value else "(empty)"
    return repr(value) if isinstance(value, str) else str(value)


def _optional(parse: Any) -> Any:
    def parse_optional(text: str) -> Any:
        return None if text.lower() in ("none", "null") else parse(text)

    parse_optional.__name__ = getattr(parse, "__name__", "value")
    return parse_optional


RUN_FLAGS = (
    "task", "algo", "seed", "seeds", "iterations", "run_dir", "resume", "overwrite", "checkpoint_every",
    "keep_checkpoints", "log_every", "video_every", "preset", "profile", "fidelity", "impl",
    "max_episode_steps", "shard", "progress", "coordinator_address", "num_processes", "process_id",
    "distributed_timeout",
)  # fmt: skip
CONFIG_PREFIX = "config."


def add_config_flags(parser: argparse.ArgumentParser, config_cls: type, defaults: dict[str, Any], title: str) -> None:
    """One flag per field of ``config_cls`` (dest ``config.<field>``, default ``None`` = not
    given): ints, floats, strings, ``T | None`` (``none``), tuples (``nargs='*'``) and booleans
    (``--x/--no-x``). Help shows what the field means (``algos.field_help``), the values a string
    field accepts and the effective default."""
    from jaxpg.algos.field_help import field_choices, field_help

    group = parser.add_argument_group(title)
    unused = getattr(config_cls, "UNUSED_FIELDS", ())
    for name, tp in runlog.field_types(config_cls).items():
        if name in unused:  # the algorithm ignores it: no flag, so that passing it is an error
            continue
        if name in RUN_FLAGS:
            raise TypeError(f"{config_cls.__module__}.Config.{name} clashes with a command-line flag")
        base, optional = runlog.strip_optional(tp)
        help_text = f"{field_help(name)} (default: {_show(defaults.get(name))})".lstrip()
        kwargs: dict[str, Any] = {"dest": CONFIG_PREFIX + name, "default": None, "help": help_text}
        origin = typing.get_origin(base)
        if base is bool:
            group.add_argument(_flag(name), action=argparse.BooleanOptionalAction, **kwargs)
            continue
        if base is tuple or origin is tuple:
            args = typing.get_args(base)
            elem = args[0] if args and args[0] in (int, float, str) else str
            group.add_argument(_flag(name), nargs="*", type=elem, metavar=elem.__name__.upper(), **kwargs)
            continue
        if origin is typing.Literal:
            group.add_argument(_flag(name), choices=typing.get_args(base), **kwargs)
            continue
        choices = field_choices(config_cls, name) if base is str else None
        if choices and not optional:
            group.add_argument(_flag(name), choices=choices, **kwargs)
            continue
        parse = base if base in (int, float, str) else str
        if optional:
            parse = _optional(parse)
        metavar = getattr(base, "__name__", "VALUE").upper()
        group.add_argument(_flag(name), type=parse, metavar=metavar, **kwargs)


def _positive(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def build_parser(experiment: Experiment, algo: str, config_cls: type | None, config_defaults: dict[str, Any]) -> Parser:
    """The full parser: run flags plus the ``Config`` flags of ``algo``."""
    from jaxpg import algos, envs

    tasks = experiment.tasks or tuple(envs.names())
    parser = Parser(
        prog=experiment.prog,
        description=experiment.description or __doc__.split("\n\n")[0],
        epilog=experiment.epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run = parser.add_argument_group("run")
    run.add_argument(
        "--task",
        "--env",
        dest="task",
        metavar="TASK",
        help=f"task: {', '.join(tasks)} (default: {experiment.task})",
    )
    run.add_argument("--algo", help=f"algorithm: {', '.join(algos.ALGORITHMS)} (default: {experiment.algo})")
    seeds = run.add_mutually_exclusive_group()
    seeds.add_argument("--seed", type=int, help=f"training seed (default: {experiment.seed})")
    seeds.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        metavar="SEED",
        help="several seeds, trained together in one vmapped program",
    )
    run.add_argument("--iterations", type=_positive, help=f"total iterations (default: {experiment.iterations})")
    run.add_argument("--run-dir", help="run directory (default: runs/<task>-<algo>-<date>-<time>)")
    run.add_argument(
        "--resume",
        metavar="RUN_DIR",
        help="continue RUN_DIR from its latest checkpoint (--iterations sets a new total)",
    )
    run.add_argument("--overwrite", action="store_true", default=None, help="replace an existing run directory")
    run.add_argument(
        "--checkpoint-every",
        type=_positive,
        help=f"iterations between checkpoints; 0: only at the end (default: {experiment.checkpoint_every})",
    )
    run.add_argument(
        "--keep-checkpoints", type=_positive, help="latest checkpoints to keep, besides the best (default: 3)"
    )
    run.add_argument("--log-every", type=int, help=f"iterations per summary line (default: {experiment.log_every})")
    run.add_argument(
        "--video-every",
        type=_positive,
        help=f"iterations between videos of the mean policy; 0: none (default: {experiment.video_every})",
    )
    run.add_argument("--preset", help="named Config overrides of the algorithm (its PRESETS), e.g. lyceum")
    run.add_argument(
        "--profile",
        action="store_true",
        default=None,
        help="time each phase of one iteration before training",
    )
    run.add_argument("--fidelity", choices=("fast", "gymnasium"), help="MJX physics settings (default: fast)")
    run.add_argument("--impl", choices=("jax", "warp"), help="MJX implementation (default: warp on a GPU, else jax)")
    run.add_argument("--max-episode-steps", type=int, help="time limit of an episode (default: the task's)")
    run.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="progress bar (default: on a terminal)",
    )
    add_distributed_flags(parser)
    if config_cls is not None:
        add_config_flags(parser, config_cls, config_defaults, f"{algo} hyperparameters (jaxpg.algos.{algo}.Config)")
    return parser


def add_distributed_flags(parser: argparse.ArgumentParser) -> None:
    """``--shard`` and the flags of ``jaxpg.distributed.initialize`` (one launch command per process)."""
    group = parser.add_argument_group(
        "several devices and processes",
        "--num-envs is split over every device of every process. Several processes (hosts): run the same "
        "command once per process, adding --coordinator-address HOST:PORT (of process 0) --num-processes K "
        "--process-id I, or setting JAX_COORDINATOR_ADDRESS, JAX_NUM_PROCESSES, JAX_PROCESS_ID.",
    )
    group.add_argument(
        "--shard",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="split the env batch over all devices (default: when there are several)",
    )
    group.add_argument("--coordinator-address", metavar="HOST:PORT", help="address of process 0's coordinator")
    group.add_argument("--num-processes", type=int, metavar="K", help="number of processes training together")
    group.add_argument("--process-id", type=int, metavar="I", help="this process's index, 0 .. K-1")
    group.add_argument(
        "--distributed-timeout",
        type=int,
        default=60,
        metavar="SECONDS",
        help="how long to wait for the coordinator and the other processes (default: 60)",
    )


def start_processes(argv: Sequence[str]) -> None:
    """``jax.distributed.initialize`` when ``argv`` or the environment name several processes;
    before anything else touches JAX's devices. ``DistributedError`` (one line) on bad settings or
    an unreachable coordinator."""
    from jaxpg import distributed

    config = distributed_config(argv)
    if config is not None:
        distributed.initialize(config)


def distributed_config(argv: Sequence[str]) -> Any:
    """The ``jaxpg.distributed.DistributedConfig`` that ``argv`` and the environment ask for
    (``None``: one process), read before the full parse so that JAX is initialised first."""
    from jaxpg import distributed

    pre = Parser(add_help=False)
    add_distributed_flags(pre)
    args, _ = pre.parse_known_args(argv)
    return distributed.DistributedConfig.resolve(
        args.coordinator_address, args.num_processes, args.process_id, timeout_s=args.distributed_timeout
    )


def _pre_parse(argv: Sequence[str]) -> argparse.Namespace:
    pre = Parser(add_help=False)
    pre.add_argument("--task", "--env", dest="task")
    pre.add_argument("--algo")
    pre.add_argument("--resume")
    pre.add_argument("--preset")
    args, _ = pre.parse_known_args(argv)
    return args


# --------------------------------------------------------------------------- planning (no side effects)


@dataclasses.dataclass
class Plan:
    """A checked run: everything is known, nothing is written or compiled yet."""

    run: RunConfig
    run_dir: Path
    module: Any
    env: Any
    config: Any
    start: int = 0
    state: Any = None
    overwrite: bool = False
    replaced: Path | None = None  # the old run that --overwrite moved aside
    created: bool = False  # this run created its directory
    profile: bool = False
    progress: bool | None = None
    command: list[str] = dataclasses.field(default_factory=list)


def _check_task(task: str, experiment: Experiment) -> None:
    from jaxpg import envs

    allowed = experiment.tasks or tuple(envs.names())
    if task not in envs.names() or task not in allowed:
        raise UsageError(f"unknown task {task!r}; known tasks: {', '.join(allowed)}")


def _make_env(task: str, env_kwargs: dict[str, Any]) -> Any:
    from jaxpg import envs

    try:
        return envs.make_shared(task, **env_kwargs)
    except TypeError as e:
        given = ", ".join(_flag(k) for k in env_kwargs if k != "batch")
        raise UsageError(f"task {task!r} does not accept {given or 'these settings'} ({e})") from None


def _explicit_config(args: argparse.Namespace) -> dict[str, Any]:
    return {k[len(CONFIG_PREFIX) :]: v for k, v in vars(args).items() if k.startswith(CONFIG_PREFIX) and v is not None}


def _default_run_dir(task: str, algo: str) -> Path:
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{task}-{algo}-{stamp}"


def _check_fresh_run_dir(run_dir: Path, overwrite: bool) -> None:
    if not run_dir.exists():
        return
    if not run_dir.is_dir():
        raise UsageError(f"run directory {str(run_dir)!r} exists and is not a directory")
    if not any(run_dir.iterdir()):
        return
    if not overwrite:
        raise UsageError(
            f"run directory {str(run_dir)!r} exists; "
            f"pass --overwrite to replace it or --resume {run_dir} to continue it"
        )
    if not (run_dir / runlog.CONFIG_FILE).is_file():
        raise UsageError(f"refusing to --overwrite {str(run_dir)!r}: it is not a jaxpg run directory (no config.json)")
    runlog.check_unlocked(run_dir)


def _device_count() -> int:
    import jax

    return jax.device_count()


def _check_sharding(config: Any, explicit: bool | None) -> bool:
    """Whether the env batch is split over ``jax.devices()`` (all devices of all processes):
    by default when there are several; ``UsageError`` if ``--num-envs`` does not divide."""
    import jax

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


def plan_fresh(args: argparse.Namespace, experiment: Experiment, module: Any, algo: str) -> Plan:
    task = args.task or experiment.task
    _check_task(task, experiment)
    config_cls = module.Config
    values = experiment.config_defaults(algo, config_cls)
    presets = getattr(module, "PRESETS", {})
    if args.preset is not None:
        if args.preset not in presets:
            known = ", ".join(sorted(presets)) or "none"
            raise UsageError(f"unknown preset {args.preset!r} for {algo}; known presets: {known}")
        values.update(presets[args.preset])
    values.update(_explicit_config(args))
    types = runlog.field_types(config_cls)
    config = config_cls(**{k: runlog.coerce(types[k], v) for k, v in values.items()})
    env_kwargs = dict(experiment.env_kwargs)
    for key in ("fidelity", "impl", "max_episode_steps"):
        if getattr(args, key) is not None:
            env_kwargs[key] = getattr(args, key)
    if args.max_episode_steps is not None and args.max_episode_steps < 1:
        raise UsageError(f"--max-episode-steps must be >= 1, got {args.max_episode_steps}")
    num_seeds = len(args.seeds) if args.seeds else 1
    shard = _check_sharding(config, args.shard)
    # With the batch split, each device steps (and the physics sizes its buffers for) its own share.
    shares = _device_count() if shard else 1
    per_device = max(-(-config.num_envs // shares), -(-config.eval_envs // shares))
    env_kwargs["batch"] = per_device * num_seeds
    env = _make_env(task, env_kwargs)
    config.validate(env)
    seeds = list(args.seeds) if args.seeds else [experiment.seed if args.seed is None else args.seed]
    if len(set(seeds)) != len(seeds):
        raise UsageError(f"--seeds must be distinct, got {' '.join(map(str, seeds))}")
    log_every = experiment.log_every if args.log_every is None else args.log_every
    if log_every < 1:
        raise UsageError(f"--log-every must be >= 1, got {log_every}")
    run = RunConfig(
        task=task,
        algo=algo,
        config=runlog.config_to_dict(config),
        seeds=seeds,
        iterations=experiment.iterations if args.iterations is None else args.iterations,
        env_kwargs=env_kwargs,
        log_every=log_every,
        checkpoint_every=experiment.checkpoint_every if args.checkpoint_every is None else args.checkpoint_every,
        keep_checkpoints=3 if args.keep_checkpoints is None else args.keep_checkpoints,
        video_every=experiment.video_every if args.video_every is None else args.video_every,
        preset=args.preset,
    )
    run.shard = shard
    run_dir = Path(args.run_dir) if args.run_dir else _default_run_dir(task, algo)
    _check_fresh_run_dir(run_dir, bool(args.overwrite))
    return Plan(run=run, run_dir=run_dir, module=module, env=env, config=config, overwrite=bool(args.overwrite))


def plan_resume(args: argparse.Namespace, run: RunConfig, run_dir: Path) -> Plan:
    from jaxpg import checkpoint as ckpt_lib
    from jaxpg import policy_io

    fixed = [_flag(k) for k in _explicit_config(args)]
    for key in ("seed", "seeds", "preset", "fidelity", "impl", "max_episode_steps", "run_dir", "overwrite"):
        if getattr(args, key) is not None:
            fixed.append(_flag(key))
    if args.task is not None and args.task != run.task:
        fixed.append("--task")
    if args.algo is not None and args.algo != run.algo:
        fixed.append("--algo")
    if fixed:
        raise UsageError(
            f"--resume continues {str(run_dir)!r} with its saved settings; drop {' '.join(fixed)} "
            "(only --iterations, --checkpoint-every, --keep-checkpoints, --log-every, --video-every may change)"
        )
    module = _algo_module(run.algo)
    config = run.algo_config()
    run.config = runlog.config_to_dict(config)  # saved again under the current field names
    env = _make_env(run.task, run.env_kwargs)
    config.validate(env)
    for key in ("iterations", "checkpoint_every", "keep_checkpoints", "log_every", "video_every"):
        if getattr(args, key) is not None:
            setattr(run, key, getattr(args, key))
    if run.log_every < 1:
        raise UsageError(f"--log-every must be >= 1, got {run.log_every}")
    run.shard = _check_sharding(config, args.shard if args.shard is not None else (run.shard or None))
    runlog.check_unlocked(run_dir)
    checkpoints = ckpt_lib.Checkpointer(run_dir / runlog.CHECKPOINT_DIR, keep=None)
    step = checkpoints.latest_step()
    if step is None:
        raise UsageError(f"cannot resume {str(run_dir)!r}: it has no checkpoint yet")
    metrics_path = run_dir / runlog.METRICS_FILE
    logged = max((int(r.get("iteration", 0)) for r in runlog.read_metrics(metrics_path)), default=0)
    if logged < step:
        state = "is missing" if not metrics_path.exists() else f"ends at iteration {logged}"
        raise UsageError(
            f"cannot resume {str(run_dir)!r}: its metrics.jsonl {state} but its checkpoint is at iteration "
            f"{step}; restore metrics.jsonl or start a new run"
        )
    target = policy_io.abstract_train_state(run, env)
    state = checkpoints.restore(target, step, expect=policy_io.checkpoint_expectations(run))
    checkpoints.close()
    return Plan(run=run, run_dir=run_dir, module=module, env=env, config=config, start=step, state=state)


def _field_default(field: dataclasses.Field) -> Any:
    if field.default is not dataclasses.MISSING:
        return field.default
    if field.default_factory is not dataclasses.MISSING:
        return field.default_factory()
    return None


def plan(argv: Sequence[str], experiment: Experiment) -> Plan:
    """Parse and check everything; raises ``UsageError``/``ValueError`` with one line."""
    pre = _pre_parse(argv)
    resume_run = None
    if pre.resume is not None:
        resume_run = RunConfig.load(pre.resume)
        algo = resume_run.algo
    else:
        algo = pre.algo or experiment.algo
    module = _algo_module(algo)
    config_cls = module.Config
    defaults = {f.name: _field_default(f) for f in dataclasses.fields(config_cls)}
    defaults.update(experiment.config_defaults(algo, config_cls))
    if resume_run is None and pre.preset is not None:
        defaults.update(getattr(module, "PRESETS", {}).get(pre.preset, {}))
    if resume_run is not None:
        defaults.update(runlog.current_field_names(config_cls, resume_run.config))
    parser = build_parser(experiment, algo, config_cls, defaults)
    args = parser.parse_args(argv)
    if args.resume is not None:
        result = plan_resume(args, resume_run, Path(args.resume))
    else:
        result = plan_fresh(args, experiment, module, algo)
    result.profile = bool(args.profile)
    result.progress = args.progress
    result.command = list(argv)
    return result


# --------------------------------------------------------------------------- running


@functools.lru_cache(maxsize=16)
def _compiled_init(module: Any, env: Any, config: Any, seeds: tuple[int, ...]) -> Any:
    """Jitted ``init`` (several seeds: ``train.init_seeds``), cached so that runs in one process
    share the compiled program."""
    import jax

    from jaxpg import train

    if len(seeds) > 1:
        return jax.jit(lambda: train.init_seeds(module.init, seeds, env, config))
    return jax.jit(lambda key: module.init(key, env, config))


def initial_state(module: Any, env: Any, config: Any, seeds: Sequence[int]) -> Any:
    import jax

    init = _compiled_init(module, env, config, tuple(seeds))
    return init() if len(seeds) > 1 else init(jax.random.PRNGKey(seeds[0]))


def distinct_buffers(tree: Any) -> Any:
    """A copy of ``tree`` in which no two leaves share a device buffer (the training step donates
    its input, and XLA refuses to donate one buffer twice)."""
    import jax

    seen: set[int] = set()

    def fresh(x: Any) -> Any:
        try:
            ptr = x.unsafe_buffer_pointer()
        except Exception:  # noqa: BLE001 - sharded or deleted arrays: copy to be safe
            return jax.numpy.array(x, copy=True)
        if ptr in seen:
            return jax.numpy.array(x, copy=True)
        seen.add(ptr)
        return x

    return jax.tree.map(fresh, tree)


def shard_state(ts: Any, vmap_seeds: bool, mesh: Any = None) -> Any:
    """``ts`` placed on ``mesh`` (default: ``jaxpg.distributed.env_mesh()``, every device of every
    process): the env axis of ``ts.env_state`` split over the ``"envs"`` axis (after the seed axis
    with ``vmap_seeds``), everything else replicated, including MuJoCo Warp's per-batch buffers
    (``core.env_batch_mask``). Every process passes the same ``ts``; each places its share."""
    import jax
    from jax.sharding import NamedSharding

    from jaxpg import distributed
    from jaxpg.algos import core

    mesh = distributed.env_mesh() if mesh is None else mesh
    lead = 1 if vmap_seeds else 0
    mask = core.env_batch_mask(core.sampler_env(ts.env, ts.config), ts.env_state, leading=lead)
    shardings = jax.tree.map(lambda batched: NamedSharding(mesh, distributed.batch_spec(batched, lead)), mask)
    env_state = distributed.put_global(ts.env_state, shardings)
    rest = distributed.replicated(ts.replace(env_state=()), mesh)
    return rest.replace(env_state=env_state)


def _seed_slice(tree: Any, index: int, vmap_seeds: bool) -> Any:
    import jax

    return jax.tree.map(lambda x: x[index], tree) if vmap_seeds else tree


def run_profile(plan_: Plan, ts: Any, out: Any) -> dict[str, float] | None:
    """Time each phase of one iteration (``jaxpg.profiling.profile_phases``)."""
    from jaxpg import profiling

    run = plan_.run
    if run.algo not in profiling.PHASES:
        known = ", ".join(sorted(profiling.PHASES))
        out(f"--profile: profiling isn't available for {run.algo} (jaxpg.profiling has phases for {known})")
        return None
    out(f"profiling one {run.algo} iteration as separately jitted phases (compiling them first) ...")
    _, timings = profiling.profile_phases(run.algo, _seed_slice(ts, 0, run.vmap_seeds))
    timings = {k: float(v) for k, v in timings.items()}
    total = sum(timings.values())
    samples = plan_.config.samples_per_iteration
    lines = [f"phase timings of one iteration ({samples:,} samples, seed {run.seeds[0]}):"]
    for name, seconds in timings.items():
        share = 100 * seconds / total if total > 0 else 0.0
        lines.append(f"  {name:<14} {seconds * 1e3:10.2f} ms  {share:5.1f}%")
    lines.append(f"  {'sum':<14} {total * 1e3:10.2f} ms  ({samples / total if total > 0 else 0:,.0f} samples/s)")
    out("\n".join(lines))
    return timings


class _Callbacks:
    """Host side of training: metrics, progress, summaries, checkpoints, videos, curves."""

    def __init__(
        self,
        plan_: Plan,
        checkpoints: Any,
        writer: runlog.MetricsWriter,
        progress: runlog.Progress,
        wall_offset: float,
        interrupts: Any = None,
    ):
        self.plan, self.run = plan_, plan_.run
        self.checkpoints, self.writer, self.progress = checkpoints, writer, progress
        self.wall_offset = wall_offset
        self.t_start = self.t_last = time.perf_counter()
        self.pending: list[dict[str, np.ndarray]] = []
        self.pending_steps = 0
        self.pending_time = 0.0
        self.first_block = True
        self.last_saved = plan_.start
        self.last_iteration = plan_.start
        self.block_times: list[tuple[int, float]] = []
        self.videos_enabled = self.run.video_every > 0
        self.samples = plan_.config.samples_per_iteration * len(self.run.seeds)
        self.primary = _primary()
        self.eval_seconds = 0.0
        self.evaluations = 0
        self.overflow_noted = False
        self.interrupts = interrupts

    def _wall(self, now: float) -> float:
        return self.wall_offset + (now - self.t_start)

    def __call__(self, ts: Any, metrics: dict[str, np.ndarray], first: int) -> None:
        if self.interrupts is not None:
            self.interrupts.graceful = True  # a call has finished: from now on interrupts checkpoint first
        now = time.perf_counter()
        duration = now - self.t_last
        n = len(next(iter(metrics.values())))
        last = first + n
        wall_times = [self._wall(self.t_last + duration * (i + 1) / n) for i in range(n)]
        self.t_last = now
        # Evaluation ran between this block's training calls: keep it out of the training rate.
        eval_s = float(np.max(np.sum(metrics["eval_seconds"], axis=0))) if "eval_seconds" in metrics else 0.0
        self.eval_seconds += eval_s
        self.evaluations += int(np.max(np.sum(metrics.get("evaluated", np.zeros(1)), axis=0)))
        train_s = max(duration - eval_s, 1e-9)
        self.block_times.append((n, train_s))
        self.writer.write(runlog.block_records(metrics, first, self.run.seeds, wall_times))
        steps_per_s = self.samples * n / train_s
        self.progress.update(n, metrics, steps_per_s)
        self.pending.append(metrics)
        self.pending_steps += self.samples * n
        self.pending_time += train_s
        self.last_iteration = last
        at_end = last >= self.run.iterations
        self._note_overflow(metrics, first)
        if last % self.run.log_every == 0 or at_end:
            merged = {k: np.concatenate([m[k] for m in self.pending]) for k in self.pending[0]}
            rate = self.pending_steps / max(self.pending_time, 1e-9)
            note = " (incl. compile)" if self.first_block else ""
            line = runlog.summary_line(merged, last, self.run.iterations, rate, note, self.eta(last))
            self.progress.write(line)
            self._note_rejections(merged, last - len(next(iter(merged.values()))))
            self.pending, self.pending_steps, self.pending_time = [], 0, 0.0
            self.first_block = False
        if (self.run.checkpoint_every and last % self.run.checkpoint_every == 0) or at_end:
            self.save(ts, last, metrics)  # every process: gathers the state; process 0 writes
            if self.primary:
                self.plot()
        if self.primary and self.videos_enabled and (last % self.run.video_every == 0 or at_end):
            self.video(ts, last)
        if self.interrupts is not None and self.interrupts.requested is not None:
            if self.last_saved != last:
                self.save(ts, last, metrics)
                if self.primary:
                    self.plot()
            raise _Stop(self.interrupts.requested)
        # Host work (checkpoints, plots, videos) is left out of the next block's throughput.
        self.t_last = time.perf_counter()

    def _note_rejections(self, metrics: dict[str, np.ndarray], first: int) -> None:
        """One line per block in which updates were rolled back (trust region or non-finite) or
        TRPO's line search accepted no step, so that a policy that stops moving says why."""
        n = len(next(iter(metrics.values())))
        rejected = np.asarray(metrics.get("update_rejected", np.zeros(n))).reshape(n, -1).max(axis=1)
        if "line_search_accepted" in metrics:
            no_step = np.asarray(metrics["line_search_accepted"]).reshape(n, -1).min(axis=1) == 0
            if no_step.any():
                self.progress.write(
                    f"warning: TRPO's line search accepted no step in {int(no_step.sum())} of iterations "
                    f"{first + 1}-{first + n} (the policy did not move; is max_kl {self.plan.config.max_kl} too large "
                    "or too small?)"
                )
        if rejected.any():
            limit = getattr(self.plan.config, "max_update_kl", 0)
            self.progress.write(
                f"warning: {int((rejected > 0).sum())} of iterations {first + 1}-{first + n} were rolled back "
                f"(mean KL above max_update_kl {limit}, or non-finite values); lower the step size or learning rate"
            )

    def eta(self, last: int) -> float | None:
        """Seconds left at the training rate measured after the first block (which compiles), plus
        the evaluations still due at their measured cost; ``None`` until a block after the first."""
        timed = self.block_times[1:]
        iterations = sum(n for n, _ in timed)
        if not iterations:
            return None
        left = self.run.iterations - last
        per_eval = self.eval_seconds / self.evaluations if self.evaluations else 0.0
        every = int(self.plan.config.eval_every) if getattr(self.plan.config, "eval_envs", 0) else 0
        evals_left = (left // every if every else 0) + (1 if every else 0)
        return left * sum(t for _, t in timed) / iterations + evals_left * per_eval

    def _note_overflow(self, metrics: dict[str, np.ndarray], first: int) -> None:
        """One line, the first time the physics reports an overflow (MuJoCo Warp's solver at its
        iteration limit, or a full contact buffer); afterwards only the metric counts them."""
        if self.overflow_noted or "physics_overflow" not in metrics:
            return
        counts = np.asarray(metrics["physics_overflow"]).reshape(len(metrics["physics_overflow"]), -1).sum(axis=1)
        hits = np.flatnonzero(counts > 0)
        if hits.size:
            self.overflow_noted = True
            row = int(hits[0])
            self.progress.write(
                f"note: the physics hit a solver or buffer limit in {counts[row]:.0f} of "
                f"{self.samples:,} env steps of iteration {first + row + 1} (MuJoCo Warp overflow flags; "
                "counted per iteration in metrics.jsonl as physics_overflow, not reported again)"
            )

    def save(self, ts: Any, step: int, metrics: dict[str, np.ndarray]) -> None:
        last_metrics = {
            k: float(np.nanmean(v[-1])) if not np.all(np.isnan(v[-1])) else None for k, v in metrics.items()
        }
        self.checkpoints.save(
            step,
            ts,
            score=runlog.latest_score(metrics),
            metrics=last_metrics,
            info={"task": self.run.task, "algo": self.run.algo, "seeds": self.run.seeds},
        )
        self.last_saved = step

    def plot(self) -> None:
        try:
            from jaxpg import plotting

            plotting.plot_run(self.plan.run_dir, task_score_name=self.plan.env.task_score_name)
        except Exception as e:  # noqa: BLE001 - a plot must never stop training
            self.progress.write(f"warning: curves.png not updated ({type(e).__name__}: {e})")

    def video(self, ts: Any, step: int) -> None:
        from jaxpg import distributed
        from jaxpg import video as video_lib

        path = self.plan.run_dir / runlog.VIDEO_DIR / f"iter_{step:06d}.mp4"
        try:
            # Host copies: the video is recorded by process 0 alone, off the training mesh.
            params = _seed_slice(distributed.host_copy(ts.params), 0, self.run.vmap_seeds)
            stats = _seed_slice(distributed.host_copy(ts.obs_stats), 0, self.run.vmap_seeds)
            out, ret, length = video_lib.record_policy(self.plan.env, ts.policy, params, stats, path, seed=step)
            self.progress.write(
                f"video {out} (mean policy, seed {self.run.seeds[0]}: return {ret:.1f}, {length} steps)"
            )
        except Exception as e:  # noqa: BLE001 - videos are optional: warn once, go on training
            self.videos_enabled = False
            self.progress.write(f"warning: videos disabled: {type(e).__name__}: {e}")


def _primary() -> bool:
    """This process writes files and prints (``jaxpg.distributed.is_primary``)."""
    from jaxpg import distributed

    return distributed.is_primary()


def _print(line: str) -> None:
    if _primary():
        print(line, flush=True)


class _Silent:
    """Metrics writer and progress of the processes other than 0, which write nothing."""

    def write(self, *args: Any) -> None:
        pass

    def add_text(self, *args: Any) -> None:
        pass

    def update(self, *args: Any) -> None:
        pass

    def close(self) -> None:
        pass


def prepare_run_dir(plan_: Plan) -> float:
    """Create (or replace, or reopen) the run directory; returns the wall-time offset.

    ``--overwrite`` moves the old run aside (``plan_.replaced``) instead of deleting it: it is
    deleted once the new run has written a checkpoint, and put back if the new run stops before
    (``finish_run_dir``), so that nothing on disk is lost to a run that never got going.
    """
    run_dir, run = plan_.run_dir, plan_.run
    if plan_.start > 0:
        wall_offset = runlog.truncate_metrics(run_dir, plan_.start)
        history = run.info.setdefault("resumes", [])
        history.append(
            {
                "from_iteration": plan_.start,
                "command": " ".join(plan_.command),
                "time": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
            }
        )
        run.save(run_dir)
        return wall_offset
    if plan_.overwrite and run_dir.exists() and any(run_dir.iterdir()):
        plan_.replaced = run_dir.with_name(f"{run_dir.name}.replaced-{os.getpid()}")
        run_dir.rename(plan_.replaced)
    plan_.created = not run_dir.exists()
    run_dir.mkdir(parents=True, exist_ok=True)
    run.info = runlog.provenance([sys.argv[0], *plan_.command])
    run.save(run_dir)
    return 0.0


def finish_run_dir(plan_: Plan, checkpointed: bool) -> str:
    """After the run: drop the run it replaced once the new one has a checkpoint; otherwise (it
    stopped before its first checkpoint) remove the new directory and put back what was there, so
    that the same command can simply be run again. Returns a note for the user ('' if none)."""
    run_dir = plan_.run_dir
    if plan_.start > 0:
        return ""
    if checkpointed:
        if plan_.replaced is not None:
            shutil.rmtree(plan_.replaced, ignore_errors=True)
        return ""
    if plan_.replaced is not None:
        shutil.rmtree(run_dir, ignore_errors=True)
        plan_.replaced.rename(run_dir)
        return f"; the run it was replacing is back in {run_dir}"
    if plan_.created:
        shutil.rmtree(run_dir, ignore_errors=True)
        return f"; {run_dir} was removed (no checkpoint had been written)"
    return ""


class _Stop(Exception):
    """Raised by the callbacks after an interrupt, once the current compiled call has finished and
    its checkpoint is written."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


class _Interrupts:
    """SIGINT and SIGTERM. Once the first compiled call has finished (``graceful``), the first
    signal asks to stop after the current call (``requested``) and a second SIGINT stops at once;
    before that (building the state, compiling) any of them stops at once (``KeyboardInterrupt``),
    so that an interrupted start leaves nothing behind. Only in a single-process run: several
    processes must agree on when to stop, which they cannot here."""

    def __init__(self) -> None:
        self.requested: int | None = None
        self.graceful = False
        self.previous: dict[int, Any] = {}

    def __enter__(self) -> _Interrupts:
        import jax

        if jax.process_count() == 1:
            for signum in (signal.SIGINT, signal.SIGTERM):
                self.previous[signum] = signal.signal(signum, self._handle)
        return self

    def _handle(self, signum: int, frame: Any) -> None:
        at_once = not self.graceful or (self.requested is not None and signum == signal.SIGINT)
        self.requested = signum if self.requested is None else self.requested
        if at_once:
            self.requested = signum
            raise KeyboardInterrupt

    def __exit__(self, *exc: Any) -> None:
        for signum, handler in self.previous.items():
            signal.signal(signum, handler)


def _exit_status(signum: int) -> int:
    return 128 + int(signum)


def execute(plan_: Plan) -> int:
    """Train as planned; returns the exit status.

    The initial state is built (and its program compiled) before the run directory is touched.
    SIGINT / SIGTERM finish the current compiled call, write a checkpoint, print one line and exit
    with 130 / 143; a second SIGINT exits at once. Write errors (disk full, permissions) and
    checkpoint errors are one ``error:`` line with status 2.
    """
    from jaxpg import distributed

    run, run_dir = plan_.run, plan_.run_dir
    primary = _primary()
    with _Interrupts() as interrupts:
        try:
            ts = plan_.state
            if ts is None:
                ts = initial_state(plan_.module, plan_.env, plan_.config, run.seeds)
        except KeyboardInterrupt:
            name = signal.Signals(interrupts.requested or signal.SIGINT).name
            print(f"\n{name}: stopped before training started; nothing was written", file=sys.stderr)
            return _exit_status(interrupts.requested or signal.SIGINT)
        # Process 0 writes the run directory once every process has checked it, before any reads it.
        distributed.barrier("jaxpg: planned")
        lock = runlog.RunLock(run_dir)
        try:
            if primary:
                if run_dir.exists() and plan_.start > 0:
                    lock.acquire()
                wall_offset = prepare_run_dir(plan_)
                if not lock.held:
                    lock.acquire()
            else:
                wall_offset = 0.0
        except OSError as e:
            print(f"error: cannot write the run directory {str(run_dir)!r}: {e.strerror or e}", file=sys.stderr)
            return 2
        except runlog.RunDirError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        try:
            return _train(plan_, ts, wall_offset, interrupts)
        except KeyboardInterrupt:
            # Between writing the run directory and the training loop's own handler (imports,
            # profiling, device placement): the same clean-up as an interrupt in the first block.
            note = finish_run_dir(plan_, checkpointed=plan_.start > 0) if primary else ""
            resume = f"; continue with: python -m jaxpg.cli --resume {run_dir}" if plan_.start > 0 else ""
            signum = interrupts.requested or signal.SIGINT
            print(f"\n{signal.Signals(signum).name}: stopped at once{resume}{note}", file=sys.stderr)
            return _exit_status(signum)
        finally:
            lock.release()


def _train(plan_: Plan, ts: Any, wall_offset: float, interrupts: _Interrupts) -> int:
    """The training loop of ``execute``, in a prepared and locked run directory."""
    import jax

    from jaxpg import checkpoint as ckpt_lib
    from jaxpg import distributed, train

    run, run_dir = plan_.run, plan_.run_dir
    primary = _primary()
    distributed.barrier("jaxpg: run directory ready")
    verb = f"resuming at iteration {plan_.start}" if plan_.start else "training"
    seeds = " ".join(map(str, run.seeds))
    _print(
        f"{verb}: {run.algo} on {run.task} ({plan_.env!r}), seed{'s' if len(run.seeds) > 1 else ''} {seeds}, "
        f"{run.iterations} iterations of {plan_.config.samples_per_iteration:,} samples, "
        f"{jax.device_count()} {jax.devices()[0].device_kind} device(s)"
        f"{f' in {jax.process_count()} processes' if jax.process_count() > 1 else ''} -> {run_dir}"
    )
    ts = distinct_buffers(ts)
    update, evaluate = plan_.module.update, train.evaluate_state
    mesh = distributed.env_mesh() if run.shard else None
    if mesh is not None:
        # The env batch splits over the mesh: sampling under shard_map, learning under jit's partitioner.
        ts = shard_state(ts, run.vmap_seeds, mesh)
        update = distributed.on_mesh(update, mesh)
        evaluate = distributed.on_mesh(evaluate, mesh)
    if plan_.profile:
        with jax.set_mesh(mesh) if mesh is not None else contextlib.nullcontext():
            timings = run_profile(plan_, ts, _print)
        if timings is not None and primary:
            runlog.write_json_atomic(run_dir / "profile.json", {"phases_s": timings, "iteration": plan_.start})
    remaining = run.iterations - plan_.start
    if remaining <= 0:
        _print(f"nothing to do: {run_dir} has done {plan_.start} of {run.iterations} iterations (raise --iterations)")
        return 0
    checkpoints = writer = progress = None
    status = 0
    callbacks: _Callbacks | None = None
    try:
        checkpoints = ckpt_lib.Checkpointer(run_dir / runlog.CHECKPOINT_DIR, keep=run.keep_checkpoints, create=True)
        writer = runlog.MetricsWriter(run_dir, run.seeds, start_iteration=plan_.start) if primary else _Silent()
        if plan_.start == 0:
            writer.add_text("config", "```\n" + json.dumps(run.to_json(), indent=2) + "\n```")
        progress = (
            runlog.Progress(run.iterations, initial=plan_.start, enabled=plan_.progress, desc=f"{run.algo} {run.task}")
            if primary
            else _Silent()
        )
        callbacks = _Callbacks(plan_, checkpoints, writer, progress, wall_offset, interrupts)
        block = run.block_size
        # Blocks start at multiples of block_size, as in an uninterrupted run.
        segments = []
        misaligned = (-plan_.start) % block
        if misaligned:
            segments.append(min(misaligned, remaining))
        if remaining - sum(segments) > 0:
            segments.append(remaining - sum(segments))
        for index, count in enumerate(segments):
            ts = train.train(
                update,
                ts,
                count,
                block_size=min(block, count),
                callbacks=[callbacks],
                seeds=run.vmap_seeds,
                evaluate=evaluate,
                final_eval=index == len(segments) - 1,  # the run's last iteration is always evaluated
            )
    except _Stop as stop:
        progress.close()
        print(
            f"{stop}: stopped after iteration {callbacks.last_iteration}, checkpoint {callbacks.last_saved} written. "
            f"Continue with: python -m jaxpg.cli --resume {run_dir}",
            file=sys.stderr,
        )
        status = _exit_status(stop.signum)
    except KeyboardInterrupt:
        if progress is not None:
            progress.close()
        saved = callbacks.last_saved if callbacks is not None else plan_.start
        note = finish_run_dir(plan_, checkpointed=saved > 0) if primary else ""
        resume = f"; continue from checkpoint {saved} with: python -m jaxpg.cli --resume {run_dir}" if saved else ""
        signum = interrupts.requested or signal.SIGINT
        print(f"\n{signal.Signals(signum).name}: stopped at once{resume}{note}", file=sys.stderr)
        return _exit_status(signum)
    except train.TrainingDiverged as e:
        progress.close()
        print(f"error: {e}; metrics and checkpoints up to then are in {run_dir}", file=sys.stderr)
        status = 1
    except (OSError, ckpt_lib.CheckpointError) as e:
        if progress is not None:
            progress.close()
        what = f"{e.strerror}: {e.filename}" if isinstance(e, OSError) and e.strerror else str(e).splitlines()[0]
        hint = " (disk full?)" if isinstance(e, OSError) and e.errno == 28 else ""
        print(f"error: writing the run directory failed: {what}{hint}", file=sys.stderr)
        status = 2
    finally:
        for closable in (progress, writer, checkpoints):
            if closable is not None:
                try:
                    closable.close()
                except Exception:  # noqa: BLE001 - closing after a failure must not hide it
                    pass
    if primary:
        saved = callbacks.last_saved if callbacks is not None else plan_.start
        note = finish_run_dir(plan_, checkpointed=saved > 0)
        if note:
            print(f"the run stopped before its first checkpoint{note}", file=sys.stderr)
    if status == 0 and primary:
        _report_end(plan_, callbacks)
    distributed.barrier("jaxpg: done")  # the processes leave together (JAX's shutdown waits for all)
    return status


def _report_end(plan_: Plan, callbacks: _Callbacks) -> None:
    run, run_dir = plan_.run, plan_.run_dir
    # The first block includes compilation.
    timed = callbacks.block_times[1:]
    iters = sum(n for n, _ in timed)
    secs = sum(t for _, t in timed)
    total = sum(t for _, t in callbacks.block_times)
    total += callbacks.eval_seconds
    if iters and secs > 0:
        rate = callbacks.samples * iters / secs
        _print(f"done in {total:.1f} s: {secs / iters:.3f} s per iteration, {rate:,.0f} env steps/s after compilation")
    else:
        _print(f"done in {total:.1f} s (including compilation)")
    if callbacks.evaluations:
        share = 100 * callbacks.eval_seconds / max(total, 1e-9)
        _print(
            f"evaluation: {callbacks.evaluations} of the mean policy ({run.config.get('eval_envs')} episodes each), "
            f"{callbacks.eval_seconds:.1f} s ({share:.1f}% of the training loop's wall clock)"
        )
    if plan_.profile and iters:
        seeds = f", {len(run.seeds)} seeds vmapped" if run.vmap_seeds else ""
        _print(f"fused update (scan of {run.block_size} iterations{seeds}): {secs / iters * 1e3:.2f} ms per iteration")
    try:
        from jaxpg import checkpoint as ckpt_lib

        checkpoints = ckpt_lib.Checkpointer(run_dir / runlog.CHECKPOINT_DIR, keep=None)
        best, latest = checkpoints.best_step(), checkpoints.latest_step()
        if best is not None and best != latest:
            score = checkpoints.score(best)
            _print(f"best checkpoint: iteration {best} (return {score:.1f}); evaluate it with --step best")
        checkpoints.close()
    except ValueError:
        pass
    _print(f"run directory: {run_dir}  (metrics.jsonl, curves.png, tensorboard/, checkpoints/)")
    _print(
        f"evaluate: python -m jaxpg.evaluate {run_dir} --episodes 10 [--gymnasium] [--video {run_dir}/videos/final.mp4]"
    )


def videos_requested(argv: Sequence[str], experiment: Experiment) -> bool:
    """Whether this command may draw videos (``--video-every`` > 0 given or by default, or a
    ``--resume``, whose run may have asked for them): only then does ``main`` choose MuJoCo's
    offscreen GL backend (``video.configure_gl``), which must happen before MuJoCo is imported.
    Read with argparse, so that abbreviations (``--video 5``) count as they do in the full parser."""
    peek = argparse.ArgumentParser(add_help=False, exit_on_error=False)
    peek.add_argument("--video-every", default=experiment.video_every)
    peek.add_argument("--resume")
    try:
        args, _ = peek.parse_known_args(list(argv))
        return args.resume is not None or int(args.video_every) > 0
    except (argparse.ArgumentError, ValueError):
        return False  # the full parser reports the bad value


def main(argv: Sequence[str] | None = None, experiment: Experiment | None = None) -> int:
    """Entry point of ``python -m jaxpg.cli`` and the experiment scripts; returns the exit status."""
    from jaxpg import compile_cache
    from jaxpg import video as video_lib

    experiment = experiment or Experiment(prog="python -m jaxpg.cli", epilog=DEFAULT_EPILOG)
    argv = list(sys.argv[1:] if argv is None else argv)
    if videos_requested(argv, experiment):
        video_lib.configure_gl()  # before MuJoCo is imported, and only when a video may be drawn
    compile_cache.enable()  # a second run of the same program loads it instead of compiling
    try:
        start_processes(argv)
        plan_ = plan(argv, experiment)
    except ValueError as e:  # UsageError, RunDirError, CheckpointError, Config.validate, DistributedError
        message = str(e).strip().splitlines()
        print(f"error: {message[0] if message else type(e).__name__}", file=sys.stderr)
        return 2
    return execute(plan_)


DEFAULT_EPILOG = """\
examples:
  python -m jaxpg.cli --env inverted_pendulum --iterations 50            # about a minute on a laptop CPU
  python -m jaxpg.cli --env hopper --preset lyceum --seeds 1 2 3 5 8 --iterations 200   # on a GPU
  python -m jaxpg.cli --resume runs/<run> --iterations 400
  python -m jaxpg.evaluate runs/<run> --episodes 10 --gymnasium --video out.mp4
"""


if __name__ == "__main__":
    raise SystemExit(main())
