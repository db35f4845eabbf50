"""Every command in the README's and its docs pages' code blocks is exercised, and the docs hold
together.

The README keeps its two commands at the top; the commands of the pages it links to (``DOC_PAGES``:
tasks, algorithms, run directories, GPUs, Pong, notebooks) are checked here as if they were its own.

* The main job (the first command: NPG on ``inverted_pendulum`` into ``runs/pendulum``) runs for
  real, as written, and must balance the pendulum: its final mean-policy return >= 950. Then the
  documented ``python -m jaxpg.evaluate runs/pendulum ... --gymnasium`` replays it in Gymnasium's
  InvertedPendulum-v5 and must reach the same.
* The GPU training commands are planned as the CLI plans them (flags, preset, config validated
  against the task, env built) without training, which needs a GPU; each flag lands in the plan
  as typed, and what the docs' text says a command trains (``README_CLAIMS``: algorithm,
  batch, preset values, iterations, env steps ...) is what it plans.
* ``python -m jaxpg.evaluate`` of a Pong run is run by ``tests/test_pong.py`` on a tiny run.
* The Pong benchmark's commands (``benchmarks/pong.py``, its own command line) pass that
  script's argument checks; ``tests/test_pong.py`` runs its comparison mode on the CPU.
* The several-process launch lines are run word for word by ``tests/test_distributed.py``.
* The install, test and venv steps are what ``.ci/run`` runs.
* The README's "API in ten lines" runs, on a small scale, on the CPU.
* The README stays under 200 lines, every relative link of the README, BENCHMARKS.md and
  ``docs/*.md`` reaches an existing file (and heading), and ``benchmarks/`` holds at most 13 scripts,
  each named by BENCHMARKS.md's commands as it exists.

A python command of the docs that none of these covers fails ``test_every_command_is_covered``.
"""

from __future__ import annotations

import dataclasses
import json
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from script_loader import load_script

from jaxpg.run.command import command_line, planning
from jaxpg.run.command.plan import Plan

ROOT = Path(__file__).resolve().parents[1]
MAIN_JOB = "python experiments/pendulum.py --run-dir runs/pendulum"
# The pages whose commands are the README's own: what the README links to for tasks, algorithms, run
# directories, GPUs, Pong and notebooks.
DOC_PAGES = (
    "README.md",
    *(f"docs/{name}.md" for name in ("tasks", "algorithms", "run_directories", "gpus", "pong", "notebooks")),
)


def docs_text() -> str:
    """The README and ``DOC_PAGES``, one after the other."""
    return "\n".join((ROOT / page).read_text() for page in DOC_PAGES)


def readme_python_commands() -> list[str]:
    """Every ``python ...`` command of the bash blocks of the README and its ``DOC_PAGES`` (one per
    ``&&`` segment, comments and a trailing ``&`` dropped)."""
    text = docs_text()
    commands = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            line = line.split(" #")[0].strip()
            if line.startswith("#"):
                continue
            for segment in line.split("&&"):
                segment = segment.strip().rstrip("&").strip()
                if segment.startswith("python ") and not segment.startswith("python3 -m venv"):
                    commands.append(segment)
    return commands


def is_distributed(command: str) -> bool:
    return "--coordinator-address" in command


def is_pong_benchmark(command: str) -> bool:
    return shlex.split(command)[1] == "benchmarks/pong.py"


def is_pong_evaluation(command: str) -> bool:
    """``python -m jaxpg.evaluate runs/pong...``: tests/test_pong.py runs it on a tiny trained run."""
    return command.startswith("python -m jaxpg.evaluate runs/pong")


def is_ale_evaluation(command: str) -> bool:
    """``python -m jaxpg.evaluate RUN --ale``: tests/test_atari.py runs it on a tiny trained run."""
    return command.startswith("python -m jaxpg.evaluate ") and "--ale" in shlex.split(command)


def is_planned(command: str) -> bool:
    """A training command checked with ``planning.plan`` (everything but the main job)."""
    words = shlex.split(command)
    return command != MAIN_JOB and (words[1].startswith("experiments/") or words[1:3] == ["-m", "jaxpg.cli"])


COVERED_ELSEWHERE = (is_distributed, is_planned, is_pong_benchmark, is_pong_evaluation, is_ale_evaluation)


def test_every_command_is_covered():
    commands = readme_python_commands()
    assert MAIN_JOB in commands
    evaluates = [c for c in commands if c.startswith("python -m jaxpg.evaluate runs/pendulum")]
    assert evaluates, "the docs evaluate the main job's run directory"
    uncovered = [
        c for c in commands if c != MAIN_JOB and c not in evaluates and not any(check(c) for check in COVERED_ELSEWHERE)
    ]
    assert not uncovered, f"documented commands no test runs: {uncovered}"


def test_ci_runs_the_readme_test_command_and_reports_skips():
    """``.ci/run`` runs the README's second command word for word (the one command line of the
    README's code blocks that runs pytest), and that command's pytest prints the reason of every
    skip (``-rs``), so that a skipped check is seen in CI's log, in two worker processes that each
    take whole test files (``-n 2 --dist loadfile``: module fixtures stay shared)."""
    blocks = re.findall(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(), flags=re.S)
    readme = [line for block in blocks for line in block.splitlines() if "pytest" in line]
    ci = [line for line in (ROOT / ".ci" / "run").read_text().splitlines() if "pytest" in line]
    assert len(readme) == 1 and ci == readme, (readme, ci)
    assert re.search(r"&& pytest -q -rs -n 2 --dist loadfile$", ci[0]), ci[0]


# What the docs' text says their training commands train: (a phrase of the docs, the values it
# states). The phrase must be in the README or a ``DOC_PAGES`` page (whitespace aside), so that this table follows the
# text; the values must be in the command's plan (``planned_values``). ``M env steps`` is
# num_envs x horizon x iterations in millions, as rounded in the phrase.
HOPPER = "python experiments/hopper.py --num-envs 256 --run-dir runs/hopper"
README_CLAIMS: dict[str, list[tuple[str, dict]]] = {
    HOPPER: [
        (
            "`python experiments/hopper.py --num-envs 256` trains NPG with the `hopper_1m` preset",
            {"algo": "npg", "preset": "hopper_1m"},
        ),
        ("256 envs x 32 steps per iteration", {"num_envs": 256, "horizon": 32}),
        (
            "a normalised step with `--kl-delta 0.07`, observation normalisation",
            {"kl_delta": 0.07, "normalize_observations": True},
        ),
        (
            "the policy's noise held at a log-std of 1",
            {"log_std_init": 1.0, "log_std_min": 1.0, "log_std_final": 1.0, "anneal_log_std_iterations": 120},
        ),
        (
            "a 128x128 value function fitted for 10 epochs of 16 minibatches",
            {"value_hidden": [128, 128], "value_epochs": 10, "value_minibatches": 16},
        ),
        ("standardised value targets (`--normalize-value-targets`", {"normalize_value_targets": True}),
        ("at most 16384 samples an epoch", {"value_epoch_samples": 16384}),
        ("Fisher-vector products use at most 16384 samples", {"fisher_samples": 16384}),
        ("for 120 iterations (0.98 M env steps)", {"iterations": 120, "M env steps": "0.98"}),
        (
            "The mean policy is evaluated (16 episodes) after the last iteration and every 120 iterations",
            {"eval_envs": 16, "eval_every": 120},
        ),
        ("acting with its clipped mean (`--eval-action clipped_mean`", {"eval_action": "clipped_mean"}),
    ],
    "python experiments/pong.py --num-envs 16 --size 40 --minutes 5 --run-dir runs/pong-cpu": [
        ("`--algo a2c` (default): A2C with GAE", {"algo": "a2c", "value_target": "gae"}),
        ("`--size 40` draws smaller frames", {"observation_size": 40 * 40}),
    ],
    "python experiments/pong.py --num-envs 1024 --lr 2e-3 --minutes 3 --run-dir runs/pong-a2c": [
        ("The policy sees 80x80 frame differences", {"observation_size": 80 * 80}),
    ],
    "python experiments/atari_pong.py --run-dir runs/atari-ppo": [
        (
            "`--algo ppo` (default) is PPO's Atari recipe with the Nature convolutional network",
            {"algo": "ppo", "conv_torso": "nature"},
        ),
        ("2500 iterations, 5.1 M steps", {"iterations": 2500, "M env steps": "5.1"}),
        ("PPO, Nature CNN, 16 games", {"num_envs": 16}),
    ],
    "python experiments/atari_pong.py --algo a2c --preset atari --iterations 130500 --checkpoint-every 2000 "
    "--log-every 500 --run-dir runs/atari-a2c": [
        (
            "A2C (`--preset atari`), Nature CNN, 16 games, t_max 5",
            {"algo": "a2c", "conv_torso": "nature", "num_envs": 16, "horizon": 5},
        ),
    ],
    "python experiments/atari_pong.py --algo a2c --num-envs 16 --iterations 2000 --run-dir runs/atari-a2c-cpu": [
        (
            "keep MinPy's 6400-200 network unless given a torso",
            {"conv_torso": "none", "observation_size": 6400, "policy_hidden": [200]},
        ),
    ],
}


def load_experiment(script: str) -> command_line.Experiment:
    """The ``EXPERIMENT`` of ``experiments/<name>.py``."""
    return load_script(script).EXPERIMENT


def plan_command(command: str, run_dir: Path) -> Plan:
    """``planning.plan`` of a README training command, as its script or ``-m jaxpg.cli`` would plan it,
    with its ``--run-dir`` moved to ``run_dir``."""
    words = shlex.split(command)
    argv = words[3:] if words[1] == "-m" else words[2:]
    experiment = command_line.Experiment() if words[1] == "-m" else load_experiment(words[1])
    if "--run-dir" in argv:
        argv[argv.index("--run-dir") + 1] = str(run_dir)
    return planning.plan(argv, experiment)


def planned_values(planned: Plan) -> dict:
    """Everything a flag or the README can name, by its flag's name (``num_envs`` for
    ``--num-envs``; ``env``, the task, for ``--env``): the run's settings, the algorithm's config,
    the task's keyword arguments, the ``minutes`` of ``--minutes``, the env's ``observation_size``
    and the ``M env steps`` trained."""
    run = planned.run
    config = planned.config
    values = {**run.env_kwargs, **dataclasses.asdict(config)}
    values.update(
        task=run.task,
        env=run.task,
        algo=run.algo,
        preset=run.preset,
        iterations=run.iterations,
        checkpoint_every=run.checkpoint_every,
        log_every=run.log_every,
        observation_size=planned.env.observation_size,
        minutes=None if planned.time_limit_s is None else planned.time_limit_s / 60,
    )
    values["M env steps"] = config.num_envs * config.horizon * run.iterations / 1e6
    return values


def typed_flags(command: str) -> dict[str, list[str]]:
    """``{name: words}`` for each ``--flag word...`` of ``command`` (``num_envs`` for ``--num-envs``),
    ``--run-dir`` left out."""
    flags: dict[str, list[str]] = {}
    for word in shlex.split(command):
        if word.startswith("--"):
            words = flags.setdefault(word[2:].replace("-", "_"), [])
        elif flags:
            words.append(word)
    flags.pop("run_dir", None)
    return flags


def as_typed(words: list[str], like: object) -> object:
    """The words a flag was given, read as the type of the planned value ``like``."""
    if isinstance(like, bool):
        return not words or words == ["true"]
    if isinstance(like, list | tuple):
        return [type(like[0])(w) for w in words] if like else words
    assert len(words) == 1, words
    return type(like)(words[0])


PLANNED = [c for c in readme_python_commands() if is_planned(c) and not is_distributed(c)]


@pytest.mark.parametrize("command", PLANNED)
def test_training_commands_plan_what_the_readme_says(command, tmp_path):
    """Planned as the CLI plans it (flags, preset, config checked against the task, env built),
    without training: every flag of the command is in the plan as typed (no preset or experiment
    default overrides it), and every value the README's text states for the command
    (``README_CLAIMS``) is the planned one."""
    values = planned_values(plan_command(command, tmp_path / "run"))
    for name, words in typed_flags(command).items():
        assert name in values, f"--{name.replace('_', '-')} is not in the plan"
        planned = values[name]
        assert as_typed(words, planned) == (list(planned) if isinstance(planned, tuple) else planned), (
            f"--{name.replace('_', '-')} {' '.join(words)} planned as {planned!r}"
        )
    readme = " ".join(docs_text().split())
    for phrase, claimed in README_CLAIMS.get(command, []):
        assert phrase in readme, f"the docs no longer say: {phrase!r} (update README_CLAIMS)"
        for name, want in claimed.items():
            got = values[name]
            if name == "M env steps":
                got = f"{got:.{len(want.split('.')[1])}f}"
            elif isinstance(got, tuple):
                got = list(got)
            assert got == want, f"docs: {phrase!r}; planned {name} = {got!r}"


def test_readme_claims_name_readme_commands():
    """Every command of ``README_CLAIMS`` is a planned README command, so none is left unchecked."""
    assert set(README_CLAIMS) <= set(PLANNED), set(README_CLAIMS) - set(PLANNED)


@pytest.mark.parametrize("command", [c for c in readme_python_commands() if is_pong_benchmark(c)])
def test_pong_benchmark_commands_pass_their_checks(command, tmp_path):
    bench = load_script("benchmarks/pong.py")
    argv = shlex.split(command)[2:]
    argv[argv.index("--run-dir") + 1] = str(tmp_path / "run")
    args = bench.build_parser().parse_args(argv)
    bench.check(args)
    assert args.compare_envs and not args.run_dir.exists()


@pytest.mark.slow
def test_main_job_balances_the_pendulum_and_gymnasium_agrees(tmp_path):
    words = shlex.split(MAIN_JOB)
    train = subprocess.run(
        [sys.executable, str(ROOT / words[1]), *words[2:]], cwd=tmp_path, capture_output=True, text=True, timeout=1200
    )
    assert train.returncode == 0, train.stderr[-3000:]
    rows = [json.loads(line) for line in (tmp_path / "runs" / "pendulum" / "metrics.jsonl").read_text().splitlines()]
    final = [r["return_mean_policy"] for r in rows if r.get("return_mean_policy") is not None][-1]
    assert float(final) >= 950, f"main job ended at mean-policy return {final}"
    for command in readme_python_commands():
        if command.startswith("python -m jaxpg.evaluate runs/pendulum"):
            words = shlex.split(command)
            out = subprocess.run(
                [sys.executable, *words[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600
            )
            assert out.returncode == 0, out.stderr[-3000:]
            returns = re.findall(r"^return: ([0-9.]+)", out.stdout, flags=re.M)
            assert returns and float(returns[0]) >= 950, out.stdout


# --------------------------------------------------------------------------- the README's API


def test_api_in_ten_lines_runs(tmp_path, monkeypatch):
    """The README's "API in ten lines", run as written on the CPU, except: 2 iterations where it
    says 50, on ``cartpole`` (the same calls; its pure-JAX physics compiles in seconds where MJX's
    pendulum takes a minute a program), and a tiny trained run in ``runs/pendulum`` for
    ``jaxpg.load_policy``, whose policy maps a NumPy observation to a NumPy action."""
    import numpy as np

    from jaxpg import cli

    text = (ROOT / "README.md").read_text()
    section = text[text.index("## The API in ten lines") :]
    code = re.search(r"```python\n(.*?)```", section, flags=re.S).group(1)
    assert len(code.strip().splitlines()) <= 14, code
    small = re.sub(r"(train\.train\(npg\.update, \w+, )50\b", r"\g<1>2", code).replace("block_size=10", "block_size=2")
    assert '"inverted_pendulum"' in small
    small = small.replace('"inverted_pendulum"', '"cartpole"')
    assert small.count(", 2,") + small.count(", 2)") >= 2, small
    monkeypatch.chdir(tmp_path)
    argv = ["--env", "cartpole", "--iterations", "1", "--num-envs", "8", "--horizon", "16"]
    argv += ["--value-batch-size", "64", "--eval-envs", "2", "--run-dir", "runs/pendulum", "--no-progress"]
    assert cli.main(argv) == 0
    namespace: dict = {}
    exec(compile(small, "README.md", "exec"), namespace)
    assert int(namespace["state"].iteration) == 3  # one jitted update, then two
    assert namespace["seeds"].iteration.shape == (5,)
    policy = namespace["policy"]
    action = policy(np.zeros(namespace["env"].observation_size, np.float32))
    assert isinstance(action, np.ndarray | np.generic) and np.all(np.isfinite(action))


# --------------------------------------------------------------------------- the docs hold together

LINK = re.compile(r"\]\(([^)\s]+)\)")
# Written on its own branch; the README links to it already.
PAGES_WRITTEN_ELSEWHERE: set[str] = set()


def heading_anchors(text: str) -> set[str]:
    """GitHub's anchors of a Markdown file's headings (``## The card command`` -> ``the-card-command``)."""
    anchors, seen = set(), {}
    for line in re.sub(r"```.*?```", "", text, flags=re.S).splitlines():
        match = re.match(r"#+ (.*)", line)
        if not match:
            continue
        slug = re.sub(r"[^\w\- ]", "", match.group(1).strip().lower()).replace(" ", "-")
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        anchors.add(slug if count == 0 else f"{slug}-{count}")
    return anchors


def markdown_files() -> list[Path]:
    return [ROOT / "README.md", ROOT / "BENCHMARKS.md", *sorted((ROOT / "docs").glob("*.md"))]


def test_readme_is_short():
    assert len((ROOT / "README.md").read_text().splitlines()) < 200


def test_relative_links_resolve():
    """Every relative link of the README, BENCHMARKS.md and ``docs/*.md`` reaches a file of the
    repository, and a ``#anchor`` into a Markdown file one of its headings."""
    broken = []
    for page in markdown_files():
        text = page.read_text()
        for target in LINK.findall(re.sub(r"```.*?```", "", text, flags=re.S)):
            if re.match(r"[a-z]+:", target):
                continue
            path, _, anchor = target.partition("#")
            file = (page.parent / path).resolve() if path else page
            name = file.relative_to(ROOT).as_posix() if file.is_relative_to(ROOT) else str(file)
            if not file.exists():
                if name not in PAGES_WRITTEN_ELSEWHERE:
                    broken.append(f"{page.relative_to(ROOT)}: {target}")
                continue
            if anchor and file.suffix == ".md" and anchor not in heading_anchors(file.read_text()):
                broken.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert not broken, broken


def test_benchmarks_are_at_most_sixteen_scripts_and_the_docs_name_them_as_they_are():
    """One script a topic, its modes in ``benchmarks/<script>_modes/``; sixteen since the sweeps'
    speed, the race against Brax's PPO and the physics step's latency each got one."""
    scripts = sorted(p.name for p in (ROOT / "benchmarks").iterdir() if p.suffix in (".py", ".sh"))
    assert len(scripts) <= 16, scripts
    current = [ROOT / "README.md", ROOT / "BENCHMARKS.md", *(ROOT / "docs").glob("*.md")]
    current = [p for p in current if p.name != "benchmarks_archive.md"]
    wrong = []
    for page in current:
        for script, word in re.findall(r"benchmarks/(\w+\.(?:py|sh))(?: ([\w-]+))?", page.read_text()):
            if script not in scripts:
                wrong.append(f"{page.name}: benchmarks/{script}")
                continue
            modes = re.search(r"^MODES = \{(.*)\}", (ROOT / "benchmarks" / script).read_text(), flags=re.M)
            if modes and word and not word.startswith("-") and word not in re.findall(r'"(\w+)"', modes.group(1)):
                wrong.append(f"{page.name}: benchmarks/{script} {word}")
    assert not wrong, wrong
