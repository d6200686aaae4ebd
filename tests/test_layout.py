"""The package's layout keeps its promises: no module imports one that imports it back (not even
lazily, inside a function), and ``import dmprs`` loads no simulator, file format, middleware or
framework (they load where they are used).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "python" / "dmprs"

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


def test_no_module_imports_a_module_that_imports_it_back() -> None:
    modules = _modules()
    graph = {m: _imports(m, p, set(modules)) for m, p in modules.items()}
    cycles = sorted({tuple(sorted((a, b))) for a, deps in graph.items() for b in deps if a in graph.get(b, ())})
    assert not cycles, f"modules that import each other: {cycles}"


def test_the_cycle_check_finds_a_cycle(tmp_path: Path) -> None:
    # the check itself, on a two-module package whose second module imports the first lazily
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("from pkg import b\n")
    (pkg / "b.py").write_text("def f():\n    from pkg import a\n    return a\n")
    known = {"pkg.a", "pkg.b"}
    assert _imports("pkg.a", pkg / "a.py", known) == {"pkg.b"}
    assert _imports("pkg.b", pkg / "b.py", known) == {"pkg.a"}


@pytest.mark.parametrize("entry", ["import dmprs", "import dmprs.experiments"])
def test_import_dmprs_loads_no_heavy_package(entry: str) -> None:
    code = f"import sys; {entry}; print(','.join(m for m in {HEAVY!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=120)
    assert out.stdout.strip() == "", f"`{entry}` imported {out.stdout.strip()}"
