"""The docs ship with the code: every ``<name>.md §N`` reference in the repository's .py, .rs, .md
and .toml files names a file in the repository that has a heading numbered N, and every relative
link in README.md and docs/*.md points to a file that exists.
"""

from __future__ import annotations

import os
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCANNED_SUFFIXES = {".py", ".rs", ".md", ".toml"}
#: skipped when the tree is walked without git (build output, environments, caches)
SKIPPED_DIRS = {".git", "target", "out", "bench-out", "build", "dist", ".venv", "venv", "node_modules",
                "__pycache__", ".pytest_cache", ".mypy_cache", ".hypothesis", ".ruff_cache"}

_SECTION = r"\d+(?:\.\d+)*"
_ITEM = r"(?:[ \t]*(?:item|fix|#)[ \t]*\d+)?"
#: `method.md §5.3`, `docs/method.md §6.2 #9`, `method.md §8.2-8.3`, `method.md §5.3, §6.2 item 4`,
#: also wrapped onto the next comment line (`method.md` / `// §5.2`)
REFERENCE = re.compile(
    rf"(?P<file>[\w./-]*\w\.md)\s+(?:(?://[/!]?|#)[ \t]*)?§(?P<refs>{_SECTION}{_ITEM}"
    rf"(?:-{_SECTION}|(?:[ \t]*,[ \t]*|\s+and\s+|\s+or\s+)§{_SECTION}{_ITEM})*)")
ONE_REF = re.compile(rf"(?P<section>{_SECTION})(?:[ \t]*(?:item|fix|#)[ \t]*(?P<item>\d+))?")
HEADING = re.compile(rf"^(?P<level>#{{1,6}})[ \t]+(?:§[ \t]*)?(?P<section>{_SECTION})\.?(?=\s|$)")
LIST_ITEM = re.compile(r"^\s*(?:[-*][ \t]+)?(?P<n>\d+)[.)][ \t]")
TABLE_ROW = re.compile(r"^\s*\|\s*(?P<n>\d+)\s*\|")
INLINE_LINK = re.compile(r"!?\[[^\]]*\]\((?P<target>[^)\s]+)(?:\s+\"[^\"]*\")?\)")
DEFINITION_LINK = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*(?P<target>\S+)")
URL_SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")


@dataclass(frozen=True)
class Reference:
    source: Path
    line: int
    file: str
    section: str
    item: str | None

    def describe(self, root: Path) -> str:
        item = f" item {self.item}" if self.item else ""
        return f"{self.source.relative_to(root)}:{self.line}: {self.file} §{self.section}{item}"


def repository_files(root: Path) -> list[Path]:
    """The files of the repository: git's tracked and untracked-but-not-ignored files, or, without
    git, every file outside build output and caches.
    """
    try:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
                             cwd=root, capture_output=True, check=True).stdout
        files = [root / p for p in out.decode().split("\0") if p]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, dirs, names in os.walk(root):
            dirs[:] = sorted(x for x in dirs if x not in SKIPPED_DIRS and not x.startswith("."))
            files += [Path(d) / n for n in sorted(names)]
    return [f for f in files if f.is_file()]


def references(path: Path) -> list[Reference]:
    """Every `<name>.md §N` reference in one file."""
    text = path.read_text(encoding="utf-8", errors="replace")
    found = []
    for m in REFERENCE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        for r in ONE_REF.finditer(m["refs"]):
            found.append(Reference(path, line, m["file"], r["section"], r["item"]))
    return found


def _outside_code_fences(text: str) -> list[tuple[int, str]]:
    """(line number, line) of a markdown text, without fenced code blocks."""
    lines, fence = [], None
    for i, line in enumerate(text.splitlines(), 1):
        stripped = line.lstrip()
        marker = stripped[:3]
        if marker in ("```", "~~~"):
            if fence is None:
                fence = marker
            elif marker == fence:
                fence = None
            continue
        if fence is None:
            lines.append((i, line))
    return lines


def sections(path: Path) -> dict[str, list[str]]:
    """Numbered headings of a markdown file -> the lines under each (up to the next heading of the
    same or a higher level).
    """
    out: dict[str, list[str]] = {}
    open_sections: list[tuple[int, str]] = []
    for _, line in _outside_code_fences(path.read_text(encoding="utf-8")):
        h = re.match(r"^(#{1,6})[ \t]", line)
        if h:
            level = len(h[1])
            open_sections = [(lv, s) for lv, s in open_sections if lv < level]
            m = HEADING.match(line)
            if m:
                open_sections.append((level, m["section"]))
                out.setdefault(m["section"], [])
            continue
        for _, s in open_sections:
            out[s].append(line)
    return out


def resolve(ref: Reference, root: Path) -> Path | None:
    """The file a reference names: relative to the citing file, the repository root or (for a
    bare name) docs/, whichever exists inside the repository.
    """
    name = Path(ref.file)
    candidates = [ref.source.parent / name, root / name]
    if len(name.parts) == 1:
        candidates.insert(1, root / "docs" / name)
    for c in candidates:
        c = c.resolve()
        if c.is_file() and c.is_relative_to(root.resolve()):
            return c
    return None


def broken_references(root: Path, files: list[Path]) -> tuple[list[str], int]:
    """Every reference that does not resolve, with why; and how many references were checked."""
    problems, n, cache = [], 0, {}
    for f in files:
        if f.suffix not in SCANNED_SUFFIXES:
            continue
        for ref in references(f):
            n += 1
            where, target = ref.describe(root), resolve(ref, root)
            if target is None:
                problems.append(f"{where}: no file {ref.file} in the repository")
                continue
            if target not in cache:
                cache[target] = sections(target)
            body, name = cache[target].get(ref.section), target.relative_to(root.resolve())
            if body is None:
                problems.append(f"{where}: {name} has no heading numbered {ref.section}")
            elif ref.item is not None and not any(
                    (m := LIST_ITEM.match(line) or TABLE_ROW.match(line)) and m["n"] == ref.item for line in body):
                problems.append(f"{where}: section {ref.section} of {name} has no numbered item {ref.item}")
    return problems, n


def broken_links(root: Path, markdown_files: list[Path]) -> tuple[list[str], int]:
    """Every relative link of the given markdown files whose target does not exist; and how many
    relative links were checked.
    """
    problems, n = [], 0
    for md in markdown_files:
        for i, line in _outside_code_fences(md.read_text(encoding="utf-8")):
            line = re.sub(r"`[^`]*`", "", line)  # inline code is not a link
            targets = [m["target"] for m in INLINE_LINK.finditer(line)]
            d = DEFINITION_LINK.match(line)
            if d:
                targets.append(d["target"])
            for target in targets:
                if URL_SCHEME.match(target) or target.startswith("#"):
                    continue
                n += 1
                path = target.split("#", 1)[0].split("?", 1)[0]
                if not (md.parent / path).exists():
                    problems.append(f"{md.relative_to(root)}:{i}: link to {target}, which does not exist")
    return problems, n


def _docs_markdown(root: Path) -> list[Path]:
    return [root / "README.md", *sorted((root / "docs").glob("*.md"))]


# --- the repository ------------------------------------------------------------------------------

def test_every_section_reference_resolves_to_a_numbered_heading():
    this_file = Path(__file__).resolve()  # its fixtures below cite a made-up spec.md on purpose
    files = [f for f in repository_files(ROOT) if f.resolve() != this_file]
    problems, n = broken_references(ROOT, files)
    assert n > 100, f"only {n} references found: the scanner no longer sees the code's citations"
    assert not problems, "\n".join(problems)


def test_relative_links_in_readme_and_docs_point_to_existing_files():
    problems, n = broken_links(ROOT, _docs_markdown(ROOT))
    assert n >= 2, f"only {n} relative links found"
    assert not problems, "\n".join(problems)


def test_method_doc_keeps_its_section_numbers_and_numbers_new_ones_after_them():
    numbered = sections(ROOT / "docs" / "method.md")
    top = [s for s in numbered if "." not in s]
    assert top == [str(k) for k in range(len(top))] and len(top) >= 12


# --- the checker itself ---------------------------------------------------------------------------

def _tree(tmp_path: Path, files: dict[str, str]) -> tuple[Path, list[Path]]:
    for name, text in files.items():
        p = tmp_path / name
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text, encoding="utf-8")
    return tmp_path, sorted(tmp_path / n for n in files)


SPEC = """# Spec

## 1. First

### 1.2 Sub

1. one
2. two

```
## 9. not a heading: inside a code fence
```

## 3. Third

| # | what |
|---|---|
| 4 | four |
"""


def test_checker_accepts_references_that_resolve(tmp_path):
    root, files = _tree(tmp_path, {
        "docs/spec.md": SPEC,
        "pkg/mod.py": '"""See spec.md §1.2 item 2 and docs/spec.md §3 #4, spec.md §1-1.2."""\n',
        "crates/x/src/lib.rs": "//! Wrapped across lines (docs/spec.md\n//! §3, §1.2 fix 1).\n",
        "Cargo.toml": "# spec.md §1\n",
    })
    problems, n = broken_references(root, files)
    assert problems == [] and n == 7


def test_checker_reports_a_missing_section_file_or_item(tmp_path):
    root, files = _tree(tmp_path, {
        "docs/spec.md": SPEC,
        "a.py": "# spec.md §2: no such section\n",
        "b.rs": "// spec.md §9 is only inside a code fence\n",
        "c.md": "gone.md §1 names no file\n",
        "d.toml": "# spec.md §1.2 item 3: no such item; spec.md §1, §3.1 also missing\n",
    })
    problems, n = broken_references(root, files)
    assert n == 6
    assert len(problems) == 5, problems
    assert any("a.py:1: spec.md §2" in p and "no heading numbered 2" in p for p in problems)
    assert any("b.rs:1: spec.md §9" in p for p in problems)
    assert any("no file gone.md" in p for p in problems)
    assert any("§1.2 item 3" in p and "no numbered item 3" in p for p in problems)
    assert any("d.toml:1: spec.md §3.1" in p and "no heading numbered 3.1" in p for p in problems)


def test_checker_reports_broken_relative_links(tmp_path):
    root, files = _tree(tmp_path, {
        "README.md": "[ok](docs/spec.md#1-first) [web](https://example.org) [x](#local) `[no](code.md)`\n"
                     "![missing](docs/figures/none.png)\n\n[ref]: docs/absent.md\n",
        "docs/spec.md": "[up](../README.md) [gone](other.md)\n",
    })
    problems, n = broken_links(root, files)
    assert n == 5
    assert sorted(p.split(": ", 1)[0] for p in problems) == ["README.md:2", "README.md:4", "docs/spec.md:1"]
