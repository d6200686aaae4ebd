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
