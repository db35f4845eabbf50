"""``suite.py count``: how many seeds of each setting reached a Gymnasium score."""

from __future__ import annotations

import argparse
import statistics
from collections.abc import Sequence

import harness

from suite_modes.verdicts import score_text

RAW = argparse.RawDescriptionHelpFormatter


COUNT_DOC = """How many seeds of each setting reached a Gymnasium score, over ``run --json`` files.

A setting is a TASK:ALGO:PRESET with the ``--extra`` flags its runs were given; a seed that two
files both hold is counted once (the later file's). Prints one row per setting: seeds, how many
scored at or above ``--bar``, the share below it, the lowest and the median, and the seeds below.

    python benchmarks/suite.py count results/*.json --bar 3000
"""


def tally(rows: Sequence[dict], bar: float) -> list[dict]:
    """One entry per setting (TASK:ALGO:PRESET and its extra flags) of the scored ``rows``: its
    seeds, how many scored at least ``bar``, the lowest and the median score, the seeds below."""
    settings: dict[tuple[str, str], dict[int, float]] = {}
    for row in rows:
        if row.get("gymnasium_return") is None:
            continue
        setting = (f"{row['task']}:{row['algo']}:{row['preset']}", " ".join(row.get("extra", [])))
        settings.setdefault(setting, {})[row["seed"]] = row["gymnasium_return"]
    out = []
    for (run, extra), scores in settings.items():
        values = list(scores.values())
        below = sorted((seed for seed, score in scores.items() if score < bar), key=scores.__getitem__)
        out.append(
            {
                "run": run,
                "extra": extra,
                "seeds": len(values),
                "reached": len(values) - len(below),
                "lowest": min(values),
                "median": statistics.median(values),
                "below": [(seed, scores[seed]) for seed in below],
            }
        )
    return out


def count_main(argv: Sequence[str]) -> None:
    parser = argparse.ArgumentParser(prog="suite.py count", description=COUNT_DOC, formatter_class=RAW)
    parser.add_argument("files", nargs="+")
    parser.add_argument("--bar", type=float, required=True, help="the score a seed must reach")
    args = parser.parse_args(argv)
    entries = tally([row for path in args.files for row in harness.rows_of(path)], args.bar)
    print(
        harness.table(
            entries,
            [
                ("task:algo:preset", lambda e: e["run"]),
                ("extra flags", lambda e: e["extra"] or "-"),
                ("seeds", lambda e: e["seeds"]),
                (f">= {args.bar:g}", lambda e: e["reached"]),
                ("below", lambda e: f"{100 * (1 - e['reached'] / e['seeds']):.1f} %"),
                ("lowest", lambda e: score_text(e["lowest"])),
                ("median", lambda e: score_text(e["median"])),
                ("seeds below (score)", lambda e: ", ".join(f"{s} ({score_text(v)})" for s, v in e["below"]) or "-"),
            ],
        )
    )
