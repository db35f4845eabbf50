"""The results tables of README.md and BENCHMARKS.md, generated from the records under ``benchmarks/results/``.

A record is one row of one table: a JSON object in a ``records.json`` list beside the raw outputs it was
read from. It names its ``table``, the ``hardware``, the exact ``command``, the ``commit`` of the code
that ran, the ``date``, its ``source`` (the raw files it was read from, or the earlier text it was
transcribed from) and its figures: ``values`` (one figure each) and ``seeds`` (groups of per-run
figures, from which medians and ranges are computed here, never typed).

What each table shows (its columns, as templates over a record's fields) is in ``benchmarks/tables.toml``.
Each table lives between ``<!-- table:NAME -->`` and ``<!-- /table -->`` in README.md or BENCHMARKS.md:

    python benchmarks/tables.py           # rewrite every table region from the records
    python benchmarks/tables.py --check   # exit 1 if a region differs, or a record names no table

``tests/test_results_tables.py`` runs the check, so a hand-edited figure, or a record whose table is
missing, fails the tests.
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import sys
import tomllib
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
LAYOUTS = Path(__file__).with_name("tables.toml")
REGION = re.compile(r"(<!-- table:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /table -->)", flags=re.S)
REQUIRED = ("id", "table", "hardware", "command", "commit", "date", "source")


class Seq(tuple):
    """Per-run figures that format element by element, joined with ", " (``{warm_wall_s:.1f}``)."""

    def __format__(self, spec: str) -> str:
        return ", ".join(format(value, spec) for value in self)


class Table(NamedTuple):
    """A generated table: the Markdown file it lives in, its columns (each a header and a
    ``str.format`` template over a record's fields, ``fields``) and the fields a record may lack,
    shown as "-"."""

    page: str
    columns: tuple[tuple[str, str], ...]
    optional: tuple[str, ...] = ()


class Dash:
    """An optional field a record lacks: "-" whatever the spec."""

    def __format__(self, spec: str) -> str:
        return "-"


class ReadmeRow(NamedTuple):
    """One row of the README's table: what was measured, the record that holds it, the result
    cell's template over that record's fields, and the BENCHMARKS.md section with the rest."""

    what: str
    record: str
    result: str
    section: str


def load_records(results: Path = RESULTS) -> list[dict]:
    """Every record of every ``records.json`` under ``results``, each with ``path`` (its file,
    relative to the repository root) added; a record missing a required key raises."""
    records = []
    for path in sorted(results.rglob("records.json")):
        for record in json.loads(path.read_text()):
            missing = [key for key in REQUIRED if key not in record]
            if missing:
                raise ValueError(f"{path}: record {record.get('id')!r} lacks {missing}")
            records.append({**record, "path": path.relative_to(ROOT).as_posix()})
    ids = [record["id"] for record in records]
    repeated = sorted({i for i in ids if ids.count(i) > 1})
    if repeated:
        raise ValueError(f"record ids used twice: {repeated}")
    return records


class Range(NamedTuple):
    """The least and greatest of some figures, formatting as "low-high", or once where the spec
    prints both alike (``{warm_range_wall_s:.0f}``)."""

    low: float
    high: float

    def __format__(self, spec: str) -> str:
        low, high = format(self.low, spec), format(self.high, spec)
        return low if low == high else f"{low}-{high}"


class Num(float):
    """A figure that also formats with the spec ``r`` (whole numbers from 100 up, two decimals below)
    and ``rate`` (steps/s in M or k), and without a spec as it was recorded (``256``, not ``256.0``,
    for a whole number)."""

    whole: bool = False

    def __new__(cls, value: float) -> Num:
        number = super().__new__(cls, value)
        number.whole = isinstance(value, int)
        return number

    def __format__(self, spec: str) -> str:
        if spec == "" and self.whole:
            return str(int(self))
        if spec == "rate":  # steps/s: "2275 M", "4.78 M", "747 k", "4.5 k"
            if self >= 1e8:
                return f"{self / 1e6:.0f} M"
            if self >= 1e6:
                return f"{self / 1e6:.2f} M"
            return f"{self / 1e3:.0f} k" if self >= 1e4 else f"{self / 1e3:.1f} k"
        if spec == "r":
            spec = ".0f" if abs(self) >= 100 else ".2f"
        return format(float(self), spec)


def as_num(value: object) -> object:
    return Num(value) if isinstance(value, int | float) and not isinstance(value, bool) else value


def group_fields(group: str, runs: list[dict]) -> dict:
    """``G_n`` and, for each figure ``K`` of the runs, ``G_K`` (a ``Seq`` of every run's that has
    it) and, where numeric, ``G_median_K``, ``G_min_K``, ``G_max_K`` and ``G_range_K``."""
    out: dict = {f"{group}_n": len(runs)}
    for key in sorted({k for run in runs for k in run}):
        present = [as_num(run[key]) for run in runs if run.get(key) is not None]
        out[f"{group}_{key}"] = Seq(present)
        if present and all(isinstance(v, Num) for v in present):
            out[f"{group}_median_{key}"] = Num(statistics.median(present))
            out[f"{group}_min_{key}"] = min(present)
            out[f"{group}_max_{key}"] = max(present)
            out[f"{group}_range_{key}"] = Range(min(present), max(present))
    return out


def fields(record: dict) -> dict:
    """What a template may name: the record's ``values``, ``hardware`` and ``date``, its ``ratios``
    (``{name: [numerator, denominator]}`` of two values, computed here), and for each
    group ``G`` of its ``seeds`` the fields of ``group_fields``. Runs that name their ``caches``
    (``warm``, ``bare``) also form a group of that name, unless the record has one already."""
    out = {"hardware": record["hardware"], "date": record["date"]}
    out.update({key: as_num(value) for key, value in record.get("values", {}).items()})
    for key, (numerator, denominator) in record.get("ratios", {}).items():
        out[key] = Num(out[numerator] / out[denominator])
    groups = dict(record.get("seeds", {}))
    for runs in list(groups.values()):
        for caches in sorted({run["caches"] for run in runs if "caches" in run}):
            groups.setdefault(caches, [run for run in runs if run.get("caches") == caches])
    for group, runs in groups.items():
        out.update(group_fields(group, runs))
    return out


def anchor(heading: str) -> str:
    """GitHub's anchor of a Markdown heading (``The card command`` -> ``the-card-command``)."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def row(cells: list[str]) -> str:
    return "| " + " | ".join(cells) + " |"


def render_table(table: Table, records: list[dict]) -> str:
    """The Markdown of one table: its columns, then the hardware, the date and a link to the
    record file, one row per record in ``order``."""
    headers = [header for header, _ in table.columns] + ["hardware", "date", "record"]
    lines = [row(headers), row(["---"] * len(headers))]
    for record in sorted(records, key=lambda r: r.get("order", 0)):
        values = {**dict.fromkeys(table.optional, Dash()), **fields(record)}
        cells = [template.format(**values) for _, template in table.columns]
        link = f"[{Path(record['path']).parent.name}]({record['path']})"
        lines.append(row([*cells, record["hardware"], record["date"], link]))
    return "\n".join(lines) + "\n"


def render_readme(records: list[dict]) -> str:
    """The README's one results table; a row's result cell may name any record's fields by its id
    (``{card_warm[runs_median_wall_s]:.1f}``)."""
    by_id = {record["id"]: record for record in records}
    every = {record_id: fields(record) for record_id, record in by_id.items()}
    lines = [row(["what", "hardware", "result", "more"]), row(["---"] * 4)]
    for item in README_ROWS:
        link = f"[{item.section}](BENCHMARKS.md#{anchor(item.section)})"
        lines.append(row([item.what, by_id[item.record]["hardware"], item.result.format(**every), link]))
    return "\n".join(lines) + "\n"


def rendered(records: list[dict]) -> dict[str, str]:
    """``{table name: Markdown}`` for every table, the README's ``readme`` among them."""
    out = {"readme": render_readme(records)}
    for name, table in TABLES.items():
        out[name] = render_table(table, [r for r in records if r["table"] == name])
    return out


def problems(records: list[dict], pages: dict[str, str]) -> list[str]:
    """What is wrong between the records and the pages' text (``{page: text}``): a record whose
    table does not exist, a table without records, a table missing from its page, a region that is
    not what its records give."""
    found = []
    for record in records:
        if record["table"] not in TABLES:
            found.append(f"{record['path']}: record {record['id']} names no table ({record['table']})")
    for name in TABLES:
        if not any(r["table"] == name for r in records):
            found.append(f"table {name} has no record")
    expected = rendered(records)
    page_of = {"readme": "README.md", **{name: table.page for name, table in TABLES.items()}}
    for name, body in expected.items():
        regions = [m for m in REGION.finditer(pages[page_of[name]]) if m.group("name") == name]
        if len(regions) != 1:
            found.append(f"{page_of[name]}: {len(regions)} regions of table {name}, not 1")
        elif regions[0].group("body") != body:
            found.append(f"{page_of[name]}: table {name} differs from its records (python benchmarks/tables.py)")
    for page, text in pages.items():
        for match in REGION.finditer(text):
            if match.group("name") not in page_of:
                found.append(f"{page}: region of unknown table {match.group('name')}")
    return found


def rewrite(text: str, tables: dict[str, str]) -> str:
    """``text`` with every known table region's body replaced by its Markdown."""

    def replace(match: re.Match) -> str:
        body = tables.get(match.group("name"), match.group("body"))
        return match.group(1) + body + match.group(4)

    return REGION.sub(replace, text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--check", action="store_true", help="only check; exit 1 if anything differs")
    args = parser.parse_args(argv)
    records = load_records()
    pages = {name: (ROOT / name).read_text() for name in ("README.md", "BENCHMARKS.md")}
    if not args.check:
        tables = rendered(records)
        for name, text in pages.items():
            (ROOT / name).write_text(rewrite(text, tables))
        pages = {name: (ROOT / name).read_text() for name in pages}
    found = problems(records, pages)
    for line in found:
        print(f"error: {line}", file=sys.stderr)
    return 1 if found else 0


def load_layouts(path: Path = LAYOUTS) -> tuple[dict[str, Table], tuple[ReadmeRow, ...]]:
    """The tables' layouts (``tables.toml``): ``{name: Table}`` and the README's rows."""
    data = tomllib.loads(path.read_text())
    layouts = {
        name: Table(spec["page"], tuple(tuple(column) for column in spec["columns"]), tuple(spec.get("optional", ())))
        for name, spec in data["tables"].items()
    }
    return layouts, tuple(ReadmeRow(**item) for item in data["readme"])


TABLES, README_ROWS = load_layouts()


if __name__ == "__main__":
    sys.exit(main())
