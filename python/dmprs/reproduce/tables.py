"""The result tables of the README and of docs/, written from a reproduction's summary.

A table in a Markdown file lies between :data:`BEGIN` (naming the table) and :data:`END`;
:func:`update_docs` rewrites every such block of a checkout from one summary and stores that
summary beside the docs, so the README and the docs cannot disagree with the run they cite or
with each other (the project's tests render the blocks from the stored summary again).
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

from dmprs._io import strict_json, write_atomic
from dmprs.errors import InvalidInputError
from dmprs.reproduce.arm_sequence import KIND as SEQUENCE_KIND
from dmprs.reproduce.arm_sequence import markdown_sequence
from dmprs.reproduce.check import without_timings
from dmprs.reproduce.release_throwing import KIND as RELEASE_KIND
from dmprs.reproduce.release_throwing import markdown_release
from dmprs.reproduce.stats import cell
from dmprs.reproduce.versus_bo import markdown_versus

#: the line before a generated table; ``{name}`` is a key of :data:`TABLES`
BEGIN = "<!-- generated from docs/reproduction.json by `dmprs reproduce --update-docs`: {name} -->"
#: the line after it
END = "<!-- end of generated table -->"
#: where a checkout keeps the summary its tables were written from
SUMMARY_PATH = Path("docs") / "reproduction.json"
#: where it keeps the quick reproduction's summary, the reference CI checks its own quick run with
QUICK_SUMMARY_PATH = Path("docs") / "reproduction-quick.json"

_BLOCK = re.compile(re.escape(BEGIN).replace(re.escape("{name}"), r"(?P<name>[a-z0-9-]+)")
                    + r"\n(?P<body>.*?)" + re.escape(END), re.DOTALL)


def _rows(summary: dict[str, Any], part: str, learner: str) -> list[dict[str, Any]]:
    return [r for r in summary["rows"] if r["part"] == part and r["learner"] == learner]


def _one(rows: list[dict[str, Any]], **setting: Any) -> dict[str, Any]:
    found = [r for r in rows if all(r.get("setting", {}).get(k) == v for k, v in setting.items())]
    if len(found) != 1:
        raise KeyError(f"the summary has {len(found)} rows for {setting}, not one")
    return found[0]


def _section(summary: dict[str, Any], kind: str) -> list[dict[str, Any]]:
    for s in summary.get("sections", []):
        if s["kind"] == kind:
            return list(s["data"])
    raise KeyError(f"the summary has no {kind!r} section")


def _volumes(rows: list[dict[str, Any]]) -> list[float]:
    return sorted({r["setting"]["bottle_volume"] for r in rows})


def _joined(cells: list[str]) -> str:
    return " / ".join(cells)


def _line(*cells: str) -> str:
    return "| " + " | ".join(cells) + " |"


def readme(summary: dict[str, Any]) -> str:
    """The README's table: the paper's experiments, the arm, throwing, the growing database and
    the baselines, one line each.
    """
    def learned(part: str, learner: str, **setting: Any) -> str:
        return cell(_one(_rows(summary, part, learner), **setting))

    pour = [0.4, 0.5, 0.7]
    pour_liquids = max(r["runs"] for r in _rows(summary, "pouring", "golden"))
    arm_volumes = _volumes(_rows(summary, "arm_pouring", "golden"))
    liquids = max(r["runs"] for r in _rows(summary, "arm_pouring", "golden"))
    throws = [r for r in _section(summary, "throwing") if r["learner"] == "secant" and r["generalizer"] == "linear"
              and r["tol"] == 0.05 and not r["noisy"]]
    growing = {r["generalizer"]: r for r in _section(summary, "growing") if r["n_demos"] == "floors"}
    orders = max(r["runs"] for r in growing.values())
    thirds = {part: [f"{r[part + '_third_mean_trials']:.2f}" for r in growing.values()] for part in ("first", "last")}
    base = [r for r in summary["rows"] if r["part"] == "baselines" and r["setting"]["demos"] == "both_flipped_back"]
    sigmas = sorted({r["setting"]["sigma_frac"] for r in base})
    base = [r for r in base if r["setting"]["sigma_frac"] == sigmas[len(sigmas) // 2]]
    def over(volumes: list[float]) -> str:
        return _joined([f"{v:g}" for v in volumes])

    lines = [
        "| experiment | learner | trials to success | paper |", "|---|---|---|---|",
        _line("matchbox, demos flipped back + over (Fig. 4)", "eq. 16, K = I",
              learned("matchbox", "error", demos="default"), "4 (simulation), 5 (robot)"),
        _line("matchbox, both demos flipped back (Fig. 7)", "eq. 17 (weighted) / eq. 16",
              _joined([learned("matchbox_both_flipped_back", lr) for lr in ("weighted", "error")]),
              "succeeds, no count"),
        _line(f"pouring 0.2 l from {over(pour)} l, {pour_liquids} liquids each (Fig. 9)", "golden section (paper mode)",
              _joined([learned("pouring", "golden", bottle_volume=v) for v in pour]), "similar rates, no count"),
        _line("pouring, same volumes", "fixed-gain eq. 16, K = 1 l/l",
              _joined([learned("pouring", "fixed", bottle_volume=v) for v in pour]), '"less successful"'),
        _line("pouring from 0.25 l (outside the demos)", "golden, paper mode / robust mode",
              _joined([learned("pouring", lr, bottle_volume=0.25) for lr in ("golden", "golden-robust")]), "not run"),
        _line(f"pouring with the 7-DOF arm, {over(arm_volumes)} l, {liquids} liquids each", "golden section",
              _joined([learned("arm_pouring", "golden", bottle_volume=v) for v in arm_volumes]),
              "KUKA LWR: converges, no count"),
        _line("same, with the Illinois root finder", "root",
              _joined([learned("arm_pouring", "root", bottle_volume=v) for v in arm_volumes]), "not run"),
        _line(f"throwing into a 5 cm basket, {_joined([str(r['runs']) for r in throws])} unseen baskets "
              f"{_joined([r['region'] for r in throws])} the demos' range", "Broyden (secant), linear",
              _joined([f"{cell(r)}, {r['successes']}/{r['runs']}" for r in throws]), "the paper's example query"),
        _line(f"growing database, new volumes in {orders} orders, mean trials to success", _joined(list(growing)),
              f"first third {_joined(thirds['first'])}, last third {_joined(thirds['last'])}",
              '"fewer and fewer learning steps"'),
        _line("matchbox, both demos flipped back",
              f"{_joined([r['setting']['name'] for r in base])}, weight space, {base[0]['runs']} seeds",
              f"{_joined([str(r['successes']) for r in base])} of {base[0]['runs']} succeed within "
              f"{base[0]['budget']}", "not reported"),
    ]
    return "\n".join(lines) + "\n"


def arm_pouring(summary: dict[str, Any]) -> str:
    """docs/arm.md's results: per bottle and learner the trials to success over the liquids, the
    first (generalized) trial's pour, and every liquid's count.
    """
    golden = _rows(summary, "arm_pouring", "golden")
    vols = _volumes(golden)
    head = ["| bottle (l) | " + " | ".join(f"{v:g}" for v in vols) + " |", "|---|" + "---:|" * len(vols)]
    root = _rows(summary, "arm_pouring", "root")
    lines = [*head,
             _line("golden section (paper mode)", *(cell(_one(golden, bottle_volume=v)) for v in vols)),
             _line("Illinois root finder", *(cell(_one(root, bottle_volume=v)) for v in vols))]
    firsts = []
    for v in vols:
        ml = sorted(1000 * run["first_signals"]["poured_volume"] for run in _one(golden, bottle_volume=v)["per_run"])
        firsts.append(f"{ml[len(ml) // 2]:.0f} [{ml[0]:.0f}-{ml[-1]:.0f}]")
    lines.append(_line("poured by the generalized movement (trial 1, ml)", *firsts))
    lines += ["", "Every liquid's run (trials to success; - : not within the cap):", "", *head]
    for learner in ("golden", "root"):
        rows = _rows(summary, "arm_pouring", learner)
        for k, run in enumerate(_one(rows, bottle_volume=vols[0])["per_run"]):
            seed = run["seeds"].get("liquid_seed", k)
            counts = [_one(rows, bottle_volume=v)["per_run"][k]["trials_to_success"] for v in vols]
            lines.append(_line(f"{learner}, liquid {seed}", *("-" if c is None else str(c) for c in counts)))
    return "\n".join(lines) + "\n"


def versus_bo(summary: dict[str, Any]) -> str:
    """The comparison with Bayesian optimization and CMA-ES, as the report gives it."""
    return markdown_versus(_section(summary, "versus"))


def _part_table(summary: dict[str, Any], kind: str, markdown_of: Callable[[Any], str]) -> str:
    """A part's table as the report gives it; a note while the summary predates that part."""
    for s in summary.get("sections", []):
        if s["kind"] == kind:
            return markdown_of(s["data"])
    return f"*The stored summary has no {kind!r} section yet: a full `dmprs reproduce --update-docs .` writes this table.*\n"


def throwing_release(summary: dict[str, Any]) -> str:
    """docs/throwing.md's final-velocity throw beside today's."""
    return _part_table(summary, RELEASE_KIND, markdown_release)


def arm_sequence(summary: dict[str, Any]) -> str:
    """docs/arm.md's reach, pour and return as one sequence beside the same movements with stops."""
    return _part_table(summary, SEQUENCE_KIND, markdown_sequence)


#: every table a Markdown file may hold, by the name its :data:`BEGIN` line gives
TABLES: dict[str, Callable[[dict[str, Any]], str]] = {"readme": readme, "arm-pouring": arm_pouring,
                                                      "versus-bo": versus_bo, "throwing-release": throwing_release,
                                                      "arm-sequence": arm_sequence}


def render(text: str, summary: dict[str, Any]) -> str:
    """``text`` with every generated block rewritten from ``summary``."""
    def one(m: re.Match[str]) -> str:
        name = m.group("name")
        if name not in TABLES:
            raise KeyError(f"no generated table is named {name!r} (known: {', '.join(TABLES)})")
        return f"{BEGIN.format(name=name)}\n{TABLES[name](summary)}{END}"

    return _BLOCK.sub(one, text)


def documents(root: Path) -> list[Path]:
    """The Markdown files of a checkout that may hold generated tables: README.md and docs/*.md."""
    return [p for p in [root / "README.md", *sorted((root / "docs").glob("*.md"))] if p.is_file()]


def docs_targets(root: str | Path, quick: bool) -> list[Path]:
    """The files :func:`update_docs` writes in the checkout at ``root``, checked before a run
    so that a wrong root fails at once: the checkout must have README.md and docs/, and no target
    may be a symbolic link (the docs are never written through one).
    """
    root = Path(root)
    if not (root / "README.md").is_file() or not (root / "docs").is_dir() or (root / "docs").is_symlink():
        raise InvalidInputError(f"--update-docs {root}: not a checkout's root (it needs README.md and a docs/ folder)")
    targets = [root / (QUICK_SUMMARY_PATH if quick else SUMMARY_PATH)]
    if not quick:
        targets += documents(root)
    links = [str(p) for p in targets if p.is_symlink()]
    if links:
        raise InvalidInputError(f"--update-docs {root}: {', '.join(links)} is a symbolic link; the docs are "
                                "never written through one")
    return targets


def update_docs(root: str | Path, summary: dict[str, Any]) -> list[Path]:
    """Stores a run's ``summary`` in the checkout at ``root``: a full run's as
    :data:`SUMMARY_PATH` with every generated table rewritten from it, a quick run's as
    :data:`QUICK_SUMMARY_PATH` (the reference of ``dmprs reproduce --quick --check``). Returns the
    files that changed.
    """
    quick = bool(summary.get("quick"))
    store, *docs = docs_targets(root, quick)
    changed = []
    for path in docs:
        text = path.read_text()
        new = render(text, summary)
        if new != text:
            write_atomic(path, new.encode())
            changed.append(path)
    stored = without_timings(summary)
    write_atomic(store, (json.dumps(strict_json(stored), indent=1, default=str, allow_nan=False) + "\n").encode())
    return changed
