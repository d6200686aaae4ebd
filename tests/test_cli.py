"""The dmprs command line, run in-process with click's runner."""

import pytest
from click.testing import CliRunner

import dmprs
from dmprs.cli import main
from dmprs.runlog import RunLog
from tests.hostile import plant


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
    assert out.exit_code != 0 and "unknown experiment 'juggling'" in out.output
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


# --- damaged run logs: one line naming the file and the trial or field, never a traceback ---------

def _unfinished_run(tmp_path):
    """A 2-trial run of the analytic task that did not converge (so resume has work to do)."""
    out = run("learn", "analytic", "--log-dir", tmp_path / "run", "--max-trials", 2, "--noise", 0.05,
              "--tol", 1e-9)
    assert out.exit_code == 1 and "not converged" in out.output, out.output
    return tmp_path / "run"


def _rewrite_trial(run_dir, index, **fields):
    import json

    log = run_dir / "trials.jsonl"
    lines = log.read_text().splitlines()
    record = json.loads(lines[index])
    for key, value in fields.items():
        if value is _DROP:
            del record[key]
        else:
            record[key] = value
    lines[index] = json.dumps(record)
    log.write_text("\n".join(lines) + "\n")


_DROP = object()


def _single_line_error(out, *needles):
    assert out.exit_code == 1 and (out.exception is None or isinstance(out.exception, SystemExit)), out.output
    lines = out.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), out.output
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


@pytest.mark.parametrize(("fields", "why"), [
    ({"eps": ["NaN"]}, "trial 1: 'eps' is [nan]: not finite"),
    ({"eps": [1.0, 2.0]}, "trial 1: 'eps' has 2 value(s), expected 1"),
    ({"query": [1.0, 2.0]}, "trial 1: 'query' has 2 value(s), expected 1"),
    ({"query": "1.0"}, "trial 1: 'query' is '1.0', expected a list of numbers"),
    ({"query": _DROP}, "trial 1: 'query' is missing"),
    ({"trial": 5}, "record 2 is numbered 5, expected 1"),
    ({"trial": True}, "trial 1: 'trial' is True"),
    ({"status": "fine"}, "trial 1: 'status' is 'fine'"),
    ({"success": "yes"}, "trial 1: 'success' is 'yes'"),
    ({"signals": [1]}, "trial 1: 'signals' is [1]"),
    ({"message": 3}, "trial 1: 'message' is 3"),
    ({"file": "../../etc/passwd"}, "trial 1: 'file' is '../../etc/passwd'"),
])
def test_resume_and_plot_name_the_file_and_trial_of_a_damaged_record(tmp_path, fields, why):
    run_dir = _unfinished_run(tmp_path)
    _rewrite_trial(run_dir, 1, **fields)
    for command in ("resume", "plot"):
        _single_line_error(run(command, run_dir), f"{run_dir / 'trials.jsonl'}", why)


@pytest.mark.parametrize("damage", ["fifo", "zero", "deep", "huge", "list", "dir"])
def test_resume_and_plot_refuse_a_damaged_file_at_once(tmp_path, damage):
    run_dir = _unfinished_run(tmp_path)
    text = {"deep": "[" * 10**5 + "]" * 10**5, "huge": '{"trial": 1' + "0" * 400 + "}", "list": "[1, 2]"}
    for name in ("trials.jsonl", "run.json"):
        target = run_dir / name
        saved = target.read_bytes()
        plant(target, damage, tmp_path, (text.get(damage, "") + "\n").encode())
        for command in ("resume", "plot"):
            _single_line_error(run(command, run_dir), str(target))
        plant(target, "saved", tmp_path, saved)


def test_plot_refuses_damaged_labels_and_desired_query(tmp_path):
    import json

    run_dir = _unfinished_run(tmp_path)
    meta = json.loads((run_dir / "run.json").read_text())
    for field, value in (("query_units", ["l", "m"]), ("desired_query", [[1.0]]), ("query_names", "x")):
        (run_dir / "run.json").write_text(json.dumps({**meta, field: value}))
        _single_line_error(run("plot", run_dir), str(run_dir / "run.json"), repr(field))


def test_plot_into_a_folder_replaces_a_link_instead_of_following_it(tmp_path, outside):
    run_dir = _unfinished_run(tmp_path)
    folder = tmp_path / "figs"
    folder.mkdir()
    (folder / "learning.png").symlink_to(outside / "written-through-a-link.png")
    assert run("plot", run_dir, "--out", folder).exit_code == 0
    assert list(outside.iterdir()) == [] and not (folder / "learning.png").is_symlink()
    assert (folder / "learning.png").read_bytes()[:4] == b"\x89PNG"


def test_a_run_log_never_writes_through_a_link(tmp_path, outside):
    run_dir = tmp_path / "run"
    run_dir.mkdir()
    (run_dir / "trials.jsonl").symlink_to(outside / "trials.jsonl")
    out = run("learn", "analytic", "--log-dir", run_dir, "--max-trials", 2)
    _single_line_error(out, str(run_dir), "trials.jsonl")
    assert list(outside.iterdir()) == [] and sorted(p.name for p in run_dir.iterdir()) == ["trials.jsonl"]
