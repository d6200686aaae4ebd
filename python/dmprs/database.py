"""The movement database: demonstrations, each a trajectory labelled with its task query
(the Z of paper eq. 5: ``{y_d^k, yd_d^k, ydd_d^k; q_k}``).

On disk a database is a directory::

    manifest.json          format, schema version, query names and units, and per demo its
                           file, sha256, label and metadata
    demo_<sha256[:16]>.npz one per demo: query, t, y and optionally yd, ydd (float64); for a pose
                           demonstration query, t, position, quaternion and optionally
                           velocity, angular_velocity, acceleration, angular_acceleration

Saving never leaves a half-written database: every file is
written to a temporary file in the same directory, flushed, fsync'ed and renamed into place; the
demo files are named by their content, so they never overwrite the files of the previous version;
the manifest is replaced last, atomically, and only then are files no manifest refers to removed.
A crash at any point leaves either the old or the new database, both loadable.

Loading trusts nothing: the manifest must be a dmprs database of a schema this version can
read; every demo file must match its sha256 and is read with ``allow_pickle=False``. Any failure
raises :class:`~dmprs.errors.DatabaseError` naming the file.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import zipfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, as_query
from dmprs._io import LOCK_FILE, directory_lock, write_atomic
from dmprs.errors import DatabaseError, DmprsError, InvalidInputError
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = ["SCHEMA_VERSION", "Database", "Demo"]

#: The newest schema this version reads and writes. Schema 2 adds pose demonstrations; a
#: database of joint-space demonstrations is still written as schema 1, so older dmprs read it.
SCHEMA_VERSION = 2
_POSE_SCHEMA = 2
_FORMAT = "dmprs.Database"
_MANIFEST = "manifest.json"
_DEMO_FILE = re.compile(r"^demo_[0-9a-f]{16}\.npz$")
_ARRAY_KEYS = {"query", "t", "y", "yd", "ydd"}
_POSE_KEYS = {
    "query", "t", "position", "quaternion", "velocity", "angular_velocity", "acceleration",
    "angular_acceleration",
}
#: what :meth:`Database.add` can do with a query already present
DUPLICATE_POLICIES = ("refuse", "replace", "keep")


@dataclass(frozen=True, eq=False)
class Demo:
    """One demonstration: its task ``query`` (n,), its ``trajectory`` (joint space, or a pose
    trajectory), an optional ``label`` and JSON-safe ``metadata``."""

    query: NDArray[np.float64]
    trajectory: Trajectory | CartesianTrajectory
    label: str | None = None
    metadata: Mapping[str, Any] = field(default_factory=dict)


def _query_tuple(value: Any, name: str) -> tuple[str, ...]:
    if isinstance(value, str):
        return (value,)
    try:
        items = tuple(value)
    except TypeError:
        raise InvalidInputError(f"{name} must be a sequence of strings; got {value!r}") from None
    for i, v in enumerate(items):
        if not isinstance(v, str):
            raise InvalidInputError(f"{name}[{i}] must be a string; got {v!r}")
    return items


class Database:
    """Demonstrations ``(query, trajectory)`` with named, unit-labelled query dimensions.

    ``Database(query_names=("bottle_volume",), query_units=("l",))``: the query of every demo has
    ``len(query_names)`` entries. All demos must have the same number of DOFs. A query that is
    already present is handled by :meth:`add`'s ``on_duplicate`` policy. The demos are either all
    joint-space :class:`~dmprs.Trajectory` s or all pose :class:`~dmprs.CartesianTrajectory` s
    (then :attr:`is_cartesian`).
    """

    def __init__(self, query_names: Sequence[str], query_units: Sequence[str] | None = None) -> None:
        names = _query_tuple(query_names, "query_names")
        if not names:
            raise InvalidInputError("query_names is empty: a query needs at least one dimension")
        if len(set(names)) != len(names):
            raise InvalidInputError(f"query_names has duplicates: {names}")
        units = ("",) * len(names) if query_units is None else _query_tuple(query_units, "query_units")
        if len(units) != len(names):
            raise InvalidInputError(
                f"query_units has {len(units)} entries but query_names has {len(names)}"
            )
        self._names = names
        self._units = units
        self._demos: list[Demo] = []

    @property
    def query_names(self) -> tuple[str, ...]:
        return self._names

    @property
    def query_units(self) -> tuple[str, ...]:
        return self._units

    @property
    def n_query(self) -> int:
        """Dimension n of the queries."""
        return len(self._names)

    @property
    def n_dof(self) -> int | None:
        """DOFs of the trajectories (None while empty)."""
        return self._demos[0].trajectory.n_dof if self._demos else None

    @property
    def is_cartesian(self) -> bool:
        """True when the demonstrations are pose trajectories (False while empty)."""
        return bool(self._demos) and isinstance(self._demos[0].trajectory, CartesianTrajectory)

    def _check_query(self, query: ArrayLike) -> NDArray[np.float64]:
        return as_query(query, "query", self._names)

    def add(
        self,
        query: ArrayLike,
        trajectory: Trajectory | CartesianTrajectory,
        *,
        label: str | None = None,
        metadata: Mapping[str, Any] | None = None,
        on_duplicate: str = "refuse",
    ) -> Demo:
        """Appends a demonstration and returns its record. ``metadata`` must be JSON-serializable.

        ``on_duplicate`` says what happens when a demo with exactly this query is present:

        * ``"refuse"`` (default): raise :class:`~dmprs.errors.InvalidInputError` and change
          nothing. The default because the other two silently change what the database means
          (replace drops a demonstration, keep gives generalizers a repeat to deal with); a
          caller that grows a database on purpose picks one (``dmprs.learn`` uses "replace").
        * ``"replace"``: the new demo takes the place (and index) of every demo at that query.
        * ``"keep"``: both are kept, in order. Generalizer ``"linear"`` averages the DMP
          parameters of repeats (their mean is the least-squares estimate at that query);
          ``"lwr-gp"`` refuses repeats with a message saying so.
        """
        if on_duplicate not in DUPLICATE_POLICIES:
            raise InvalidInputError(
                f"on_duplicate = {on_duplicate!r} is invalid: use one of {DUPLICATE_POLICIES}"
            )
        q = self._check_query(query)
        if not isinstance(trajectory, (Trajectory, CartesianTrajectory)):
            raise InvalidInputError(
                f"trajectory is a {type(trajectory).__name__}; expected a dmprs.Trajectory or "
                "dmprs.CartesianTrajectory"
            )
        if self._demos and isinstance(trajectory, CartesianTrajectory) != self.is_cartesian:
            kinds = ("joint-space trajectories", "pose trajectories")
            raise InvalidInputError(
                f"the trajectory is one of the {kinds[not self.is_cartesian]}, but the demonstrations "
                f"in this database are {kinds[self.is_cartesian]}"
            )
        if self._demos and trajectory.n_dof != self.n_dof:
            raise InvalidInputError(
                f"the trajectory has {trajectory.n_dof} DOFs, but the demonstrations in this "
                f"database have {self.n_dof}"
            )
        same = [k for k, d in enumerate(self._demos) if np.array_equal(d.query, q)]
        if same and on_duplicate == "refuse":
            raise InvalidInputError(
                f"demonstration {same[0]} already has the query {q.tolist()}; pass "
                "on_duplicate='replace' or 'keep' to add another demonstration at the same query"
            )
        if label is not None and not isinstance(label, str):
            raise InvalidInputError(f"label must be a string or None; got {label!r}")
        meta = dict(metadata or {})
        try:
            json.dumps(meta, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"metadata must be JSON-serializable: {exc}") from None
        q.setflags(write=False)
        demo = Demo(q, trajectory, label, meta)
        if same and on_duplicate == "replace":
            self._demos[same[0]] = demo
            for k in reversed(same[1:]):
                del self._demos[k]
        else:
            self._demos.append(demo)
        return demo

    def __len__(self) -> int:
        return len(self._demos)

    def __iter__(self) -> Iterator[Demo]:
        return iter(list(self._demos))

    def __getitem__(self, index: int) -> Demo:
        return self._demos[index]

    @property
    def queries(self) -> NDArray[np.float64]:
        """All queries, (M, n)."""
        return np.array([d.query for d in self._demos], dtype=np.float64).reshape(len(self), self.n_query)

    def nearest(self, query: ArrayLike, k: int = 2) -> Database:
        """A new database with the ``k`` demonstrations whose queries are nearest ``query``
        (Euclidean distance in query units; ties keep database order). With ``"linear"``
        generalization, which takes n + 1 demos, this gives piecewise-linear generalization
        over a growing database."""
        q = self._check_query(query)
        k = as_count(k, "k", 1)
        if k > len(self):
            raise InvalidInputError(f"k = {k} but the database has {len(self)} demonstrations")
        order = np.argsort(np.linalg.norm(self.queries - q, axis=1), kind="stable")[:k]
        out = Database(self._names, self._units)
        out._demos = [self._demos[i] for i in sorted(order)]
        return out

    def __repr__(self) -> str:
        dims = ", ".join(f"{n} [{u}]" if u else n for n, u in zip(self._names, self._units))
        return f"Database({len(self)} demos, query=({dims}), n_dof={self.n_dof})"

    # --- persistence ------------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes the database to the directory ``path`` (created if missing) atomically; see the
        module docs. Refuses a non-empty directory that is not a dmprs database."""
        root = Path(path)
        try:
            root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DatabaseError(f"cannot create the database directory {root}: {exc}") from None
        try:
            with directory_lock(root, shared=False):
                self._save_locked(root)
        except OSError as exc:
            raise DatabaseError(f"{root}: cannot save the database ({exc.strerror or exc})") from None

    def _save_locked(self, root: Path) -> None:
        existing = [p.name for p in root.iterdir() if p.name != LOCK_FILE]
        if existing and _MANIFEST not in existing and not all(_DEMO_FILE.match(n) for n in existing):
            raise DatabaseError(
                f"{root} is a non-empty directory without a {_MANIFEST}; refusing to write a "
                "database into it"
            )
        # Only files the previous manifest listed are ours to delete later: a file that merely
        # looks like a demo file may be the user's.
        previous = _manifest_files(root / _MANIFEST)
        entries = []
        for demo in self._demos:
            data = _npz_bytes(demo)
            digest = hashlib.sha256(data).hexdigest()
            name = f"demo_{digest[:16]}.npz"
            target = root / name
            if not (target.is_file() and _sha256_file(target) == digest):
                _atomic_write(target, data)
            entries.append({"file": name, "sha256": digest, "label": demo.label, "metadata": dict(demo.metadata)})
        manifest = {
            "format": _FORMAT,
            "schema_version": _POSE_SCHEMA if self.is_cartesian else 1,
            "query_names": list(self._names),
            "query_units": list(self._units),
            "demos": entries,
        }
        text = json.dumps(manifest, indent=2, allow_nan=False) + "\n"
        _atomic_write(root / _MANIFEST, text.encode("utf-8"))
        # The new manifest is durable: files only the old one referred to can go.
        keep = {e["file"] for e in entries}
        for name in previous - keep:
            try:
                (root / name).unlink()
            except OSError:
                pass  # a stale file is harmless: no manifest refers to it
        # Temporary files of an interrupted earlier save (the lock says no save is running).
        for p in root.glob(".*.tmp"):
            try:
                p.unlink()
            except OSError:
                pass

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Database:
        """Reads a database written by :meth:`save`, verifying every file."""
        root = Path(path)
        if not root.is_dir():
            raise DatabaseError(f"{root / _MANIFEST}: cannot read the manifest (no directory {root})")
        with directory_lock(root, shared=True):
            return cls._load_locked(root)

    @classmethod
    def _load_locked(cls, root: Path) -> Database:
        mpath = root / _MANIFEST
        try:
            raw = mpath.read_bytes()
        except OSError as exc:
            raise DatabaseError(f"{mpath}: cannot read the manifest ({exc.strerror or exc})") from None
        try:
            manifest = json.loads(raw.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise DatabaseError(f"{mpath}: not valid JSON, the file is corrupted or truncated ({exc})") from None
        except RecursionError:
            raise DatabaseError(f"{mpath}: nested too deeply to be a dmprs manifest") from None
        if not isinstance(manifest, dict) or manifest.get("format") != _FORMAT:
            raise DatabaseError(f"{mpath}: not a dmprs database manifest (no \"format\": \"{_FORMAT}\")")
        version = manifest.get("schema_version")
        if not isinstance(version, int) or isinstance(version, bool) or version < 1:
            raise DatabaseError(f"{mpath}: invalid schema_version {version!r}")
        if version > SCHEMA_VERSION:
            raise DatabaseError(
                f"{mpath}: schema version {version} was written by a newer dmprs; this version "
                f"reads up to schema version {SCHEMA_VERSION}. Upgrade dmprs to load it."
            )
        try:
            db = cls(manifest["query_names"], manifest["query_units"])
            entries = manifest["demos"]
            if not isinstance(entries, list):
                raise TypeError("'demos' is not a list")
        except (KeyError, TypeError, DmprsError) as exc:
            raise DatabaseError(f"{mpath}: malformed manifest ({exc})") from None
        for k, entry in enumerate(entries):
            demo = _read_demo(root, mpath, k, entry, db.n_query)
            try:
                db.add(demo.query, demo.trajectory, label=demo.label, metadata=demo.metadata,
                       on_duplicate="keep")  # as saved
            except DmprsError as exc:
                raise DatabaseError(f"{root / entry['file']}: {exc}") from None
        return db


def _npz_bytes(demo: Demo) -> bytes:
    tr = demo.trajectory
    arrays = {"query": demo.query}
    names = sorted(_POSE_KEYS if isinstance(tr, CartesianTrajectory) else _ARRAY_KEYS)
    for name in names:
        if name != "query" and getattr(tr, name) is not None:
            arrays[name] = getattr(tr, name)
    buf = io.BytesIO()
    savez: Any = np.savez  # numpy's stub types the keyword arrays as its own options
    savez(buf, **arrays)
    return buf.getvalue()


def _manifest_files(mpath: Path) -> set[str]:
    """The demo files an existing manifest lists (none if it is missing or unreadable)."""
    try:
        entries = json.loads(mpath.read_text(encoding="utf-8")).get("demos", [])
        return {e["file"] for e in entries if isinstance(e, dict) and isinstance(e.get("file"), str)
                and _DEMO_FILE.match(e["file"])}
    except (OSError, ValueError, AttributeError, TypeError, RecursionError):
        return set()


def _sha256_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _atomic_write(target: Path, data: bytes) -> None:
    """Readers see the old file or the new one, never a partial one (:func:`dmprs._io.write_atomic`)."""
    try:
        write_atomic(target, data)
    except OSError as exc:
        raise DatabaseError(f"{target}: cannot write ({exc.strerror or exc})") from None


def _read_demo(root: Path, mpath: Path, k: int, entry: Any, n_query: int) -> Demo:
    if not isinstance(entry, dict) or not isinstance(entry.get("file"), str) or not isinstance(entry.get("sha256"), str):
        raise DatabaseError(f"{mpath}: demos[{k}] must have string 'file' and 'sha256' entries")
    name = entry["file"]
    if not _DEMO_FILE.match(name):
        raise DatabaseError(f"{mpath}: demos[{k}] names {name!r}, which is not a demo file of a dmprs database")
    fpath = root / name
    try:
        data = fpath.read_bytes()
    except OSError as exc:
        raise DatabaseError(f"{fpath}: cannot read demonstration {k} ({exc.strerror or exc})") from None
    digest = hashlib.sha256(data).hexdigest()
    if digest != entry["sha256"]:
        raise DatabaseError(
            f"{fpath}: checksum mismatch (sha256 {digest[:16]}..., the manifest expects "
            f"{entry['sha256'][:16]}...): the file is corrupted, truncated or was replaced"
        )
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            keys = set(npz.files)
            pose = "position" in keys
            missing = ({"query", "t", "position", "quaternion"} if pose else {"query", "t", "y"}) - keys
            extra = keys - (_POSE_KEYS if pose else _ARRAY_KEYS)
            if missing or extra:
                raise ValueError(
                    f"arrays {sorted(keys)}; expected query, t, y and optionally yd, ydd, or query, "
                    "t, position, quaternion and optionally their derivatives"
                )
            arrays = {key: npz[key] for key in keys}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile) as exc:
        raise DatabaseError(f"{fpath}: not a readable demonstration file ({exc})") from None
    except MemoryError:  # a crafted header claiming far more elements than the file holds
        raise DatabaseError(
            f"{fpath}: an array header claims more data than fits in memory ({len(data)} bytes on disk)"
        ) from None
    for key, arr in arrays.items():
        if arr.dtype != np.float64:
            raise DatabaseError(f"{fpath}: array {key!r} has dtype {arr.dtype}, expected float64")
    q = arrays["query"]
    if q.shape != (n_query,):
        raise DatabaseError(f"{fpath}: query has shape {q.shape}, expected ({n_query},)")
    try:
        traj: Trajectory | CartesianTrajectory
        if pose:
            traj = CartesianTrajectory(**{k: v for k, v in arrays.items() if k != "query"})
        else:
            traj = Trajectory(arrays["t"], arrays["y"], arrays.get("yd"), arrays.get("ydd"))
    except DmprsError as exc:
        raise DatabaseError(f"{fpath}: invalid trajectory ({exc})") from None
    label = entry.get("label")
    metadata = entry.get("metadata", {})
    if (label is not None and not isinstance(label, str)) or not isinstance(metadata, dict):
        raise DatabaseError(f"{mpath}: demos[{k}] has a malformed label or metadata")
    return Demo(q, traj, label, metadata)
