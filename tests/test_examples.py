"""The scripts in examples/ run, quickly, and do what they say."""

from __future__ import annotations

import importlib.util
import warnings
from pathlib import Path

import numpy as np

from dmprs.io import read_csv_trajectory

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_bag_to_skill(tmp_path):
    out = load("bag_to_skill").main(tmp_path)
    assert out["movements"] == 2 and out["rms"] < 0.01
    np.testing.assert_allclose(out["end"], out["goal"], atol=2e-3)
    back, _ = read_csv_trajectory(out["csv"], "time", ["shoulder", "elbow", "wrist"])
    np.testing.assert_allclose(back.y[-1], out["end"], rtol=0, atol=0)
    assert (out["bag"] / "metadata.yaml").is_file()


def test_generalize_database(tmp_path):
    out = load("generalize_database").main(tmp_path)
    assert out["n_demos"] == 8 and max(out["errors_m"]) < 0.01  # within 1 cm of targets no demo reached
    assert (tmp_path / "reaches" / "manifest.json").is_file()


def test_write_an_adapter():
    out = load("write_an_adapter").main()
    assert len(out["full"]) > len(out["dry"]) and out["outcome"].ok
    assert out["too_fast"].status.value == "rejected" and "signal 'gripper' is not declared" in out["caught"]


def test_cma_es_on_a_gymnasium_environment():
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", module="gymnasium")
        out = load("cma_es_matchbox").main(iterations=4)
    # the generalizer's strike for pi/2 flips the box back (|eps| ~ 0.53 rad): CMA-ES improves on it
    assert out["evaluations"] <= 32 and -out["reward"] < 0.3


def test_goals_near_start_side_by_side(tmp_path):
    out = load("goals_near_start").main(tmp_path)
    reach, loop = out["reach"], out["loop"]
    assert out["figure"].is_file()
    # dmprs: every rollout finite and bounded; a goal at the start of a returning movement keeps
    # its bump (0.3 high), and its goal is reached
    for runs in (reach["dmprs"], loop["dmprs"]):
        for goal, y in runs.items():
            assert np.isfinite(y).all() and np.abs(y).max() < 2 and abs(y[-1] - goal) < 0.01
    assert 0.29 < loop["dmprs"][0.0].max() < 0.31
    # Ijspeert's scaling: the bump squashed towards a goal near the start, gone (no motion at all)
    # for the returning movement sent to its start, and an explosion to any other goal
    assert reach["ijspeert"][0.05].max() < 0.06
    assert np.abs(loop["ijspeert"][0.0]).max() < 1e-9
    assert np.abs(loop["ijspeert"][0.3]).max() > 1e3
    # Hoffmann's: the bump kept near the start, nothing explodes
    assert reach["hoffmann"][0.05].max() > 0.3 and np.abs(loop["hoffmann"][0.3]).max() < 1
