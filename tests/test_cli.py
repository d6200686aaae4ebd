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

    out = subprocess.run([sys.executable, "-m", "dmprs", "--help"], check=False, capture_output=True, text=True)
    assert out.returncode == 0 and "learn" in out.stdout


def _logged_run(tmp_path):
    out = run("learn", "analytic", "--log-dir", tmp_path / "run", "--max-trials", 3, "--noise", 0.05)
    assert out.exit_code in (0, 1), out.output
    return tmp_path / "run"


def _one_line_error(out, *needles):
    assert out.exit_code != 0, out.output
    assert out.exception is None or isinstance(out.exception, SystemExit), repr(out.exception)
    assert "Traceback" not in out.output
    assert all(n in out.output for n in needles), out.output


def test_a_damaged_run_json_is_a_one_line_error_naming_file_and_field(tmp_path):
    import json

    path = _logged_run(tmp_path)
    good = json.loads((path / "run.json").read_text())
    for field, value in [("schema_version", "1"), ("schema_version", None), ("experiment", "juggling"),
                         ("learner_name", None), ("max_trials", None), ("setup_options", {"bogus": 1}),
                         ("setup_options", [1]), ("tol", "abc"), ("max_trials", 2.5)]:
        meta = dict(good)
        if value is None and field != "schema_version":
            del meta[field]
        else:
            meta[field] = value
        (path / "run.json").write_text(json.dumps(meta))
        out = CliRunner().invoke(main, ["resume", str(path)])
        _one_line_error(out, "run.json", field)


def test_plot_out_into_a_folder_a_missing_folder_or_an_unknown_format(tmp_path):
    path = _logged_run(tmp_path)
    folder = tmp_path / "figures"
    folder.mkdir()
    out = run("plot", path, "--out", folder)
    assert out.exit_code == 0 and (folder / "learning.png").is_file(), out.output
    _one_line_error(CliRunner().invoke(main, ["plot", str(path), "--out", str(tmp_path / "no" / "f.png")]),
                    "does not exist")
    _one_line_error(CliRunner().invoke(main, ["plot", str(path), "--out", str(tmp_path / "f.xyz")]), "f.xyz")


def test_out_of_range_options_are_refused(tmp_path):
    path = _logged_run(tmp_path)
    _one_line_error(CliRunner().invoke(main, ["resume", str(path), "--max-trials", "0"]), "max-trials")
    _one_line_error(CliRunner().invoke(main, ["learn", "analytic", "--noise", "-1"]), "noise")


def test_learn_refuses_a_foreign_non_empty_log_dir(tmp_path):
    (tmp_path / "thesis.tex").write_text("precious")
    out = CliRunner().invoke(main, ["learn", "analytic", "--log-dir", str(tmp_path)])
    _one_line_error(out, "not a dmprs run")
    assert (tmp_path / "thesis.tex").read_text() == "precious"
