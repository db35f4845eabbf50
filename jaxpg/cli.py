"""The command line of jaxpg: train any algorithm on any task into a run directory.

    python -m jaxpg.cli --env inverted_pendulum --algo npg --iterations 50
    python -m jaxpg.cli --env hopper --preset lyceum --seeds 1 2 3 5 8 --run-dir runs/hopper
    python -m jaxpg.cli --resume runs/hopper --iterations 400

The experiment scripts (``experiments/*.py``) are this command with other defaults
(``main(argv, Experiment(...))``). This module parses and plans (``plan``: a checked ``Plan``,
nothing written or compiled); ``jaxpg.session.execute`` runs a plan on the host. Every field
of the algorithm's ``Config`` is a flag (``policy_hidden`` -> ``--policy-hidden 64 64``,
booleans as ``--x/--no-x``); precedence, lowest first: ``Config`` defaults, the experiment's
defaults, ``--preset``, explicit flags.

A run directory (see ``jaxpg.runlog``) gets ``config.json``, ``metrics.jsonl``, TensorBoard
events, ``curves.png``, Orbax ``checkpoints/`` and, with ``--video-every``, ``videos/``. An existing
run directory is only replaced with ``--overwrite`` (a jaxpg run and nothing else:
``runlog.check_replaceable``) or continued with ``--resume``; a resumed run continues from its
latest checkpoint and produces the same metrics, bit for bit on the same device, as a run that
was never interrupted (the iteration where an earlier process ended also holds that process's
final evaluation of the mean policy: every run evaluates its last iteration).

``--minutes M`` stops a run after M minutes of training (counted after the first compiled block,
which compiles), with a checkpoint written, so that ``--resume`` continues it.

Bad input (unknown task or algorithm, impossible sizes, a run directory that exists, a resume of
a missing or foreign directory, an unusable checkpoint) is reported as one ``error: ...`` line on
stderr with exit status 2, before anything is compiled or written.

Several devices and processes (``jaxpg.mesh``, ``jaxpg.run.processes``): ``--num-envs`` is split over every device
(``--shard``, on when there are several). Several processes run one command each, adding
``--coordinator-address HOST:PORT --num-processes K --process-id I`` (or the ``JAX_*`` variables);
``start_processes`` joins them before anything else touches JAX, a coordinator that cannot be
reached is an ``error:`` line with status 2, and process 0 alone writes the run directory.
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import os
import sys
import typing
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from jaxpg import algos, runlog, session
from jaxpg.run.flags import UsageError, check_backend, finite_float, seed_value
from jaxpg.runlog import RunConfig
from jaxpg.session import Plan, execute


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
      env_flags: keyword arguments of the task offered as flags, ``name -> (type, help)``
        (``{"size": (int, "frames are SIZE x SIZE pixels")}`` gives ``--size 40``); a given flag
        goes to ``jaxpg.envs.make`` on top of ``env_kwargs``, and is saved with the run.
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
    env_flags: dict[str, tuple[type, str]] = dataclasses.field(default_factory=dict)
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


def _parser_type(tp: type) -> Any:
    """The argparse ``type`` of a field of type ``tp``: floats must be finite."""
    return finite_float if tp is float else tp


def _optional(parse: Any) -> Any:
    def parse_optional(text: str) -> Any:
        return None if text.lower() in ("none", "null") else parse(text)

    parse_optional.__name__ = getattr(parse, "__name__", "value")
    return parse_optional


RUN_FLAGS = (
    "task", "algo", "seed", "seeds", "iterations", "run_dir", "resume", "overwrite", "checkpoint_every",
    "keep_checkpoints", "log_every", "video_every", "preset", "profile", "fidelity", "impl",
    "max_episode_steps", "shard", "progress", "coordinator_address", "num_processes", "process_id",
    "distributed_timeout", "minutes",
)  # fmt: skip
CONFIG_PREFIX = "config."
ENV_PREFIX = "env."


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
            group.add_argument(_flag(name), nargs="*", type=_parser_type(elem), metavar=elem.__name__.upper(), **kwargs)
            continue
        if origin is typing.Literal:
            group.add_argument(_flag(name), choices=typing.get_args(base), **kwargs)
            continue
        choices = field_choices(config_cls, name) if base is str else None
        if choices and not optional:
            group.add_argument(_flag(name), choices=choices, **kwargs)
            continue
        parse = _parser_type(base) if base in (int, float, str) else str
        if optional:
            parse = _optional(parse)
        metavar = getattr(base, "__name__", "VALUE").upper()
        group.add_argument(_flag(name), type=parse, metavar=metavar, **kwargs)


def add_env_flags(parser: argparse.ArgumentParser, experiment: Experiment) -> None:
    """One flag per entry of ``experiment.env_flags`` (dest ``env.<name>``, default ``None`` =
    not given; booleans as ``--x/--no-x``)."""
    if not experiment.env_flags:
        return
    group = parser.add_argument_group(f"task settings (keyword arguments of the task {experiment.task!r})")
    for name, (kind, help_text) in experiment.env_flags.items():
        kwargs: dict[str, Any] = {"dest": ENV_PREFIX + name, "default": None, "help": help_text}
        if kind is bool:
            group.add_argument(_flag(name), action=argparse.BooleanOptionalAction, **kwargs)
        else:
            group.add_argument(_flag(name), type=_parser_type(kind), metavar=kind.__name__.upper(), **kwargs)


def _positive(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def _keep_count(text: str) -> int:
    """``--keep-checkpoints``: at least 1, since the latest checkpoint (what ``--resume`` continues)
    is kept whatever the count."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1 (the latest checkpoint is always kept), got {value}")
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
    seeds.add_argument("--seed", type=seed_value, help=f"training seed (default: {experiment.seed})")
    seeds.add_argument(
        "--seeds",
        type=seed_value,
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
        "--minutes",
        type=finite_float,
        help="stop after this many minutes of training, counted from the end of the first compiled "
        "block (which compiles): a checkpoint is written and --resume continues (default: no limit)",
    )
    run.add_argument(
        "--checkpoint-every",
        type=_positive,
        help=f"iterations between checkpoints; 0: only at the end (default: {experiment.checkpoint_every})",
    )
    run.add_argument(
        "--keep-checkpoints",
        type=_keep_count,
        help="latest checkpoints to keep (>= 1), besides the best; the final one always survives (default: 3)",
    )
    run.add_argument("--log-every", type=int, help=f"iterations per summary line (default: {experiment.log_every})")
    run.add_argument(
        "--video-every",
        type=_positive,
        help=f"iterations between videos of the mean policy; 0: none (default: {experiment.video_every})",
    )
    run.add_argument(
        "--preset",
        help="named Config overrides of the algorithm (jaxpg.algos.presets, checked against the task), e.g. lyceum",
    )
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
    add_env_flags(parser, experiment)
    add_distributed_flags(parser)
    if config_cls is not None:
        add_config_flags(parser, config_cls, config_defaults, f"{algo} hyperparameters (jaxpg.algos.{algo}.Config)")
    return parser


def add_distributed_flags(parser: argparse.ArgumentParser) -> None:
    """``--shard`` and the flags of ``jaxpg.run.processes.initialize`` (one launch command per process)."""
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
    from jaxpg.run import processes

    config = distributed_config(argv)
    if config is not None:
        processes.initialize(config)


def distributed_config(argv: Sequence[str]) -> Any:
    """The ``jaxpg.run.processes.DistributedConfig`` that ``argv`` and the environment ask for
    (``None``: one process), read before the full parse so that JAX is initialised first."""
    from jaxpg.run import processes

    pre = Parser(add_help=False)
    add_distributed_flags(pre)
    args, _ = pre.parse_known_args(argv)
    return processes.DistributedConfig.resolve(
        args.coordinator_address, args.num_processes, args.process_id, timeout_s=args.distributed_timeout
    )


def _pre_parse(argv: Sequence[str]) -> argparse.Namespace:
    pre = Parser(add_help=False)
    pre.add_argument("--task", "--env", dest="task")
    pre.add_argument("--algo")
    pre.add_argument("--resume")
    pre.add_argument("--run-dir")
    pre.add_argument("--preset")
    args, _ = pre.parse_known_args(argv)
    return args


# --------------------------------------------------------------------------- planning (no side effects)


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


def _explicit_env(args: argparse.Namespace) -> dict[str, Any]:
    return {k[len(ENV_PREFIX) :]: v for k, v in vars(args).items() if k.startswith(ENV_PREFIX) and v is not None}


def _default_run_dir(task: str, algo: str) -> Path:
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return Path("runs") / f"{task}-{algo}-{stamp}"


def _check_fresh_run_dir(run_dir: Path, overwrite: bool) -> None:
    """A new run may go into ``run_dir`` if it is missing or empty; with ``--overwrite``, also if it
    is a jaxpg run that no live process writes (``runlog.check_replaceable``)."""
    if not run_dir.exists():
        return
    if not run_dir.is_dir():
        raise UsageError(f"run directory {str(run_dir)!r} exists and is not a directory")
    if not any(run_dir.iterdir()):
        return
    if not overwrite:
        raise UsageError(session.exists_message(run_dir))
    runlog.check_replaceable(run_dir)
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


def _format_bytes(count: float) -> str:
    """``count`` bytes in binary units: ``'1.5 GiB'``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if count < 1024 or unit == "PiB":
            return f"{count:.0f} {unit}" if unit == "B" else f"{count:.1f} {unit}"
        count /= 1024
    raise AssertionError("unreachable")


def _host_available_bytes() -> int | None:
    """Memory the host can give a process now (``MemAvailable`` of ``/proc/meminfo``, else the
    free physical pages); ``None`` where neither is known."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, AttributeError):
        return None


def available_memory() -> tuple[int, str, bool] | None:
    """``(bytes, where, shared)``: the free memory of the smallest local accelerator (its
    allocator's limit minus what is in use; ``shared`` False: each device holds its own share),
    or on CPU the host's available memory (``shared`` True: every CPU device draws on it);
    ``None`` when the platform does not say."""
    import jax

    devices = jax.local_devices()
    if devices[0].platform == "cpu":
        host = _host_available_bytes()
        return None if host is None else (host, "this host", True)
    free = []
    for device in devices:
        stats = device.memory_stats() or {}
        if "bytes_limit" not in stats:
            return None
        free.append(int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0)))
    return min(free), f"each {devices[0].device_kind}", False


def check_memory(config: Any, env: Any, num_seeds: int, shares: int) -> None:
    """``UsageError`` (one line: how much is needed, how much there is, what to lower) when the
    ``core.memory_lower_bound`` of the config for ``num_seeds`` seeds, its batch split over ``shares``
    devices, exceeds the memory available (``available_memory``), so that an absurd size is
    refused up front instead of hanging in an allocation."""
    from jaxpg.algos import core

    memory = available_memory()
    if memory is None:
        return
    available, where, shared = memory
    bound = core.memory_lower_bound(config, env)
    batch = bound["rollout"] + bound["env_states"]
    if shared:  # every device's share, and a copy of the parameters per device, in one memory
        need = num_seeds * (bound["parameters"] * shares + batch)
    else:
        need = num_seeds * (bound["parameters"] + -(-batch // shares))
    if need <= available:
        return
    seeds = f" for {num_seeds} seeds" if num_seeds > 1 else ""
    raise UsageError(
        f"this configuration needs at least {_format_bytes(need)} of memory{seeds} (parameters "
        f"{_format_bytes(bound['parameters'])}, rollout of {config.num_envs} envs x {config.horizon} steps "
        f"{_format_bytes(bound['rollout'])}, env states {_format_bytes(bound['env_states'])}) but {where} has "
        f"{_format_bytes(available)} available; lower --num-envs, --horizon or the network sizes"
    )


def plan_fresh(args: argparse.Namespace, experiment: Experiment, module: Any, algo: str) -> Plan:
    task = args.task or experiment.task
    _check_task(task, experiment)
    config_cls = module.Config
    values = experiment.config_defaults(algo, config_cls)
    if args.preset is not None:
        try:
            values.update(algos.preset(algo, args.preset, task))
        except ValueError as e:
            known = ", ".join(algos.preset_names(algo, task)) or "none"
            raise UsageError(f"{e}; presets of {algo} for {task}: {known}") from None
    values.update(_explicit_config(args))
    types = runlog.field_types(config_cls)
    config = config_cls(**{k: runlog.coerce(types[k], v) for k, v in values.items()})
    env_kwargs = {**experiment.env_kwargs, **_explicit_env(args)}
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
    check_memory(config, env, num_seeds, shares)
    seeds = list(args.seeds) if args.seeds else [experiment.seed if args.seed is None else args.seed]
    if len(set(seeds)) != len(seeds):
        raise UsageError(f"--seeds must be distinct, got {' '.join(map(str, seeds))}")
    if len(seeds) > 1 and not getattr(env.unwrapped, "vmap_seeds", True):
        raise UsageError(f"task {task!r} steps its games on the host: train one seed per command (--seed)")
    log_every = experiment.log_every if args.log_every is None else args.log_every
    if log_every < 1:
        raise UsageError(f"--log-every must be >= 1, got {log_every}")
    iterations = experiment.iterations if args.iterations is None else args.iterations
    if iterations < 1:
        # It would leave a run directory without a checkpoint: nothing to resume or evaluate.
        raise UsageError(f"--iterations must be >= 1 for a new run, got {iterations}")
    run = RunConfig(
        task=task,
        algo=algo,
        config=runlog.config_to_dict(config),
        seeds=seeds,
        iterations=iterations,
        env_kwargs=env_kwargs,
        log_every=log_every,
        checkpoint_every=experiment.checkpoint_every if args.checkpoint_every is None else args.checkpoint_every,
        keep_checkpoints=3 if args.keep_checkpoints is None else args.keep_checkpoints,
        video_every=experiment.video_every if args.video_every is None else args.video_every,
        preset=args.preset,
    )
    run.shard = shard
    run_dir = Path(args.run_dir) if args.run_dir else _default_run_dir(task, algo)
    runlog.check_path(run_dir, "--run-dir")
    _check_fresh_run_dir(run_dir, bool(args.overwrite))
    return Plan(run=run, run_dir=run_dir, module=module, env=env, config=config, overwrite=bool(args.overwrite))


def plan_resume(args: argparse.Namespace, run: RunConfig, run_dir: Path) -> Plan:
    from jaxpg import checkpoint as ckpt_lib
    from jaxpg import policy_io

    fixed = [_flag(k) for k in (*_explicit_config(args), *_explicit_env(args))]
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
            "(only --iterations, --minutes, --checkpoint-every, --keep-checkpoints, --log-every, --video-every "
            "may change)"
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
    check_memory(config, env, len(run.seeds), _device_count() if run.shard else 1)
    runlog.check_unlocked(run_dir)
    no_checkpoint = UsageError(
        f"cannot resume {str(run_dir)!r}: it has no checkpoints (it stopped before its first one, so there is "
        "nothing to resume); start it again with --overwrite"
    )
    if not (run_dir / runlog.CHECKPOINT_DIR).is_dir():
        raise no_checkpoint
    checkpoints = ckpt_lib.Checkpointer(run_dir / runlog.CHECKPOINT_DIR, keep=None)
    step = checkpoints.latest_step()
    if step is None:
        raise no_checkpoint
    metrics_path = run_dir / runlog.METRICS_FILE
    damaged = runlog.damaged_metrics_line(metrics_path) if metrics_path.is_file() else None
    if damaged is not None:
        raise UsageError(
            f"cannot resume {str(run_dir)!r}: line {damaged} of its metrics.jsonl is not a JSON record "
            "(a resume would drop it); repair or delete that line, then resume"
        )
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
        runlog.check_path(pre.resume, "--resume")
        resume_run = RunConfig.load(pre.resume)
        algo = resume_run.algo
    else:
        algo = pre.algo or experiment.algo
    module = _algo_module(algo)
    config_cls = module.Config
    defaults = {f.name: _field_default(f) for f in dataclasses.fields(config_cls)}
    defaults.update(experiment.config_defaults(algo, config_cls))
    if resume_run is None and pre.preset in algos.preset_names(algo):
        defaults.update(algos.preset(algo, pre.preset))  # plan_fresh checks it against the task
    if resume_run is not None:
        defaults.update(runlog.current_field_names(config_cls, resume_run.config))
    parser = build_parser(experiment, algo, config_cls, defaults)
    args = parser.parse_args(argv)
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
    return result


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
        check_backend()
        recover_run_dir(argv)
        plan_ = plan(argv, experiment)
    except ValueError as e:  # UsageError, RunDirError, CheckpointError, Config.validate, DistributedError
        message = str(e).strip().splitlines()
        print(f"error: {message[0] if message else type(e).__name__}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"error: cannot put the run directory back in order: {e}", file=sys.stderr)
        return 2
    return execute(plan_)


def recover_run_dir(argv: Sequence[str]) -> None:
    """Before planning: put back the run that an ``--overwrite`` of the command's run directory
    (``--run-dir`` or ``--resume``) moved aside, if its process ended before the new run's first
    checkpoint, or point to it (``session.recover_replaced``). Process 0 alone; the others wait."""
    from jaxpg.run import processes

    pre = _pre_parse(argv)
    target = pre.resume if pre.resume is not None else pre.run_dir
    if target is not None and processes.is_primary():
        for line in session.recover_replaced(target):
            print(line, file=sys.stderr)
    processes.barrier("jaxpg: run directory recovered")


DEFAULT_EPILOG = """\
examples:
  python -m jaxpg.cli --env inverted_pendulum --iterations 50            # about a minute on a laptop CPU
  python -m jaxpg.cli --env hopper --preset lyceum --seeds 1 2 3 5 8 --iterations 200   # on a GPU
  python -m jaxpg.cli --resume runs/<run> --iterations 400
  python -m jaxpg.evaluate runs/<run> --episodes 10 --gymnasium --video out.mp4
"""


if __name__ == "__main__":
    raise SystemExit(main())
