"""``dmprs demos import`` and the readers behind it (bags, LeRobot, CSV, npz), and the export of a
rolled-out trajectory to a ROS 2 bag and CSV.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from click.testing import CliRunner

import dmprs
from dmprs.cli import main
from dmprs.errors import InvalidInputError
from dmprs.io.export import write_joint_trajectory_bag, write_trajectory_csv
from dmprs.io.importer import build_database, load_demos
from dmprs.io.tables import read_csv_trajectory, read_query_table
from tests.lerobot_writer import episode_states, volume, write_v3
from tests.test_io_rosbag import JOINTS, recording, write_joint_bag


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)


def test_import_a_bag_cut_at_rests_with_a_query_table(tmp_path):
    t, y, _ = recording()
    bag = write_joint_bag(tmp_path, "ros2-sqlite3", t, y)
    table = tmp_path / "queries.csv"
    table.write_text("demo,reach [m]\ndemo#0,0.8\ndemo#1,0.2\n")
    out = tmp_path / "db"
    res = run("demos", "import", bag, "--out", out, "--queries", table, "--joints", ",".join(JOINTS),
              "--rest-speed", 0.02, "--rate", 100)
    assert res.exit_code == 0, res.output
    db = dmprs.Database.load(out)
    assert len(db) == 2 and db.query_names == ("reach",) and db.query_units == ("m",)
    assert [d.label for d in db] == ["demo#0", "demo#1"]
    assert db[0].metadata["names"] == list(JOINTS)
    np.testing.assert_allclose(db.queries[:, 0], [0.8, 0.2])
    first = db[0].trajectory
    np.testing.assert_allclose(np.diff(first.t), 0.01, rtol=1e-9)
    # the first movement goes from the rest pose to the far one
    np.testing.assert_allclose(first.y[0], y[0], atol=1e-3)
    np.testing.assert_allclose(first.y[-1], y[np.searchsorted(t, 2.0)], atol=1e-3)
    # the database generalizes: the two demos' own queries give back their movements
    dmp = dmprs.Generalizer(db).predict([0.8])
    np.testing.assert_allclose(dmp.goal, first.y[-1], atol=1e-9)


def test_import_lerobot_with_queries_from_a_field_and_json_table(tmp_path):
    root = write_v3(tmp_path / "ds", n_episodes=3)
    out = tmp_path / "db"
    res = run("demos", "import", root, "--out", out, "--query-field", "bottle_volume", "--units", "l",
              "--dims", "shoulder,elbow")
    assert res.exit_code == 0, res.output
    db = dmprs.Database.load(out)
    np.testing.assert_allclose(db.queries[:, 0], [volume(k) for k in range(3)])
    assert db.n_dof == 2 and db.query_units == ("l",)
    np.testing.assert_array_equal(db[1].trajectory.y, episode_states(1)[:, :2].astype(np.float64))
    assert db[2].metadata["labels"]["task"] == "pour into the glass"
    table = tmp_path / "q.json"
    table.write_text(json.dumps({"units": {"v": "l"}, "demos": [{"demo": str(k), "v": 1.0 + k} for k in range(3)]}))
    res = run("demos", "import", root, "--out", tmp_path / "db2", "--queries", table)
    assert res.exit_code == 0, res.output
    assert dmprs.Database.load(tmp_path / "db2").query_units == ("l",)


def test_import_csv_and_npz(tmp_path):
    t = np.linspace(0, 1, 51)
    for k, amp in enumerate((0.5, 1.0)):
        lines = ["t,a,b"] + [f"{v!r},{amp * v**2!r},{-amp * v!r}" for v in map(float, t)]
        (tmp_path / f"run{k}.csv").write_text("\n".join(lines) + "\n")
        np.savez(tmp_path / f"take{k}.npz", t=t, y=np.stack([amp * t**2, -amp * t], 1), amplitude=amp)
    demos = load_demos(sorted(tmp_path.glob("run*.csv")))
    assert [d.name for d in demos] == ["run0", "run1"]
    np.testing.assert_array_equal(demos[1].trajectory.y[:, 0], 1.0 * t**2)
    db = build_database(load_demos(sorted(tmp_path.glob("take*.npz"))), query_fields=["amplitude"])
    np.testing.assert_array_equal(db.queries[:, 0], [0.5, 1.0])


def test_clear_errors_name_what_exists(tmp_path):
    t, y, _ = recording()
    bag = write_joint_bag(tmp_path, "ros1", t, y)
    res = run("demos", "import", bag, "--out", tmp_path / "db", "--query-field", "x", "--topic", "/js")
    assert res.exit_code != 0 and "no topic '/js'" in res.output and "/joint_states" in res.output
    table = tmp_path / "q.csv"
    table.write_text("demo,v\nother,1\n")
    res = run("demos", "import", bag, "--out", tmp_path / "db", "--queries", table)
    assert res.exit_code != 0 and "no row for 'demo'" in res.output and "'other'" in res.output
    res = run("demos", "import", bag, "--out", tmp_path / "db", "--query-field", "volume")
    assert res.exit_code != 0 and "has no field 'volume'" in res.output
    (tmp_path / "x.csv").write_text("time,a\n0,1\n1,2\n2,3\n")
    with pytest.raises(InvalidInputError, match=r"no time column 't'; the columns are time, a"):
        read_csv_trajectory(tmp_path / "x.csv")
    with pytest.raises(InvalidInputError, match=r"no column 'b'; the columns are time, a"):
        read_csv_trajectory(tmp_path / "x.csv", "time", ["b"])
    # a binary header is named with its escapes, not printed raw; a wide one is cut short
    (tmp_path / "binary.csv").write_bytes(b"garbage\x00\x01,x\n0,1\n")
    with pytest.raises(InvalidInputError, match=r"the columns are 'garbage\\x00\\x01', x$"):
        read_csv_trajectory(tmp_path / "binary.csv")
    (tmp_path / "wide.csv").write_text(",".join(f"c{i}" for i in range(50)) + "\n" + ",".join("1" * 50) + "\n")
    with pytest.raises(InvalidInputError, match=r"the columns are c0, c1, .*, c19 and 30 more$"):
        read_csv_trajectory(tmp_path / "wide.csv")
    (tmp_path / "bad.csv").write_text("q,v\n1,2\n")
    with pytest.raises(InvalidInputError, match="no 'demo' column"):
        read_query_table(tmp_path / "bad.csv")
    # the old form still records a task's scripted demonstrations
    assert run("demos", "analytic", "--out", tmp_path / "scripted").exit_code == 0


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_export_joint_trajectory_bag_reads_back_with_rosbags(tmp_path, storage):
    from rosbags.highlevel import AnyReader

    dmp = dmprs.DMP.fit(np.linspace(0, 1, 101), np.stack([np.linspace(0, 1, 101) ** 2] * 2, 1), 15)
    traj = dmp.rollout(dt=0.01)
    path = write_joint_trajectory_bag(tmp_path / "out", traj, ["j1", "j2"], storage=storage,
                                      stamp_ns=1_700_000_000_123_456_789)
    with AnyReader([path]) as reader:
        (conn,) = reader.connections
        assert conn.topic == "/joint_trajectory" and conn.msgtype == "trajectory_msgs/msg/JointTrajectory"
        ((_, ts, raw),) = list(reader.messages())
        msg = reader.deserialize(raw, conn.msgtype)
    assert ts == 1_700_000_000_123_456_789 and list(msg.joint_names) == ["j1", "j2"]
    assert msg.header.stamp.sec == 1_700_000_000 and msg.header.stamp.nanosec == 123_456_789
    pos = np.array([p.positions for p in msg.points])
    tfs = np.array([p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in msg.points])
    np.testing.assert_array_equal(pos, traj.y)
    np.testing.assert_array_equal(np.array([p.velocities for p in msg.points]), traj.yd)
    np.testing.assert_allclose(tfs, traj.t, atol=1e-9)
    csv_path = write_trajectory_csv(tmp_path / "out.csv", traj, ["j1", "j2"])
    back, names = read_csv_trajectory(csv_path, "time", ["j1", "j2"])
    assert names == ("j1", "j2")
    np.testing.assert_array_equal(back.y, traj.y)
    np.testing.assert_array_equal(back.t, traj.t)
    with pytest.raises(InvalidInputError, match="2 distinct names"):
        write_trajectory_csv(tmp_path / "o.csv", traj, ["j1"])


def test_import_poses_from_tf_into_a_database_of_pose_demonstrations(tmp_path):
    from scipy.spatial.transform import Rotation

    from tests.bag_writers import BagWriter, bag_path
    from tests.conftest import min_jerk
    from tests.test_io_rosbag import T0

    t = np.arange(0.0, 5.0, 0.02)
    a, b = min_jerk(np.clip((t - 0.5) / 1.5, 0, 1)), min_jerk(np.clip((t - 3.0) / 1.5, 0, 1))
    s = a - b  # reach out, rest, come back
    rot = Rotation.from_rotvec(np.outer(s, [0.0, 0.0, 0.8])).as_quat(scalar_first=True)
    poses = np.hstack([np.stack([0.3 * s, 0.1 * s, 0 * s], axis=1), rot])
    bag = bag_path(tmp_path, "ros1", "pour")
    with BagWriter(bag, "ros1") as w:
        for tk, pk in zip(t, poses, strict=True):
            ns = T0 + round(tk * 1e9)
            w.write("/tf", w.tf_message(ns, [("world", "tool", pk)]), ns)
    table = tmp_path / "q.csv"
    table.write_text("demo,reach [m]\npour#0,0.3\npour#1,0.0\n")
    out = tmp_path / "db"
    res = run("demos", "import", bag, "--tf", "world:tool", "--rest-speed", 0.01, "--rate", 50,
              "--queries", table, "--out", out)
    assert res.exit_code == 0, res.output
    db = dmprs.Database.load(out)
    assert db.is_cartesian and len(db) == 2 and db[0].metadata["tf"] == ["world", "tool"]
    np.testing.assert_allclose(db[0].trajectory.pose[-1], poses[np.searchsorted(t, 2.5)], atol=1e-3)
    dmp = dmprs.Generalizer(db).predict([0.3])  # a demo's own query gives back its movement
    assert isinstance(dmp, dmprs.CartesianDMP)
    np.testing.assert_allclose(dmp.goal, db[0].trajectory.pose[-1], atol=1e-9)
    res = run("demos", "import", bag, "--tf", "world", "--queries", table, "--out", tmp_path / "x")
    assert res.exit_code != 0 and "FRAME:CHILD" in res.output


def _err(res):
    """The CLI failed with exactly one line, 'Error: ...', and no traceback."""
    assert (res.exit_code != 0 and res.exception is None) or isinstance(res.exception, SystemExit), res.output
    lines = [line for line in res.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: "), res.output
    return lines[0]


def test_the_rate_is_bounded_before_anything_is_allocated(tmp_path):
    (tmp_path / "a.csv").write_text("t,x\n0,0\n1,1\n2,4\n3.7,9\n")
    line = _err(CliRunner().invoke(main, ["demos", "import", str(tmp_path / "a.csv"), "--out", str(tmp_path / "db"),
                                          "--query-field", "x", "--rate", "1e9"]))
    assert "a.csv" in line and "resampling 3.7 s at 1e+09 Hz gives 3.7e+09 samples x 1 DOF" in line
    for rate in ("nan", "-5", "0", "inf"):
        line = _err(CliRunner().invoke(main, ["demos", "import", str(tmp_path / "a.csv"), "--out",
                                              str(tmp_path / "db"), "--query-field", "x", "--rate", rate]))
        assert "rate" in line


def test_files_that_are_not_regular_or_not_text_are_one_line_errors_naming_them(tmp_path):
    os.mkfifo(tmp_path / "pipe.csv")
    (tmp_path / "zero.npz").symlink_to("/dev/zero")
    (tmp_path / "latin.csv").write_bytes(b"t,x\n0,\xe9\n")
    (tmp_path / "nul.csv").write_bytes(b"t,x\n0,1\x00\n1,2\n")
    (tmp_path / "nan.csv").write_text("t,x\n0,1\n1,nan\n2,3\n")
    (tmp_path / "back.csv").write_text("t,x\n0,1\n\n2,2\n1,3\n")
    (tmp_path / "two.csv").write_text("t,x\n0,1\n1,2\n")
    (tmp_path / "huge.csv").write_text("t,x\n0," + "9" * 200_000 + "\n")
    expected = {
        "pipe.csv": "pipe.csv: is a FIFO (named pipe); a CSV file must be a regular file",
        "zero.npz": "zero.npz: is a character device",
        "latin.csv": "latin.csv: not utf-8 text (byte 6 is b'\\xe9')",
        "nul.csv": "nul.csv, line 2, column 'x': '1\\x00' is not a number",
        "nan.csv": "nan.csv, line 3, column 'x': 'nan'; every value must be finite",
        "back.csv": "back.csv, line 5: time 1.0 does not exceed 2.0 on line 4; times must increase",
        "two.csv": "two.csv: 2 data rows; a demonstration needs at least 3",
        "huge.csv": "huge.csv, line 2: not valid CSV (field larger than field limit",
    }
    for name, want in expected.items():
        line = _err(CliRunner().invoke(main, ["demos", "import", str(tmp_path / name), "--out", str(tmp_path / "db"),
                                              "--query-field", "x"]))
        assert want in line, line


def test_npz_bombs_and_query_tables_are_refused_naming_the_file(tmp_path):
    import io
    import zipfile

    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("t.npy", bytes(40 * 2**20))
    (tmp_path / "bomb.npz").write_bytes(buf.getvalue())
    with pytest.raises(InvalidInputError, match=r"bomb\.npz: not a readable npz file \(ValueError: .*magic string"):
        load_demos([tmp_path / "bomb.npz"])
    t = np.linspace(0, 1, 5)
    np.savez(tmp_path / "ok.npz", t=t, y=t**2, amplitude=np.float64("nan"))
    with pytest.raises(InvalidInputError, match=r"ok\.npz: label 'amplitude' is nan"):
        load_demos([tmp_path / "ok.npz"])
    for text, why in [("demo,v\nok,1\nok,2\n", r"q\.csv, line 3: demonstration 'ok' appears twice"),
                      ("demo,v\n,1\n", r"q\.csv, line 2: the demonstration's name is empty"),
                      ("demo,v\nok,inf\n", r"q\.csv, line 2, column 'v': 'inf'; every value must be finite"),
                      ("demo,v,v\nok,1,2\n", r"q\.csv, line 1: column 'v' appears twice")]:
        (tmp_path / "q.csv").write_text(text)
        with pytest.raises(InvalidInputError, match=why):
            read_query_table(tmp_path / "q.csv")
    (tmp_path / "q.json").write_text('{"units": 3, "demos": []}')
    with pytest.raises(InvalidInputError, match=r"q\.json: 'units' must map"):
        read_query_table(tmp_path / "q.json")


def test_a_static_tf_chain_is_not_a_demonstration(tmp_path):
    from tests.bag_writers import BagWriter, bag_path
    from tests.test_io_rosbag import T0

    bag = bag_path(tmp_path, "ros2-mcap", "static")
    with BagWriter(bag, "ros2-mcap") as w:
        w.write("/tf_static", w.tf_message(T0, [("world", "tool", [0, 0, 0, 1, 0, 0, 0])]), T0)
    with pytest.raises(InvalidInputError, match=r"static, TF 'world' -> 'tool' has 1 distinct samples of poses \(a chain of static transforms is one pose\)"):
        load_demos([bag], tf=("world", "tool"))


def test_fifty_episodes_in_five_files_import_exactly_with_a_progress_bar(tmp_path):
    root = write_v3(tmp_path / "ds", n_episodes=50, per_file=10, period=7)
    seen = []
    demos = load_demos([root], progress=lambda src, done, total: seen.append((src.name, done, total)))
    assert len(demos) == 50 and [s[1] for s in seen] == sorted(s[1] for s in seen) and seen[-1][1] == seen[-1][2]
    assert len(seen) == 5
    res = CliRunner().invoke(main, ["demos", "import", str(root), "--out", str(tmp_path / "db"), "--query-field",
                                    "bottle_volume", "--progress"])
    assert res.exit_code == 0 and "reading ds" in res.output and "50 demonstrations" in res.output
    db = dmprs.Database.load(tmp_path / "db")
    assert [d.label for d in db] == [str(k) for k in range(50)]
    for k, d in enumerate(db):
        np.testing.assert_array_equal(d.trajectory.y, episode_states(k, 7).astype(np.float64))
    np.testing.assert_allclose(db.queries[:, 0], [volume(k) for k in range(50)])
    res = CliRunner().invoke(main, ["demos", "import", str(root), "--out", str(tmp_path / "db2"), "--query-field",
                                    "bottle_volume"])
    assert res.exit_code == 0 and "reading" not in res.output  # not a terminal: no bar
