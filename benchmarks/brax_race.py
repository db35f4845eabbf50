"""Brax's PPO against jaxpg on the same env, scored by one evaluator.

Two suites of envs, each trained by both trainers:
  jaxpg  jaxpg's ``ant`` and ``humanoid`` (fast physics): jaxpg trains them natively (its preset
         ``ant_fast`` / ``humanoid_fast``), Brax's PPO through ``jaxpg.envs.brax_env`` (actions in
         [-1, 1], fresh reset noise as Gymnasium's, and the 1000-step limit handled as on Brax's own
         envs: ``EpisodeWrapper`` truncates and PPO masks the cut step);
  brax   Brax's own ``ant`` and ``humanoid`` (backend mjx): Brax's PPO trains them natively, jaxpg
         through ``jaxpg.envs.brax_task`` (``--env brax:ant``) with the same presets.

Brax's PPO uses the hyperparameters Brax published for Ant and Humanoid (``BRAX_PPO``). Every run has
the same training-clock budget. Its clock starts when the trainer is called (compilation included)
and excludes the evaluations, which happen between training chunks at geometrically spaced clock
marks (each mark ``--mark-ratio`` past the previous one): a time to a score is then known to within
that ratio plus one chunk. Each evaluation is the same function for both trainers: the deterministic
policy's mean return over ``--eval-episodes`` fresh episodes (fixed reset keys) of the env with its
time limit (jaxpg's ``episode_totals_from``). The final policy of a jaxpg task is replayed in
Gymnasium too (``jaxpg.run.evaluation.replay``).

    python benchmarks/brax_race.py --suite jaxpg --env ant --trainer brax jaxpg --seeds 0 1 2 --budget 240 \\
        --json runs/race-ant.json
    python benchmarks/brax_race.py --table runs/race-*.json          # one table from several runs
    python benchmarks/brax_race.py --quick                            # CPU smoke test, tiny sizes

Brax 0.14.2 needs ``jaxpg.envs.brax_compat.brax_jax_shim`` on JAX >= 0.10: it is entered around
Brax's trainer here, nowhere else. GPU results go to BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import sys
import time
from pathlib import Path
from typing import Any

PROCESS_START = time.perf_counter()

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from jaxpg import algos, envs  # noqa: E402
from jaxpg import train as train_lib  # noqa: E402
from jaxpg.algos.core import sampling  # noqa: E402
from jaxpg.envs.wrappers import ClipAction, RescaleAction  # noqa: E402
from jaxpg.rollout import episode_totals_from  # noqa: E402

THRESHOLDS = {"ant": (3000.0, 4000.0), "humanoid": (5000.0, 8000.0), "inverted_pendulum": (20.0, 50.0)}
JAXPG_PRESETS = {"ant": "ant_fast", "humanoid": "humanoid_fast"}
# Brax's published PPO settings for its Ant and Humanoid (its README and training notebook).
BRAX_PPO = {
    "ant": dict(
        reward_scaling=10.0, unroll_length=5, num_minibatches=32, num_updates_per_batch=4, discounting=0.97,
        learning_rate=3e-4, entropy_cost=1e-2, num_envs=4096, batch_size=2048,
    ),
    "humanoid": dict(
        reward_scaling=0.1, unroll_length=10, num_minibatches=32, num_updates_per_batch=8, discounting=0.97,
        learning_rate=3e-4, entropy_cost=1e-3, num_envs=2048, batch_size=1024,
    ),
}  # fmt: skip
# --quick: the inverted pendulum at tiny sizes, every code path in a minute or two of CPU.
QUICK_BRAX = dict(
    reward_scaling=1.0, unroll_length=8, num_minibatches=2, num_updates_per_batch=1, discounting=0.97,
    learning_rate=3e-4, entropy_cost=1e-2, num_envs=8, batch_size=8,
)  # fmt: skip
QUICK_JAXPG = dict(num_envs=8, horizon=16, num_minibatches=2, num_epochs=1, policy_hidden=(8,), value_hidden=(8,))


@dataclasses.dataclass
class Race:
    """One run's settings: ``suite`` (whose env), ``env``, ``trainer``, ``seed``, the clock
    ``budget`` (s), evaluation episodes and the ratio between evaluation marks."""

    suite: str
    env: str
    trainer: str
    seed: int
    budget: float
    eval_episodes: int
    mark_ratio: float
    quick: bool
    impl: str | None = None

    def jaxpg_task_options(self) -> dict[str, Any]:
        """Options of a jaxpg task in this run: its MJX implementation when one is asked for."""
        return {"impl": self.impl} if self.impl and self.suite == "jaxpg" else {}


class Clock:
    """The training clock: wall time since ``start`` less the time spent in evaluations, and the
    evaluations themselves, each ``(train_s, env_steps, mean_return)``, at marks ``ratio`` apart."""

    def __init__(self, race: Race, evaluate: Any):
        self.race, self.evaluate = race, evaluate
        self.start = time.perf_counter()
        self.excluded = 0.0
        self.next_mark = 1.0
        self.evals: list[tuple[float, int, float]] = []

    def train_s(self) -> float:
        return time.perf_counter() - self.start - self.excluded

    def maybe_evaluate(self, act: Any, params: Any, env_steps: int, last: bool = False) -> bool:
        """Evaluate when the clock passed the next mark (or ``last``); True when the budget is spent."""
        now = self.train_s()
        if now >= self.next_mark or last:
            began = time.perf_counter()
            score = float(self.evaluate(act, params))
            self.evals.append((now, int(env_steps), score))
            self.excluded += time.perf_counter() - began
            self.next_mark = max(now * self.race.mark_ratio, now + 0.5)
            print(f"  {self.race.trainer:5s} seed {self.race.seed} {now:7.1f} s {env_steps:>11,d} steps {score:9.1f}")
        return now >= self.race.budget


def evaluation_task(race: Race) -> envs.Env:
    """The env every policy is scored in: actions in [-1, 1], the task's time limit."""
    name = race.env if race.suite == "jaxpg" else f"brax:{race.env}"
    task = envs.make_task(name, **({"backend": "mjx"} if race.suite == "brax" else race.jaxpg_task_options()))
    return ClipAction(RescaleAction(task))


def make_evaluator(task: envs.Env, episodes: int) -> Any:
    """``evaluate(act, params) -> mean return`` of ``episodes`` fresh episodes (fixed keys)."""
    first = jax.jit(jax.vmap(task.reset))(jax.random.split(jax.random.PRNGKey(12345), episodes))

    @functools.cache
    def compiled(act: Any) -> Any:
        run = functools.partial(episode_totals_from, task, act)
        return jax.jit(
            lambda params: jnp.mean(run(params, first, jax.random.PRNGKey(0), task.max_episode_steps)["return"])
        )

    return lambda act, params: compiled(act)(params)


def train_brax(race: Race, clock_evaluate: Any) -> tuple[Clock, Any]:
    """Brax's PPO on ``race``'s env until the budget; returns the clock and a numpy policy."""
    from brax import envs as brax_envs
    from brax.training.agents.ppo import train as brax_ppo

    from jaxpg.envs import brax_compat, brax_env

    clock = Clock(race, clock_evaluate)  # started before the env is built, as jaxpg's
    if race.suite == "jaxpg":
        # Brax's own time-limit handling (EpisodeWrapper's truncation mask), as on its own envs.
        environment = brax_env.as_brax_env(race.env, time_limit=False, **race.jaxpg_task_options())
        wrap = brax_env.wrap_for_training
    else:
        environment, wrap = brax_envs.get_environment(race.env, backend="mjx"), None
    settings = QUICK_BRAX if race.quick else BRAX_PPO[race.env]
    chunk = settings["num_envs"] * settings["unroll_length"] * 4 if race.quick else 1_000_000
    holder: dict[str, Any] = {}

    class BudgetSpent(Exception):
        pass

    def on_params(step: int, make_policy: Any, params: Any) -> None:
        if "act" not in holder:
            holder["act"] = lambda p, obs, key: (
                make_policy(p, deterministic=True)(obs, key)[0],
                jnp.zeros(obs.shape[:-1]),
            )
        holder["params"] = params
        if clock.maybe_evaluate(holder["act"], params, step):
            raise BudgetSpent

    with brax_compat.brax_jax_shim():
        try:
            brax_ppo.train(
                environment=environment, num_timesteps=chunk * 100_000, num_evals=100_000, episode_length=1000,
                normalize_observations=True, action_repeat=1, seed=race.seed, run_evals=False,
                wrap_env_fn=wrap, policy_params_fn=on_params, **settings,
            )  # fmt: skip
        except BudgetSpent:
            pass
    if clock.evals[-1][0] < race.budget:  # the steps ran out first (only in --quick)
        clock.maybe_evaluate(holder["act"], holder["params"], clock.evals[-1][1], last=True)
    return clock, numpy_policy(holder["act"], holder["params"])


def train_jaxpg(race: Race, clock_evaluate: Any) -> tuple[Clock, Any]:
    """jaxpg's PPO (the env's fast preset) on ``race``'s env until the budget."""
    ppo = algos.get("ppo")
    preset = JAXPG_PRESETS.get(race.env, "ant_fast")
    overrides = {**algos.preset("ppo", preset), **(QUICK_JAXPG if race.quick else {})}
    env_kwargs = algos.preset_env_kwargs("ppo", preset)
    config = ppo.Config(**overrides)
    clock = Clock(race, clock_evaluate)
    name = race.env if race.suite == "jaxpg" else f"brax:{race.env}"
    env = envs.make(name, batch=config.num_envs, **env_kwargs, **race.jaxpg_task_options())
    ts = ppo.init(jax.random.PRNGKey(race.seed), env, config)
    iterations = algos.preset_iterations("ppo", preset) or 100
    block = train_lib.compiled_block(ppo.update, 1 if race.quick else max(1, iterations // 100), seeds=False)
    bounds = config.eval_action_bounds(env)
    low, high = float(env.action_low), float(env.action_high)

    def act(params: Any, obs: jax.Array, key: jax.Array) -> tuple[jax.Array, jax.Array]:
        action, logp = sampling.make_act(ts.policy, params[1], True, clipped_mean_bounds=bounds)(params[0], obs, key)
        return (action - (high + low) / 2) / ((high - low) / 2), logp  # in [-1, 1], as the evaluator's env

    steps = 0
    while True:
        ts, _ = block(ts)
        jax.block_until_ready(ts.params)
        steps = int(ts.iteration) * config.num_envs * config.horizon
        if clock.maybe_evaluate(act, (ts.params, ts.obs_stats), steps):
            break
    return clock, numpy_policy(act, (ts.params, ts.obs_stats))


def numpy_policy(act: Any, params: Any) -> Any:
    """``obs [obs_size] -> action [action_size]`` in [-1, 1], NumPy in and out (one jitted call)."""
    jitted = jax.jit(lambda obs: act(params, obs[None], jax.random.PRNGKey(0))[0][0])
    return lambda obs: np.asarray(jitted(jnp.asarray(obs, jnp.float32)))


def gymnasium_score(race: Race, policy: Any, episodes: int) -> float | None:
    """The final policy's mean return in Gymnasium (jaxpg's tasks only; ``None`` without Gymnasium)."""
    if race.suite != "jaxpg":
        return None
    try:
        from jaxpg.run.evaluation import replay
    except ImportError:
        return None
    task = envs.make_task(race.env)
    low, high = float(task.action_low), float(task.action_high)

    def in_task_units(obs: np.ndarray) -> np.ndarray:
        unit = np.clip(policy(obs.astype(np.float32)), -1.0, 1.0)
        return (high + low) / 2 + (high - low) / 2 * unit

    try:
        returns, _, _ = replay.evaluate_gymnasium(in_task_units, race.env, {}, episodes)
    except ImportError:
        return None
    return float(np.mean(returns))


def run(race: Race, gym_episodes: int) -> dict[str, Any]:
    """Train, score and summarise one run."""
    evaluate = make_evaluator(evaluation_task(race), race.eval_episodes)
    called = time.perf_counter()
    clock, policy = (train_brax if race.trainer == "brax" else train_jaxpg)(race, evaluate)
    thresholds = THRESHOLDS.get(race.env, ())
    first = {str(t): next((i for i, (_, _, r) in enumerate(clock.evals) if r >= t), None) for t in thresholds}
    reached = {t: None if i is None else clock.evals[i][0] for t, i in first.items()}
    # The score was crossed between the evaluation before and this one: its share of the time.
    resolution = {t: None if not i else 1.0 - clock.evals[i - 1][0] / clock.evals[i][0] for t, i in first.items()}
    return {
        **dataclasses.asdict(race),
        "evals": clock.evals,
        "time_to": reached,
        "time_to_resolution": resolution,
        # The last evaluation: at the first chunk's end past the budget (its clock time beside it).
        "score_at_budget": clock.evals[-1][2],
        "final_train_s": clock.evals[-1][0],
        "gymnasium_score": gymnasium_score(race, policy, gym_episodes),
        "process_start_to_trainer_s": called - PROCESS_START,
        "device": str(jax.devices()[0].device_kind),
    }


def median_or_none(values: list[float | None]) -> str:
    got = [v for v in values if v is not None]
    if not got:
        return "-"
    text = f"{np.median(got):.0f}"
    return text if len(got) == len(values) else f"{text} ({len(got)}/{len(values)})"


def table(records: list[dict[str, Any]]) -> str:
    """Per suite, env and trainer: median time to each threshold over seeds (s of training clock;
    "(k/n)" where only k of n seeds reached it), the largest share of such a time that falls
    between two evaluations, the median score at the budget (the clock range of those last
    evaluations under "budget"), and in Gymnasium."""
    groups: dict[tuple, list[dict]] = {}
    for r in records:
        groups.setdefault((r["suite"], r["env"], r["trainer"]), []).append(r)
    lines = [
        "| suite | env | trainer | seeds | time to score (s) | resolved to | score at budget | Gymnasium | budget (s) |"
    ]
    lines.append("|---|---|---|---|---|---|---|---|---|")
    for (suite, env, trainer), rs in sorted(groups.items()):
        times = ", ".join(f"{t}: {median_or_none([r['time_to'][t] for r in rs])}" for t in rs[0]["time_to"])
        budget = f"{min(r['budget'] for r in rs):.0f}-{max(r['final_train_s'] for r in rs):.0f}"
        gym = median_or_none([r["gymnasium_score"] for r in rs])
        at = median_or_none([r["score_at_budget"] for r in rs])
        shares = [v for r in rs for v in r.get("time_to_resolution", {}).values() if v is not None]
        resolved = f"{100 * max(shares):.0f} %" if shares else "-"
        lines.append(f"| {suite} | {env} | {trainer} | {len(rs)} | {times} | {resolved} | {at} | {gym} | {budget} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--suite", nargs="+", choices=("jaxpg", "brax"), default=["jaxpg", "brax"])
    parser.add_argument("--env", nargs="+", choices=("ant", "humanoid"), default=["ant", "humanoid"])
    parser.add_argument("--trainer", nargs="+", choices=("brax", "jaxpg"), default=["brax", "jaxpg"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--budget", type=float, default=240.0, help="training-clock seconds per run")
    parser.add_argument("--eval-episodes", type=int, default=128)
    parser.add_argument("--gym-episodes", type=int, default=10, help="Gymnasium replays of each final policy")
    parser.add_argument("--mark-ratio", type=float, default=1.08, help="clock ratio between evaluations")
    parser.add_argument(
        "--impl", choices=("jax", "warp"), help="MJX implementation of jaxpg's tasks (default: jaxpg's)"
    )
    parser.add_argument("--json", help="write the runs here (and print the table)")
    parser.add_argument("--table", nargs="+", metavar="JSON", help="only print one table from these files")
    parser.add_argument("--quick", action="store_true", help="CPU smoke test: the inverted pendulum, tiny sizes")
    args = parser.parse_args(argv)
    if args.table:
        records = [r for path in args.table for r in json.loads(Path(path).read_text())["runs"]]
        print(table(records))
        return 0
    if args.budget <= 0 or args.eval_episodes < 1 or args.mark_ratio <= 1.0:
        print("error: --budget and --eval-episodes must be positive and --mark-ratio above 1", file=sys.stderr)
        return 2
    env_names = ["inverted_pendulum"] if args.quick else args.env
    if args.quick:
        args.budget, args.eval_episodes, args.gym_episodes = min(args.budget, 45.0), 4, 1
    records = []
    for suite in args.suite:
        for env in env_names:
            for trainer in args.trainer:
                for seed in args.seeds:
                    race = Race(
                        suite,
                        env,
                        trainer,
                        seed,
                        args.budget,
                        args.eval_episodes,
                        args.mark_ratio,
                        args.quick,
                        args.impl,
                    )
                    print(f"{suite} suite, {env}, {trainer}, seed {seed}", flush=True)
                    records.append(run(race, args.gym_episodes))
                    if args.json:  # after every run: a later one may not finish within the call
                        Path(args.json).write_text(json.dumps({"runs": records}, indent=1))
    print(table(records))
    return 0


if __name__ == "__main__":
    sys.exit(main())
