"""The results tables of README.md and BENCHMARKS.md are what ``benchmarks/tables.py`` generates
from the records under ``benchmarks/results/``, and the records hold what their raw outputs say.

* The pages as committed match their records (``python benchmarks/tables.py --check``).
* A figure edited by hand in a generated table, a record whose table does not exist, and a table
  whose region was removed from its page each fail the check.
* Every record names its hardware, command, commit, date and source; a source that is not the
  earlier text names a raw file beside the record that exists.
* The figures of records read from JSON (the card command's runs, the 1 M presets' replays in
  Gymnasium, the throughput runs) equal those files' own numbers, read here independently of the
  script.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from script_loader import load_script

ROOT = Path(__file__).resolve().parents[1]
tables = load_script("benchmarks/tables.py")
PAGES = ("README.md", "BENCHMARKS.md")


def pages() -> dict[str, str]:
    return {name: (ROOT / name).read_text() for name in PAGES}


@pytest.fixture(scope="module")
def records() -> list[dict]:
    return tables.load_records()


def test_pages_match_their_records(records):
    assert tables.problems(records, pages()) == []


def test_the_check_runs_from_the_command_line():
    done = subprocess.run(
        [sys.executable, "benchmarks/tables.py", "--check"], cwd=ROOT, capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr


def test_a_hand_edited_figure_fails(records):
    text = pages()
    region = re.search(r"<!-- table:readme -->\n(.*?)<!-- /table -->", text["README.md"], flags=re.S).group(1)
    line = next(line for line in region.splitlines() if "**" in line and re.search(r"\d", line))
    edited = re.sub(r"\d", lambda m: str((int(m.group(0)) + 1) % 10), line, count=1)
    text["README.md"] = text["README.md"].replace(line, edited)
    found = tables.problems(records, text)
    assert found and "table readme differs" in found[0]


def test_a_record_without_its_table_fails(records):
    stray = {**records[0], "id": "stray", "table": "no_such_table"}
    found = tables.problems([*records, stray], pages())
    assert any("names no table (no_such_table)" in line for line in found), found


def test_a_table_removed_from_its_page_fails(records):
    text = pages()
    text["BENCHMARKS.md"] = re.sub(r"<!-- table:scaling -->.*?<!-- /table -->\n", "", text["BENCHMARKS.md"], flags=re.S)
    assert any("0 regions of table scaling" in line for line in tables.problems(records, text))


def test_every_table_has_records_and_every_record_says_where_it_came_from(records):
    assert {r["table"] for r in records} == set(tables.TABLES)
    for record in records:
        for key in ("hardware", "command", "commit", "date", "source"):
            assert record[key], (record["id"], key)
        assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", record["date"]), record["id"]
        if record["source"].startswith(("transcribed from", "BENCHMARKS.md at")):
            continue
        folder = (ROOT / record["path"]).parent
        first = record["source"].split()[0].rstrip(":;,")
        assert list(folder.glob(first)), f"{record['id']}: {first} not in {folder}"


def by_id(records: list[dict]) -> dict[str, dict]:
    return {r["id"]: r for r in records}


def test_the_card_records_hold_their_raw_runs(records):
    folder = ROOT / "benchmarks/results/2026-12-05-h100c/host2"
    raw = {}
    for path in [*folder.glob("card_bare*.json"), *folder.glob("new_warm*.json")]:
        for row in json.loads(path.read_text())["rows"]:
            raw[(row["mode"], row["seed"])] = (row["wall_s"], row["gymnasium_return"])
    records = by_id(records)
    for record_id, mode in (("card_bare", "cold"), ("card_warm", "warm")):
        runs = records[record_id]["seeds"]["runs"]
        assert {(mode, run["seed"]) for run in runs} == {key for key in raw if key[0] == mode}
        for run in runs:
            wall_s, gymnasium = raw[(mode, run["seed"])]
            assert run["wall_s"] == pytest.approx(wall_s, abs=0.005)  # recorded to 0.01 s
            assert run["gymnasium"] == gymnasium


@pytest.mark.parametrize(
    ("record_id", "raw"),
    [
        ("m1_half_cheetah", "2026-12-05-h100e/rest/physics_half_cheetah.json"),
        ("m1_swimmer", "2026-12-05-h100e/rest/physics_swimmer.json"),
        ("m1_reacher", "2026-12-05-h100e/rest/physics_reacher.json"),
        ("m1_pusher", "2026-12-05-h100e/rest/physics_pusher.json"),
        ("m1_ant", "2026-12-05-h100f/ant_anneal/physics_ant.json"),
        ("m1_humanoid", "2026-12-05-h100d/a2c/physics_humanoid.json"),
    ],
)
def test_the_1m_records_hold_their_gymnasium_replays(records, record_id, raw):
    rows = json.loads((ROOT / "benchmarks/results" / raw).read_text())["rows"]
    runs = by_id(records)[record_id]["seeds"]["runs"]
    assert [run["seed"] for run in runs] == [row["seed"] for row in rows]
    for run, row in zip(runs, rows, strict=True):
        assert run["gymnasium"] == pytest.approx(sum(row["returns"]) / len(row["returns"]), abs=0.005)


def test_medians_are_computed_from_the_runs():
    """A group's median, range and count come from its runs (statistics by hand), and runs that
    name their caches form a group of that name."""
    record = {
        "hardware": "h",
        "date": "2026-01-01",
        "values": {"envs": 256},
        "seeds": {"runs": [{"x": 3.0, "caches": "warm"}, {"x": 1.0, "caches": "bare"}, {"x": 2.0, "caches": "warm"}]},
    }
    fields = tables.fields(record)
    assert fields["runs_median_x"] == 2.0 and fields["runs_min_x"] == 1.0 and fields["runs_max_x"] == 3.0
    assert fields["warm_median_x"] == 2.5 and fields["bare_n"] == 1
    assert format(fields["runs_x"], ".1f") == "3.0, 1.0, 2.0"
    assert format(fields["runs_range_x"], ".0f") == "1-3" and format(fields["bare_range_x"], ".0f") == "1"
    assert f"{fields['envs']}" == "256" and format(tables.Num(-28.744), "r") == "-28.74"


def test_the_throughput_records_hold_their_raw_rates(records):
    """Training against raw simulation, the suite's env throughput and several GPUs: each record's
    rates are its JSON's own."""
    records = by_id(records)
    raw = json.loads((ROOT / "benchmarks/results/2026-11-24-h100e/machine3/ratio_a.json").read_text())
    for row in raw:
        values = records[f"train_raw_{row['num_envs']}"]["values"]
        assert (values["raw"], values["train"]) == (row["raw_steps_per_s"], row["train_steps_per_s"])
    suite = json.loads((ROOT / "benchmarks/results/2026-11-27-h200x4b/suite_env/env_second.json").read_text())
    for row in suite["rows"]:
        key = "4" if row["envs"] == 4096 else "16"
        values = records[f"suite_env_{row['task']}"]["values"]
        assert values[f"raw{key}"] == row["results"]["raw"]["steps_per_s"], row["task"]
        assert values[f"env{key}"] == row["results"]["env"]["steps_per_s"], row["task"]
    scaling = json.loads((ROOT / "benchmarks/results/2026-11-22-h200x2/scaling_warp_gspmd.json").read_text())
    for row in scaling:
        values = records[f"scaling_{row['devices']}"]["values"]
        assert (values["train"], values["efficiency"]) == (row["train_steps_per_s"], row["train_efficiency"])


@pytest.mark.parametrize("task", ["ant", "humanoid"])
def test_the_deviation_records_hold_their_replays(records, task):
    """The 50-episode replays in jaxpg and in Gymnasium: the records' means and stds are the logs',
    the difference is jaxpg's minus Gymnasium's and its standard error that of two independent
    means of 50 episodes."""
    folder = ROOT / "benchmarks/results/2026-11-25-h100c"
    logged = {}
    for side in ("jaxpg", "gym"):
        text = (folder / f"{task}_eval50_{side}.log").read_text()
        mean, std = re.findall(r"return: ([-\d.]+) ± ([\d.]+)", text)[-1]
        logged[side] = (float(mean), float(std))
    values = by_id(records)[f"deviation_{task}"]["values"]
    assert (values["jaxpg_mean"], values["jaxpg_std"]) == logged["jaxpg"]
    assert (values["gym_mean"], values["gym_std"]) == logged["gym"]
    assert values["difference"] == pytest.approx(logged["jaxpg"][0] - logged["gym"][0])
    assert values["standard_error"] == pytest.approx(((logged["jaxpg"][1] ** 2 + logged["gym"][1] ** 2) / 50) ** 0.5)
