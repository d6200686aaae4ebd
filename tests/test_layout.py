"""The package's layout keeps its promises: no import cycle among its modules (not even through
a lazy import inside a function), ``import dmprs`` loads no simulator, file format, middleware or
framework (they load where they are used), and no docstring or Rust doc comment points into the
issue tracker (the why of the code is in docs/, its measurements in benches/README.md).
"""

from __future__ import annotations

import ast
import graphlib
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "python" / "dmprs"
#: a reference into the issue tracker ("issue 16", "issues 3 and 4", "issue #12")
TRACKER = re.compile(r"\bissues? #?\d", re.IGNORECASE)

#: heavy optional packages that ``import dmprs`` must not import
HEAVY = ("pymunk", "mujoco", "matplotlib", "pyarrow", "rosbags", "gymnasium", "ray", "cyclonedds", "cma",
         "bayes_opt", "optuna")


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(module: str, path: Path, known: set[str]) -> set[str]:
    """The package's modules ``module`` imports anywhere in its body (functions included; not
    under ``if TYPE_CHECKING``, which never runs).
    """
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            node.body = []
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package[: len(package) - node.level + 1] + ([base] if base else []))
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
    return {m for m in found if m in known and m != module and not m.startswith(module + ".")}


def _cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle of ``graph`` (module -> the modules it imports), or [] if it has none."""
    try:
        graphlib.TopologicalSorter(graph).prepare()
    except graphlib.CycleError as err:
        return list(err.args[1])
    return []


def test_no_import_cycle_among_the_modules() -> None:
    modules = _modules()
    graph = {m: _imports(m, p, set(modules)) for m, p in modules.items()}
    assert not _cycle(graph), f"an import cycle: {' -> '.join(_cycle(graph))}"


def test_the_cycle_check_finds_a_cycle(tmp_path: Path) -> None:
    # the check itself, on a two-module package whose second module imports the first lazily
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("from pkg import b\n")
    (pkg / "b.py").write_text("def f():\n    from pkg import a\n    return a\n")
    known = {"pkg.a", "pkg.b"}
    assert _imports("pkg.a", pkg / "a.py", known) == {"pkg.b"}
    assert _imports("pkg.b", pkg / "b.py", known) == {"pkg.a"}
    assert set(_cycle({m: _imports(m, pkg / f"{m[4:]}.py", known) for m in known})) == known
    # and a longer one, through three modules
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}})
    assert not _cycle({"a": {"b"}, "b": {"c"}, "c": set()})


@pytest.mark.parametrize("entry", ["import dmprs", "import dmprs.experiments"])
def test_import_dmprs_loads_no_heavy_package(entry: str) -> None:
    code = f"import sys; {entry}; print(','.join(m for m in {HEAVY!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.strip() == "", f"`{entry}` imported {out.stdout.strip()}"


def _doc_texts() -> list[tuple[str, str]]:
    """Every docstring of the package's Python modules and every doc comment of the Rust crates,
    with where it stands.
    """
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
                doc = ast.get_docstring(node)
                if doc:
                    out.append((f"{path.relative_to(ROOT)}:{getattr(node, 'lineno', 1)}", doc))
    for path in sorted((ROOT / "crates").glob("*/src/**/*.rs")):
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if line.lstrip().startswith(("///", "//!")):
                out.append((f"{path.relative_to(ROOT)}:{n}", line))
    return out


def test_no_docstring_points_into_the_issue_tracker() -> None:
    found = [f"{where}: {m.group(0)!r}" for where, text in _doc_texts() if (m := TRACKER.search(text))]
    assert not found, "tracker references in docstrings:\n" + "\n".join(found)


@pytest.mark.parametrize(("text", "hit"), [("(issue 16 item 5)", True), ("Issues 3 and 4", True), ("issue #12", True),
                                           ("docs/method.md §6.2 item 7", False), ("a tissue 3 mm", False),
                                           ("§11 #8", False)])
def test_the_tracker_pattern(text: str, hit: bool) -> None:
    assert bool(TRACKER.search(text)) is hit
