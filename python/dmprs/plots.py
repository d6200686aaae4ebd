"""Figures. matplotlib is an optional extra (``pip install 'dmprs[plot]'``), imported lazily.

A figure is rendered in memory and written with :func:`dmprs._io.write_atomic`: never through a
link, never half-written.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from dmprs._extras import require
from dmprs._io import write_atomic
from dmprs.errors import DmprsError
from dmprs.runlog import RunLog


def pyplot():
    """matplotlib.pyplot with the Agg backend, or a DmprsError saying how to install it."""
    require("matplotlib", "plotting")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _write_figure(fig: Any, path: Path, dpi: int) -> Path:
    """Renders ``fig`` in the format of ``path``'s extension and writes it atomically; closes it."""
    plt = pyplot()
    buf = io.BytesIO()
    try:
        fig.savefig(buf, format=path.suffix[1:] or None, dpi=dpi)
        write_atomic(path, buf.getvalue())
    except (OSError, ValueError) as exc:  # matplotlib's error for an unknown format is a ValueError
        raise DmprsError(f"cannot write the figure {path}: {exc}") from None
    finally:
        plt.close(fig)
    return path


def save_figure(fig, path: Path) -> Path:
    """Lays out, writes (110 dpi, the reproduction's figures) and closes ``fig``; returns ``path``."""
    fig.tight_layout()
    return _write_figure(fig, Path(path), 110)


def _labels(meta: dict[str, Any], name: str, n: int, default: list[str], where: Path) -> list[str]:
    """``meta[name]``: ``n`` strings (the query's names or units), or ``default`` when absent."""
    value = meta.get(name)
    if value is None:
        return default
    if not (isinstance(value, list) and len(value) == n and all(isinstance(v, str) for v in value)):
        raise DmprsError(f"{where}: {name!r} is {value!r:.60}, expected {n} string(s), one per query dimension")
    return value


def _desired(meta: dict[str, Any], n: int, where: Path) -> list[float]:
    value = meta.get("desired_query", [])
    items = value if isinstance(value, list) else [value]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) and np.isfinite(v) for v in items) or (
            items and len(items) != n):
        raise DmprsError(f"{where}: 'desired_query' is {value!r:.60}, expected {n} finite number(s)")
    return [float(v) for v in items]


def plot_run(run: str | Path, out: str | Path | None = None) -> Path:
    """Error and query per trial of a logged run, in the style of the paper's Figs. 4 and 9."""
    log = RunLog(run)
    meta = log.meta()
    trials, _ = log.read()
    ok = [t for t in trials if t.eps is not None]
    if not ok:
        raise DmprsError(f"{log.trials_path} has no scored trial to plot")
    n_query = len(ok[0].query)
    for t in ok:  # a run in weight space (a baseline's) has no error per query dimension
        assert t.eps is not None
        if len(t.eps) != n_query:
            raise DmprsError(f"{log.trials_path}, trial {t.index}: the error has {len(t.eps)} value(s) but the "
                             f"query {n_query}; only a run in the query space can be plotted")
    names = _labels(meta, "query_names", n_query, [f"q{i}" for i in range(n_query)], log.meta_path)
    units = _labels(meta, "query_units", n_query, [""] * n_query, log.meta_path)
    desired = _desired(meta, n_query, log.meta_path)
    path = _figure_path(out, log.directory)
    plt = pyplot()
    n = np.arange(1, len(ok) + 1)
    eps = np.array([t.eps for t in ok])
    q = np.array([t.query for t in ok])
    fig, ax = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    for i in range(n_query):
        ax[0].plot(n, q[:, i], "o-", label=f"query {names[i]} ({units[i]})")
        ax[1].plot(n, eps[:, i], "o-", label=f"error eps ({units[i]})")
    for d in desired:
        ax[0].axhline(d, color="grey", ls="--", lw=0.8, label="desired query")
    ax[1].axhline(0.0, color="grey", lw=0.8)
    for i, t in enumerate(ok):
        if t.success:
            ax[1].plot(n[i], eps[i, 0], "*", ms=14, color="tab:green", label="success")
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    ax[1].set_xlabel("trial")
    ax[0].set_title(f"{str(meta.get('task', ''))[:60]}: {str(meta.get('learner', ''))[:60]}")
    ax[1].set_xticks(n)
    fig.tight_layout()
    return _write_figure(fig, path, 120)


def _figure_path(out: str | Path | None, run_dir: Path) -> Path:
    """Where the figure goes: ``out`` itself, ``out/learning.png`` when ``out`` is a folder."""
    if out is None:
        return run_dir / "learning.png"
    path = Path(out)
    if path.is_dir():
        return path / "learning.png"
    if not path.parent.is_dir():
        raise DmprsError(f"cannot write the figure {path}: the folder {path.parent} does not exist")
    if not path.suffix:
        raise DmprsError(f"cannot write the figure {path}: give an existing folder or a file name with an "
                         "extension such as .png or .pdf")
    return path
