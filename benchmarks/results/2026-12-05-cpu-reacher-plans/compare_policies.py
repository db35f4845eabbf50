"""The trained policies of eval40.log against the best plan found per episode in the planners' logs, and the
best return known per episode (the better of every plan and every policy: each is a sequence of actions that
reaches it). usage: python compare_policies.py EVAL_LOG PLAN_LOG [PLAN_LOG ...]"""

import ast
import re
import sys

import numpy as np

plans: dict[int, float] = {}
for path in sys.argv[2:]:
    for line in open(path):
        m = re.match(r"reset seed (\d+): (?:plan|Gymnasium) (-?[\d.]+)", line)
        if m:
            plans[int(m[1])] = max(plans.get(int(m[1]), -np.inf), float(m[2]))
policies = {}
for line in open(sys.argv[1]):
    m = re.match(r"(\S+) seed (\d+): mean .* over \d+ episodes \((\d+)-(\d+)\); returns (\[.*\])", line)
    if m:
        policies[f"{m[1]} seed {m[2]}"] = (int(m[3]), np.array(ast.literal_eval(m[5])))
first = next(iter(policies.values()))[0]
seeds = range(first, first + len(next(iter(policies.values()))[1]))
plan = np.array([plans[s] for s in seeds])
known = np.max([plan, *[rets for _, rets in policies.values()]], axis=0)
print(f"{len(plan)} episodes (reset seeds {seeds[0]}-{seeds[-1]}), Gymnasium Reacher-v5:")
print(f"  best plan found per episode: mean {plan.mean():.3f}")
print(
    f"  best return known per episode (plans and policies): mean {known.mean():.3f} "
    f"+- {known.std(ddof=1) / np.sqrt(len(known)):.3f}"
)
for name, (_, rets) in policies.items():
    beats = rets > plan + 1e-4
    print(
        f"  {name:22s} mean {rets.mean():.3f}, below the best known by {known.mean() - rets.mean():.3f}; "
        f"better than the best plan in {int(beats.sum())} episodes "
        f"(by up to {max(0.0, float(np.max(rets - plan))):.3f})"
    )
