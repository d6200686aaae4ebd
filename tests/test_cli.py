"""The dmprs command line, run in-process with click's runner."""

from click.testing import CliRunner

import dmprs
from dmprs.cli import main
from dmprs.runlog import RunLog


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_learn_then_plot(tmp_path):
    out = run("learn", "analytic", "--log-dir", tmp_path / "run", "--desired", 1.2)
    assert out.exit_code == 0, out.output
    assert "trial   1" in out.output and "converged" in out.output
    trials, _ = RunLog(tmp_path / "run").read()
    assert trials[-1].success
    out = run("plot", tmp_path / "run")
    assert out.exit_code == 0, out.output
    png = tmp_path / "run" / "learning.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_resume_a_run_that_hit_its_trial_cap(tmp_path):
    out = run("learn", "analytic", "--log-dir", tmp_path, "--max-trials", 1, "--noise", 0.05)
    assert out.exit_code == 1 and "not converged" in out.output
    out = run("resume", tmp_path, "--max-trials", 20)
    assert out.exit_code == 0, out.output
    trials, _ = RunLog(tmp_path).read()
    assert trials[0].index == 0 and trials[-1].success and len(trials) >= 2


def test_demos_writes_a_loadable_database(tmp_path):
    out = run("demos", "analytic", "--out", tmp_path / "db")
    assert out.exit_code == 0, out.output
    db = dmprs.Database.load(tmp_path / "db")
    assert len(db) == 2


def test_unknown_names_and_unreadable_runs_are_clean_errors(tmp_path):
    out = run("learn", "juggling")
    assert out.exit_code != 0 and "unknown task 'juggling'" in out.output
    out = run("learn", "analytic", "--learner", "sgd")
    assert out.exit_code != 0 and "unknown learner 'sgd'" in out.output
    out = run("resume", tmp_path / "nothing")
    assert out.exit_code != 0 and "run.json" in out.output
    out = run("plot", tmp_path / "nothing")
    assert out.exit_code != 0


def test_python_dash_m_runs_the_cli():
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "dmprs", "--help"], capture_output=True, text=True)
    assert out.returncode == 0 and "learn" in out.stdout
