"""Merge the planners' logs: per reset seed the best plan found by any run (each replayed in Gymnasium), the
trained policy's closed-loop return, then what Tianshou's metric (the highest point of a 10-seed mean curve,
10 test episodes per seed per point) adds to a flat curve of either, by simulation."""

import re
import sys

import numpy as np

best, policy, start = {}, {}, {}
for path in sys.argv[1:]:
    for line in open(path):
        m = re.match(r"reset seed (\d+): (?:plan|Gymnasium) (-?[\d.]+)", line)
        if not m:
            continue
        sd, ret = int(m[1]), float(m[2])
        best[sd] = max(best.get(sd, -np.inf), ret)
        p = re.search(r"policy (-?[\d.]+)", line)
        if p and sd not in policy:
            policy[sd] = float(p[1])
        d = re.search(r"start distance ([\d.]+)", line)
        if d:
            start[sd] = float(d[1])
seeds = sorted(policy)
b = np.array([best[s] for s in seeds])
p = np.array([policy[s] for s in seeds])
d0 = np.array([start[s] for s in seeds])
print(f"{len(seeds)} episodes (reset seeds {seeds[0]}-{seeds[-1]}), Gymnasium Reacher-v5 returns:")
print(
    f"  trained policy (TRPO reacher_1m, seed 0), closed loop: mean {p.mean():.3f} "
    f"+- {p.std(ddof=1) / np.sqrt(len(p)):.3f} (episode std {p.std(ddof=1):.2f})"
)
print(
    f"  best open-loop plan found per episode:                mean {b.mean():.3f} "
    f"+- {b.std(ddof=1) / np.sqrt(len(b)):.3f} (episode std {b.std(ddof=1):.2f})"
)
print(
    f"  plan minus policy: mean {np.mean(b - p):.3f}, per episode {np.min(b - p):.3f} to {np.max(b - p):.3f}; "
    f"plans better in {np.sum(b > p + 1e-3)} of {len(p)}"
)
print(
    f"  mean start distance {d0.mean():.3f}: Reacher-v2 (distance before each step) would count each "
    "about that much lower"
)
rng = np.random.default_rng(0)
for name, x in (("policy", p), ("plans", b)):
    for points in (50, 100, 200):
        maxima = [np.max(rng.choice(x, (points, 100)).mean(axis=1)) for _ in range(2000)]
        print(
            f"  highest of {points} points of a flat curve, each the mean of 10 seeds x 10 episodes ({name}): "
            f"{np.mean(maxima) - x.mean():+.3f} over its mean (5-95 %: {np.percentile(maxima, 5) - x.mean():+.3f} "
            f"to {np.percentile(maxima, 95) - x.mean():+.3f})"
        )
