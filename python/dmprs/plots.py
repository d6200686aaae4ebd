"""Figures. matplotlib is an optional extra (``pip install 'dmprs[plot]'``), imported lazily."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dmprs._extras import require
from dmprs.errors import DmprsError
from dmprs.runlog import RunLog


def pyplot():
    """matplotlib.pyplot with the Agg backend, or a DmprsError saying how to install it."""
    require("matplotlib", "plotting")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> Path:
    """Lays out, writes (110 dpi, the reproduction's figures) and closes ``fig``; returns ``path``."""
    plt = pyplot()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_run(run: str | Path, out: str | Path | None = None) -> Path:
    """Error and query per trial of a logged run, in the style of the paper's Figs. 4 and 9."""
    log = RunLog(run)
    meta = log.meta()
    trials, _ = log.read()
    ok = [t for t in trials if t.eps is not None]
    if not ok:
        raise DmprsError(f"{log.trials_path} has no scored trial to plot")
    plt = pyplot()
    n = np.arange(1, len(ok) + 1)
    eps = np.array([t.eps for t in ok])
    q = np.array([t.query for t in ok])
    names = meta.get("query_names") or [f"q{i}" for i in range(q.shape[1])]
    units = meta.get("query_units") or [""] * q.shape[1]
    fig, ax = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    for i in range(q.shape[1]):
        ax[0].plot(n, q[:, i], "o-", label=f"query {names[i]} ({units[i]})")
        ax[1].plot(n, eps[:, i], "o-", label=f"error eps ({units[i]})")
    desired = np.atleast_1d(meta.get("desired_query", []))
    for d in desired:
        ax[0].axhline(float(d), color="grey", ls="--", lw=0.8, label="desired query")
    ax[1].axhline(0.0, color="grey", lw=0.8)
    for i, t in enumerate(ok):
        if t.success:
            ax[1].plot(n[i], eps[i, 0], "*", ms=14, color="tab:green", label="success")
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    ax[1].set_xlabel("trial")
    ax[0].set_title(f"{meta.get('task', '')}: {meta.get('learner', '')}")
    ax[1].set_xticks(n)
    fig.tight_layout()
    path = _figure_path(out, log.directory)
    try:
        fig.savefig(path, dpi=120)
    except (OSError, ValueError) as exc:  # matplotlib's error for an unknown format is a ValueError
        raise DmprsError(f"cannot write the figure {path}: {exc}") from None
    finally:
        plt.close(fig)
    return path


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
