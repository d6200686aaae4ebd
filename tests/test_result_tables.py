"""One source for every reported number: the README's and docs/' result tables are the rendering of
the reproduction summary committed beside them (docs/reproduction.json), and the reproduction's
report groups the runs of one setting over its seeds.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from dmprs.cli import main
from dmprs.errors import InvalidInputError
from dmprs.reproduce.check import ReproductionMismatchError, check_summary, first_difference
from dmprs.reproduce.report import summarize
from dmprs.reproduce.stats import cell, trial_stats
from dmprs.reproduce.tables import (
    BEGIN,
    END,
    QUICK_SUMMARY_PATH,
    SUMMARY_PATH,
    TABLES,
    documents,
    render,
    update_docs,
)

ROOT = Path(__file__).resolve().parents[1]


def committed_summary() -> dict:
    return json.loads((ROOT / SUMMARY_PATH).read_text())


def test_every_generated_table_matches_the_committed_summary():
    summary = committed_summary()
    assert not summary["quick"], "the docs must cite a full reproduction"
    found = set()
    for path in documents(ROOT):
        text = path.read_text()
        for name in TABLES:
            if BEGIN.format(name=name) in text:
                found.add(name)
        assert render(text, summary) == text, (
            f"{path.relative_to(ROOT)}: a generated table differs from {SUMMARY_PATH}; run "
            "`dmprs reproduce --update-docs .` (or dmprs.reproduce.tables.update_docs with the summary)")
    assert found == set(TABLES), f"tables no document holds: {set(TABLES) - found}"


def _refuse(token: str) -> float:
    raise ValueError(f"{token} is not JSON")


def test_the_committed_summary_is_strict_json():
    # Python's json writes NaN and Infinity as bare tokens, which other JSON readers refuse
    json.loads((ROOT / SUMMARY_PATH).read_text(), parse_constant=_refuse)


@pytest.mark.parametrize(("values", "median", "shown"), [
    ([3, 5, 4], 4, "4 [3-5]"),
    ([3, None, 5], 5, "5 [3-5], 2/3 succeeded"),
    ([3, None, None], None, ">9 [3-3], 1/3 succeeded"),
    ([2, 3, None, None], None, ">9 [2-3], 2/4 succeeded"),
    ([None, None], None, "none within 9"),
])
def test_a_median_beyond_the_cap_is_none_and_shown_as_more_than_the_cap(values, median, shown):
    stats = trial_stats(values, budget=9)
    assert stats["median"] == median
    assert cell(stats) == shown
    json.dumps(stats, allow_nan=False)


def test_the_readme_states_the_arms_spread_over_liquids():
    summary = committed_summary()
    arm = [r for r in summary["rows"] if r["part"] == "arm_pouring"]
    assert arm and all(r["runs"] >= 5 for r in arm)
    assert all(len(r["per_run"]) == r["runs"] for r in arm)
    # every arm cell of the README is a median with its range over the liquids
    table = TABLES["readme"](summary)
    for r in arm:
        assert cell(r) in table
        assert "[" in cell(r) or r["successes"] == 0


def _learn(part: str, learner: str, setup: dict, trials_to_success: int | None, poured: float = 0.25) -> dict:
    return {"kind": "learn", "part": part, "experiment": "arm-pouring", "setup": setup, "learner": learner,
            "converged": trials_to_success is not None, "trials_to_success": trials_to_success,
            "n_trials": trials_to_success or 6, "stop_reason": None if trials_to_success else "max_trials",
            "trials": [{"signals": {"poured_volume": poured, "note": "x"}}]}


def test_runs_that_differ_only_in_the_liquid_are_one_row_with_median_range_and_successes():
    runs = [_learn("arm_pouring", "golden", {"bottle_volume": 0.5, "liquid_seed": s}, t, 0.2 + s / 100)
            for s, t in enumerate([3, 5, None, 2, 4])]
    runs.append(_learn("arm_pouring", "golden", {"bottle_volume": 0.6, "liquid_seed": 0}, 1))
    rows = summarize(runs)["rows"]
    assert len(rows) == 2
    row = rows[0]
    assert row["setting"] == {"bottle_volume": 0.5}
    assert (row["runs"], row["successes"], row["min"], row["max"], row["median"]) == (5, 4, 2, 5, 4)
    assert [p["seeds"] for p in row["per_run"]] == [{"liquid_seed": s} for s in range(5)]
    assert [p["first_signals"] for p in row["per_run"]][2] == {"poured_volume": 0.22}
    assert cell(row) == "4 [2-5], 4/5 succeeded"
    assert cell(rows[1]) == "1"


def test_update_docs_rewrites_only_the_marked_blocks_and_stores_the_summary(tmp_path):
    summary = committed_summary()
    readme = tmp_path / "README.md"
    prose = "Text before.\n\n"
    readme.write_text(f"{prose}{BEGIN.format(name='readme')}\nstale\n{END}\n\nText after.\n")
    (tmp_path / "docs").mkdir()
    untouched = tmp_path / "docs" / "other.md"
    untouched.write_text("no tables here\n")
    assert update_docs(tmp_path, summary) == [readme]
    text = readme.read_text()
    assert text.startswith(prose) and text.endswith("\n\nText after.\n")
    assert TABLES["readme"](summary) in text and "stale" not in text
    assert json.loads((tmp_path / SUMMARY_PATH).read_text()) == {k: v for k, v in summary.items() if k != "seconds"}
    assert update_docs(tmp_path, summary) == []  # idempotent


def test_a_quick_summary_is_stored_apart_and_rewrites_no_table(tmp_path):
    (tmp_path / "README.md").write_text(f"{BEGIN.format(name='readme')}\nstale\n{END}\n")
    (tmp_path / "docs").mkdir()
    quick = {**committed_summary(), "quick": True, "seconds": 3.5}
    assert update_docs(tmp_path, quick) == []
    assert "stale" in (tmp_path / "README.md").read_text()
    assert json.loads((tmp_path / QUICK_SUMMARY_PATH).read_text())["quick"] is True
    assert not (tmp_path / SUMMARY_PATH).exists()


def test_an_unknown_table_is_refused():
    with pytest.raises(KeyError, match="no generated table is named 'nope'"):
        render(f"{BEGIN.format(name='nope')}\n{END}", committed_summary())


def test_the_docs_are_never_written_through_a_symbolic_link(tmp_path):
    (tmp_path / "README.md").write_text("no tables\n")
    (tmp_path / "docs").mkdir()
    outside = tmp_path / "outside.json"
    outside.write_text("keep me\n")
    (tmp_path / SUMMARY_PATH).symlink_to(outside)
    with pytest.raises(InvalidInputError, match="symbolic link"):
        update_docs(tmp_path, committed_summary())
    assert outside.read_text() == "keep me\n"


@pytest.mark.parametrize(("args", "why"), [
    (["--update-docs", "{tmp}"], "not a checkout's root"),
    (["--update-docs", "{tmp}/checkout"], "symbolic link"),
])
def test_the_cli_refuses_update_docs_without_a_checkout_before_the_run(tmp_path, args, why):
    checkout = tmp_path / "checkout"
    (checkout / "docs").mkdir(parents=True)
    (checkout / "README.md").write_text("x\n")
    (checkout / SUMMARY_PATH).symlink_to(tmp_path / "elsewhere.json")
    args = [a.format(tmp=tmp_path) for a in args]
    result = CliRunner().invoke(main, ["reproduce", *args, "--out", str(tmp_path / "out")])
    assert result.exit_code == 2 and why in result.output
    assert not (tmp_path / "out").exists()  # refused before any work


def test_check_names_the_first_difference_and_ignores_timings(tmp_path):
    summary = committed_summary()
    stored = tmp_path / "summary.json"
    stored.write_text(json.dumps({**summary, "seconds": 1.0}))
    check_summary({**summary, "seconds": 99.0}, stored)  # timings aside, identical
    changed = json.loads(json.dumps(summary))
    changed["rows"][3]["median"] = 1 + (changed["rows"][3]["median"] or 0)
    with pytest.raises(ReproductionMismatchError, match=r"summary\['rows'\]\[3\]\['median'\]"):
        check_summary(changed, stored)
    assert first_difference({"a": [1.0]}, {"a": [1.0000000000000002]}) == "summary['a'][0]: the reference has 1.0, this run 1.0000000000000002"
    assert first_difference({"a": 1}, {"a": 1.0}) is not None  # an int is not a float
    assert first_difference({"a": [1]}, {"a": [1, 2]}) == "summary['a']: 2 entries, the reference has 1"
