"""The command line of jaxpg: train any algorithm on any task into a run directory.

    python -m jaxpg.cli --env inverted_pendulum --algo npg --iterations 50
    python -m jaxpg.cli --env hopper --preset lyceum --seeds 1 2 3 5 8 --run-dir runs/hopper
    python -m jaxpg.cli --resume runs/hopper --iterations 400

The experiment scripts (``experiments/*.py``) are this command with other defaults
(``main(argv, Experiment(...))``). This module builds the flags; ``jaxpg.run.command.planning.plan``
turns them into a checked ``Plan`` (nothing written or compiled) and
``jaxpg.run.training.session.execute`` runs a plan on the host. Every field
of the algorithm's ``Config`` is a flag (``policy_hidden`` -> ``--policy-hidden 64 64``,
booleans as ``--x/--no-x``); precedence, lowest first: ``Config`` defaults, the experiment's
defaults, ``--preset``, explicit flags.

A run directory (see ``jaxpg.run.rundir.layout``) gets ``config.json``, ``metrics.jsonl``, TensorBoard
events, ``curves.png``, Orbax ``checkpoints/`` and, with ``--video-every``, ``videos/``. An existing
run directory is only replaced with ``--overwrite`` (a jaxpg run and nothing else:
``directory.check_replaceable``) or continued with ``--resume``; a resumed run continues from its
latest checkpoint and produces the same metrics, bit for bit on the same device, as a run that
was never interrupted (the iteration where an earlier process ended also holds that process's
final evaluation of the mean policy: every run evaluates its last iteration).

``--minutes M`` stops a run after M minutes of training (counted after the first compiled block,
which compiles), with a checkpoint written, so that ``--resume`` continues it.

Bad input (unknown task or algorithm, impossible sizes, a run directory that exists, a resume of
a missing or foreign directory, an unusable checkpoint) is reported as one ``error: ...`` line on
stderr with exit status 2, before anything is compiled or written.

Several devices and processes (``jaxpg.mesh``, ``jaxpg.run.host.processes``): ``--num-envs`` is split over every device
(``--shard``, on when there are several). Several processes run one command each, adding
``--coordinator-address HOST:PORT --num-processes K --process-id I`` (or the ``JAX_*`` variables);
``startup.start`` joins them before anything else touches JAX, a coordinator that cannot be
reached is an ``error:`` line with status 2, and process 0 alone writes the run directory.
"""

from __future__ import annotations

import argparse
import dataclasses
import typing
from typing import Any

from jaxpg import algos, envs
from jaxpg.algos.field_help import field_choices, field_help
from jaxpg.run.command import task_options
from jaxpg.run.command.flags import UsageError, finite_float, seed_value
from jaxpg.run.rundir import config_io


@dataclasses.dataclass(frozen=True)
class Experiment:
    """What an experiment script fixes on top of the generic command line.

    Attributes:
      task: default task; tasks: the tasks the script accepts (``None``: every registered one).
      algo: default algorithm.
      iterations, seed, log_every, checkpoint_every, video_every: defaults of those flags.
      config: ``Config`` overrides per algorithm name (``"*"``: for every algorithm that has the
        field); applied below ``--preset`` and explicit flags.
      default_presets: the preset a fresh run of an algorithm takes when ``--preset`` is not
        given (``{"npg": "hopper_1m"}``), applied and saved as if given; a given ``--preset``
        replaces it.
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
    default_presets: dict[str, str] = dataclasses.field(default_factory=dict)
    env_kwargs: dict[str, Any] = dataclasses.field(default_factory=dict)
    env_flags: dict[str, tuple[type, str]] = dataclasses.field(default_factory=dict)
    prog: str | None = None
    description: str | None = None
    epilog: str | None = None

    def preset_name(self, algo: str, given: str | None) -> str | None:
        """The preset a fresh run of ``algo`` takes: ``given`` (``--preset``), else this script's
        default for ``algo`` (``None``: none)."""
        return given if given is not None else self.default_presets.get(algo)

    def config_defaults(self, algo: str, config_cls: type) -> dict[str, Any]:
        names = {f.name for f in dataclasses.fields(config_cls)}
        out = {k: v for k, v in self.config.get("*", {}).items() if k in names}
        out.update(self.config.get(algo, {}))
        return out


class Parser(argparse.ArgumentParser):
    """argparse that raises ``UsageError`` instead of printing the usage and exiting."""

    def error(self, message: str) -> typing.NoReturn:
        raise UsageError(message)


def algo_module(name: str) -> Any:

    if name not in algos.ALGORITHMS:
        raise UsageError(f"unknown algorithm {name!r}; known algorithms: {', '.join(sorted(algos.ALGORITHMS))}")
    try:
        return algos.get(name)
    except ModuleNotFoundError as e:
        if e.name == algos.ALGORITHMS[name]:
            raise UsageError(f"algorithm {name!r} is not available yet in this jaxpg ({e.name} is missing)") from None
        raise


def flag_name(name: str) -> str:
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
    "task", "algo", "seed", "seeds", "iterations", "run_dir", "resume", "from_step", "overwrite", "checkpoint_every",
    "keep_checkpoints", "log_every", "video_every", "preset", "profile", "fidelity", "impl",
    "max_episode_steps", "action_scaling", "shard", "progress", "coordinator_address", "num_processes", "process_id",
    "distributed_timeout", "minutes", "env_kwargs",
)  # fmt: skip


CONFIG_PREFIX = "config."


ENV_PREFIX = "env."


def add_config_flags(parser: argparse.ArgumentParser, config_cls: type, defaults: dict[str, Any], title: str) -> None:
    """One flag per field of ``config_cls`` (dest ``config.<field>``, default ``None`` = not
    given): ints, floats, strings, ``T | None`` (``none``), tuples (``nargs='*'``) and booleans
    (``--x/--no-x``). Help shows what the field means (``algos.field_help``), the values a string
    field accepts and the effective default."""
    group = parser.add_argument_group(title)
    unused = getattr(config_cls, "UNUSED_FIELDS", ())
    for name, tp in config_io.field_types(config_cls).items():
        if name in unused:  # the algorithm ignores it: no flag, so that passing it is an error
            continue
        if name in RUN_FLAGS:
            raise TypeError(f"{config_cls.__module__}.Config.{name} clashes with a command-line flag")
        base, optional = config_io.strip_optional(tp)
        help_text = f"{field_help(name)} (default: {_show(defaults.get(name))})".lstrip()
        kwargs: dict[str, Any] = {"dest": CONFIG_PREFIX + name, "default": None, "help": help_text}
        origin = typing.get_origin(base)
        if base is bool:
            group.add_argument(flag_name(name), action=argparse.BooleanOptionalAction, **kwargs)
            continue
        if base is tuple or origin is tuple:
            args = typing.get_args(base)
            elem = args[0] if args and args[0] in (int, float, str) else str
            group.add_argument(
                flag_name(name), nargs="*", type=_parser_type(elem), metavar=elem.__name__.upper(), **kwargs
            )
            continue
        if origin is typing.Literal:
            group.add_argument(flag_name(name), choices=typing.get_args(base), **kwargs)
            continue
        choices = field_choices(config_cls, name) if base is str else None
        if choices and not optional:
            group.add_argument(flag_name(name), choices=choices, **kwargs)
            continue
        parse = _parser_type(base) if base in (int, float, str) else str
        if optional:
            parse = _optional(parse)
        metavar = getattr(base, "__name__", "VALUE").upper()
        group.add_argument(flag_name(name), type=parse, metavar=metavar, **kwargs)


def add_env_flags(parser: argparse.ArgumentParser, experiment: Experiment) -> None:
    """One flag per entry of ``experiment.env_flags`` (dest ``env.<name>``, default ``None`` =
    not given; booleans as ``--x/--no-x``)."""
    if not experiment.env_flags:
        return
    group = parser.add_argument_group(f"task settings (keyword arguments of the task {experiment.task!r})")
    for name, (kind, help_text) in experiment.env_flags.items():
        kwargs: dict[str, Any] = {"dest": ENV_PREFIX + name, "default": None, "help": help_text}
        if kind is bool:
            group.add_argument(flag_name(name), action=argparse.BooleanOptionalAction, **kwargs)
        else:
            group.add_argument(flag_name(name), type=_parser_type(kind), metavar=kind.__name__.upper(), **kwargs)


def _positive(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def _assignment(text: str) -> tuple[str, Any]:
    try:
        return task_options.parse_assignment(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _keep_count(text: str) -> int:
    """``--keep-checkpoints``: at least 1, since the latest checkpoint (what ``--resume`` continues)
    is kept whatever the count."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1 (the latest checkpoint is always kept), got {value}")
    return value


def build_parser(experiment: Experiment, algo: str, config_cls: type | None, config_defaults: dict[str, Any]) -> Parser:
    """The full parser: run flags plus the ``Config`` flags of ``algo``."""
    tasks = experiment.tasks or tuple(envs.names())
    default_preset = experiment.preset_name(algo, None)
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
    run.add_argument(
        "--iterations",
        type=_positive,
        help=f"total iterations (default: {experiment.iterations}, or the preset's own, e.g. 120 for the *_1m presets)",
    )
    run.add_argument("--run-dir", help="run directory (default: runs/<task>-<algo>-<date>-<time>)")
    run.add_argument(
        "--resume",
        metavar="RUN_DIR",
        help="continue RUN_DIR from its latest checkpoint (--iterations sets a new total)",
    )
    run.add_argument(
        "--from-step",
        type=_positive,
        metavar="N",
        help="with --resume: continue from the earlier checkpoint of iteration N instead; the checkpoints after "
        "it and the metrics after iteration N are deleted once the run directory is locked",
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
        help=f"iterations between checkpoints; 0: only at the end (default: {experiment.checkpoint_every}, or "
        "for a long run a twentieth of its iterations, rounded up to a multiple of --log-every)",
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
        help="named Config overrides of the algorithm (jaxpg.algos.presets, checked against the task), e.g. lyceum"
        + (f" (default: {default_preset})" if default_preset else ""),
    )
    run.add_argument(
        "--profile",
        action="store_true",
        default=None,
        help="time each phase of one iteration before training",
    )
    run.add_argument(
        "--fidelity",
        choices=("fast", "gymnasium"),
        help="MJX physics settings (default: the preset's, else fast; --algo a2c --preset ant_1m trains in gymnasium)",
    )
    run.add_argument("--impl", choices=("jax", "warp"), help="MJX implementation (default: warp on a GPU, else jax)")
    run.add_argument("--max-episode-steps", type=int, help="time limit of an episode (default: the task's)")
    run.add_argument(
        "--action-scaling",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the policy acts in [-1, 1], mapped linearly onto the task's action range (continuous tasks; "
        "saved with the run, and the Gymnasium replay maps its actions the same way) (default: off, or the preset's)",
    )
    run.add_argument(
        "--env-kwargs",
        nargs="+",
        type=_assignment,
        metavar="KEY=VALUE",
        help="options of the task, with the meaning of Gymnasium's env keyword arguments, e.g. "
        "include_cfrc_ext_in_observation=false for ant; saved with the run, and given to Gymnasium's env "
        "by python -m jaxpg.evaluate --gymnasium (default: the task's, or the preset's)",
    )
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
    """``--shard`` and the flags of ``jaxpg.run.host.processes.initialize`` (one launch command per process)."""
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


DEFAULT_EPILOG = """\
examples:
  python -m jaxpg.cli --env inverted_pendulum --iterations 50            # about a minute on a laptop CPU
  python -m jaxpg.cli --env hopper --preset lyceum --seeds 1 2 3 5 8 --iterations 200   # on a GPU
  python -m jaxpg.cli --resume runs/<run> --iterations 400
  python -m jaxpg.evaluate runs/<run> --episodes 10 --gymnasium --video out.mp4
"""
