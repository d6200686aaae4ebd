"""The README's main command must work with the extras it names: every optional package is
mapped to the extra that brings it, and a reproduction without one leaves its runs out at once,
saying which extra brings them, instead of failing after minutes of work.
"""

from __future__ import annotations

import importlib
import re
import tomllib
from pathlib import Path

import pytest

from dmprs import _extras
from dmprs.baselines import BaselineSpec
from dmprs.reproduce import versus_bo

plan_module = importlib.import_module("dmprs.reproduce.plan")  # the package re-exports the function plan

ROOT = Path(__file__).resolve().parents[1]


def _extras_of_pyproject() -> dict[str, list[str]]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]


#: the modules whose distribution on PyPI has another name
DISTRIBUTION = {"bayes_opt": "bayesian_optimization"}


def test_every_optional_module_names_an_extra_that_installs_it():
    extras = _extras_of_pyproject()
    for module, extra in _extras.EXTRA_OF.items():
        assert extra in extras, f"{module}: no extra {extra!r} in pyproject.toml"
        names = " ".join(extras[extra]).lower().replace("-", "_")
        assert DISTRIBUTION.get(module, module).lower() in names, (
            f"the extra {extra!r} does not list {module}: {extras[extra]}")


def test_the_readme_main_command_names_an_extra_with_what_the_job_runs():
    text = (ROOT / "README.md").read_text()
    m = re.search(r'^python3 -m pip install "\.\[([a-z0-9,]+)\]" && python3 -m dmprs reproduce', text, re.MULTILINE)
    assert m, "the README's main command is not where .ci/run looks for it"
    extras = _extras_of_pyproject()
    named = set(m.group(1).split(","))
    installed = set(named)
    for extra in named:  # one level of self-references, as pyproject.toml uses them
        for req in extras[extra]:
            inner = re.match(r"dmprs\[([a-z0-9,]+)\]", req)
            installed |= set(inner.group(1).split(",")) if inner else set()
    for need in ("mujoco", "cma", "matplotlib"):
        assert _extras.EXTRA_OF[need] in installed, f"the main command does not install {need}"


def test_a_reproduction_without_cma_leaves_its_runs_out_and_says_why(monkeypatch):
    monkeypatch.setattr(plan_module, "available", lambda module: module != "cma")
    specs = plan_module.plan(quick=True)
    assert specs and not any(isinstance(s, BaselineSpec) and s.method == "cma" for s in specs)
    notes = plan_module.skipped(quick=True)
    assert len([n for n in notes if "cma" in n]) == 1
    assert "run(s) of cma not run: they need cma (pip install 'dmprs[cma]')" in notes[0]


def test_a_reproduction_without_mujoco_says_which_rows_of_the_comparison_it_leaves_out(monkeypatch):
    # the comparison with BO runs without MuJoCo, but without its arm's settings
    monkeypatch.setattr(versus_bo, "available", lambda module: module != "mujoco")
    monkeypatch.setattr(plan_module, "available", lambda module: module != "mujoco")
    arm = [s for s in versus_bo.SETTINGS if s.experiment in ("arm-pouring", "arm-throwing", "arm-juggling")]
    assert arm and not any(versus_bo.SETTINGS[s.setting] in arm for s in versus_bo.plan_versus())
    notes = [n for n in plan_module.skipped() if n.startswith(versus_bo.TITLE)]
    assert notes == [(f"{versus_bo.TITLE}: {len(arm)} setting(s) not run: they need mujoco "
                     "(pip install 'dmprs[robot]')")]
    assert not [n for n in plan_module.skipped(quick=True) if n.startswith(versus_bo.TITLE)]


def test_nothing_is_skipped_when_everything_is_installed():
    assert plan_module.skipped(quick=True) == []


def test_require_names_the_extra(monkeypatch):
    _extras.require("numpy", "anything")  # present: nothing happens
    monkeypatch.setattr(_extras, "available", lambda module: False)
    with pytest.raises(_extras.DmprsError, match=r"the ray backend needs the optional package ray: pip install 'dmprs\[ray\]'"):
        _extras.require("ray", "the ray backend")
