"""Hostile directory entries, planted where dmprs expects one of its files: shared by the fuzz
targets (``tests/fuzz_targets.py``) and the tests that damage a run log or a database on purpose.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path


def plant(path: Path, kind: str, outside: Path, content: bytes = b"") -> None:
    """Replaces ``path`` (a file, a link or a folder) by a hostile entry of ``kind``: ``"fifo"``,
    ``"zero"`` (a link to /dev/zero), ``"dir"``, ``"link-outside"`` (a link to a copy of
    ``content`` in ``outside``), ``"dangling"`` (a link to a missing file in ``outside``); any
    other kind is a regular file of ``content``.
    """
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif os.path.lexists(path):
        path.unlink()
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "zero":
        path.symlink_to("/dev/zero")
    elif kind == "dir":
        path.mkdir()
    elif kind == "link-outside":  # a link to a copy outside: reading it is fine, writing through it is not
        target = outside / f"target-of-{path.name}"
        target.write_bytes(content)
        path.symlink_to(target)
    elif kind == "dangling":
        path.symlink_to(outside / f"created-through-{path.name}")
    else:  # "bomb" and the like: these bytes
        path.write_bytes(content)
