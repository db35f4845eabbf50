"""``benchmarks/pong.py --plot`` and ``--compare-envs``: running reward against wall clock, a line per run."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path


def plot(runs: Sequence[dict], out: str | Path, title: str) -> None:
    """Running reward against wall clock, one line per run (a colour per setting), into ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    settings = sorted({(r["num_envs"], r.get("horizon", 8), r.get("lr", 1e-3), r.get("algo", "a2c")) for r in runs})
    cmap = plt.get_cmap("viridis") if len(settings) > 10 else None
    colors = (
        dict(zip(settings, cmap([i / max(len(settings) - 1, 1) for i in range(len(settings))]), strict=True))
        if cmap
        else dict(zip(settings, plt.get_cmap("tab10").colors, strict=False))
    )
    fig, ax = plt.subplots(figsize=(8, 4.5))
    labelled = set()
    for run in runs:
        key = (run["num_envs"], run.get("horizon", 8), run.get("lr", 1e-3), run.get("algo", "a2c"))
        envs = f"{key[0]} env{'s' if key[0] > 1 else ''}"
        label = None if key in labelled else f"{key[3].upper()}, {envs}, horizon {key[1]}, lr {key[2]:g}"
        labelled.add(key)
        t = [row["wall_s"] for row in run["curve"]]
        reward = [math.nan if row["running_reward"] is None else row["running_reward"] for row in run["curve"]]
        ax.plot(t, reward, color=colors.get(key), lw=1.2, label=label)
    ax.axhline(0.0, color="k", lw=0.8, ls="--")
    ax.axhline(10.0, color="k", lw=0.8, ls=":")
    ax.set_xlabel("wall-clock seconds (compilation excluded)")
    ax.set_ylabel("running reward (EMA of game score)")
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def plot_files(json_paths: Sequence[str], out: str) -> None:
    """``plot`` of every run in earlier ``--json`` files (e.g. one file per number of envs)."""
    runs, device, task = [], "", "pong"
    for path in json_paths:
        with open(path) as f:
            result = json.load(f)
        runs += result["beat"]
        device, task = result["device"], result.get("task", "pong")
    game = "jaxpg Pong from frame differences" if task == "pong" else "Atari Pong (ALE)"
    plot(runs, out, f"{game}, {device}: one line per run (seed)")


# ---------------------------------------------------------------------------------------------
