"""`dmprs reproduce --quick` runs every part at small scale and writes the report and figures."""

import json

from click.testing import CliRunner

from dmprs.cli import main


def _refuse(token: str) -> float:
    raise ValueError(f"{token} is not JSON")


def test_quick_reproduction(tmp_path, calibration_cache, monkeypatch):
    monkeypatch.setenv("DMPRS_CACHE_DIR", calibration_cache)  # the arm's calibration, computed once
    out = tmp_path / "out"
    result = CliRunner().invoke(main, ["reproduce", "--quick", "--out", str(out), "--backend", "serial"],
                                catch_exceptions=False)
    assert result.exit_code == 0, result.output
    # strict JSON: NaN and infinities are written as strings, not as Python's bare tokens
    report = json.loads((out / "report.json").read_text(), parse_constant=_refuse)
    parts = {r["part"] for r in report["runs"]}
    assert parts == {"matchbox", "matchbox_both_flipped_back", "pouring", "arm_pouring", "baselines", "growing",
                     "noisy", "throwing", "juggling", "online", "versus", "throwing-release", "arm-sequence"}
    learn = [r for r in report["runs"] if r["kind"] == "learn"]
    assert all(r["converged"] for r in learn), [(r["part"], r["stop_reason"]) for r in learn]
    versus = [r for r in report["runs"] if r["kind"] == "versus"]
    assert {r["learner"] for r in versus} == {"auto", "bo"} and all(r["converged"] for r in versus)
    md = (out / "report.md").read_text()
    assert "| experiment | learner | trials to success | paper |" in md
    for title in ("## Learning gets faster as the database grows", "## A noisy robot", "## Throwing into a basket",
                  "## Paddle juggling with the 7-DOF arm",
                  "## A stepper in the arm's servo loop", "## Bayesian optimization beside the query-space learners",
                  "## The final-velocity throw beside today's throw",
                  "## Reach, pour and return as one sequence on the arm"):
        assert title in md
    for fig in ("fig4_matchbox.png", "fig7_matchbox_extrapolation.png", "fig9_pouring.png", "fig9_arm_pouring.png",
                "baselines.png", "growing_pouring.png", "noisy_robot.png", "throwing.png", "juggling.png", "online_arm.png",
                "versus_bo.png", "throwing_release.png", "arm_sequence.png"):
        assert (out / fig).read_bytes()[:4] == b"\x89PNG"
