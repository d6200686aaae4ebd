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

A save is append-only: a database remembers the directory it last saved to or loaded from (the
manifest's inode, size and modification time, and the files it listed). When the directory is
still as it left it, a save writes only the demos added since and the manifest; otherwise every
demo file is checked against its sha256 and rewritten if it is not whole. Demo files are made
durable together (each fsync'ed, the directory once) before the manifest is replaced.

A save refuses a directory that holds files dmprs did not write (a non-empty directory without a
dmprs manifest, or with a ``manifest.json`` that is not one), before it writes anything there. It
writes no file through a link. The next save removes what an interrupted one left behind, but only
files that are provably dmprs's own: demo files no manifest lists whose content matches the
sha256 in their name, and the temporary files of its atomic writes.

Loading trusts nothing and writes nothing: the manifest must be a regular file holding a dmprs
database of a schema this version can read; every demo file must be a regular file of bounded
size, match its sha256, and hold float64 arrays (npy headers are checked before any data is
read; nothing is unpickled). Any failure raises :class:`~dmprs.errors.DatabaseError` naming the
file.
"""

from __future__ import annotations

import functools
import hashlib
import io
import json
import os
import re
import stat
from collections.abc import Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs._arrays import as_count, as_query
from dmprs._io import (
    JSON_MAX_BYTES,
    LOCK_FILE,
    MiB,
    atomic_temp_target,
    directory_lock,
    fsync_dir,
    load_npz,
    read_bytes,
    read_json,
    regular_files,
    remove_if,
    remove_stale_temp_files,
    write_atomic,
)
from dmprs.errors import DatabaseError, DmprsError, InvalidInputError
from dmprs.trajectory import CartesianTrajectory, Trajectory, from_arrays

__all__ = ["SCHEMA_VERSION", "Database", "Demo"]

#: The newest schema this version reads and writes. Schema 2 adds pose demonstrations; a
#: database of joint-space demonstrations is still written as schema 1, so older dmprs read it.
SCHEMA_VERSION = 2
_POSE_SCHEMA = 2
_FORMAT = "dmprs.Database"
_MANIFEST = "manifest.json"
_DEMO_FILE = re.compile(r"^demo_[0-9a-f]{16}\.npz$")
_DIGEST_NAME = "demo_{}.npz"
#: The largest manifest and demo file a database may hold (a link to a device, or a huge file,
#: is refused before anything is read).
MANIFEST_MAX_BYTES = JSON_MAX_BYTES
DEMO_MAX_BYTES = 1024 * MiB
#: what :meth:`Database.add` can do with a query already present
DUPLICATE_POLICIES = ("refuse", "replace", "keep")


@dataclass(frozen=True, eq=False)
class Demo:
    """One demonstration: its task ``query`` (n,), its ``trajectory`` (joint space, or a pose
    trajectory), an optional ``label`` and JSON-safe ``metadata``.
    """

    query: NDArray[np.float64]
    trajectory: Trajectory | CartesianTrajectory
    label: str | None = None
    metadata: Mapping[str, Any] = field(default_factory=dict)
    # its manifest entry, made at its first save or load (see _entry_of)
    _entry: _Entry | None = field(default=None, init=False, repr=False, compare=False)


@dataclass(frozen=True)
class _Entry:
    """A demo's manifest entry: its file (named by its content, which never changes: the query
    is read-only and the trajectory frozen), the metadata the entry was written from, and the
    entry as the manifest's JSON line.
    """

    file: str
    sha256: str
    metadata: Any
    line: str


def _entry(file: str, sha256: str, label: str | None, metadata: Mapping[str, Any]) -> _Entry:
    line = json.dumps({"file": file, "sha256": sha256, "label": label, "metadata": dict(metadata)},
                      allow_nan=False)
    return _Entry(file, sha256, json.loads(line)["metadata"], line)  # a deep copy, as JSON holds it


def _entry_of(demo: Demo) -> tuple[_Entry, bytes | None]:
    """A new manifest entry for a demo whose entry is missing or whose metadata changed since it
    was made (the same file then), and the file's bytes when they were computed for the digest.
    """
    known = demo._entry
    data = None
    if known is None:
        data = _npz_bytes(demo)
        digest = hashlib.sha256(data).hexdigest()
        file = _DIGEST_NAME.format(digest[:16])
    else:
        file, digest = known.file, known.sha256
    made = _entry(file, digest, demo.label, demo.metadata)
    object.__setattr__(demo, "_entry", made)
    return made, data


FileIdentity = tuple[int, int, int]


@dataclass(frozen=True)
class _Synced:
    """A directory as a database last saved or loaded it: the identities of the manifest, of
    the directory and of each demo file the manifest lists. While the manifest is unchanged, a
    file that is still a regular file of that identity is whole (it was verified or written by
    this database, and only a save replaces the manifest); while the directory is unchanged too,
    no file in it was created, removed or renamed, and nothing needs looking at.
    """

    root: Path
    manifest: tuple[int, int, int, int]
    directory: tuple[int, int, int]
    files: Mapping[str, FileIdentity]


def _directory_identity(root: Path) -> tuple[int, int, int]:
    st = os.stat(root)
    return (st.st_ino, st.st_mtime_ns, st.st_ctime_ns)


def _identity(path: Path) -> FileIdentity:
    st = os.lstat(path)
    return (st.st_ino, st.st_size, st.st_mtime_ns)


def _file_identities(root: Path) -> dict[str, FileIdentity]:
    """The identity (inode, size, modification time) of each regular file in ``root``: a file
    rewritten, truncated or swapped for another changes it (a freed inode may be reused at
    once, so the inode alone is not enough).
    """
    out = {}
    with os.scandir(root) as entries:
        for e in entries:
            if e.is_file(follow_symlinks=False):
                st = e.stat(follow_symlinks=False)
                out[e.name] = (st.st_ino, st.st_size, st.st_mtime_ns)
    return out


def _manifest_identity(root: Path) -> tuple[int, int, int, int] | None:
    try:
        st = os.lstat(root / _MANIFEST)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def _query_key(q: NDArray[np.float64]) -> tuple[float, ...]:
    """A query as a dict key; equal exactly when ``np.array_equal`` says so (0.0 == -0.0)."""
    return tuple(q.tolist())


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
        # how many demos hold each query: add's duplicate check without a scan of every demo
        self._query_count: dict[tuple[float, ...], int] = {}
        self._queries: NDArray[np.float64] | None = None  # cached for queries and nearest
        self._tree: Any = None  # scipy's cKDTree over the queries, built on the first nearest
        self._synced: _Synced | None = None

    @property
    def query_names(self) -> tuple[str, ...]:
        """The names of the query's components."""
        return self._names

    @property
    def query_units(self) -> tuple[str, ...]:
        """The units of the query's components ('' where none)."""
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
        key = _query_key(q)
        same = ([k for k, d in enumerate(self._demos) if np.array_equal(d.query, q)]
                if self._query_count.get(key) else [])
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
            self._query_count[key] = 1
        else:
            self._demos.append(demo)
            self._query_count[key] = self._query_count.get(key, 0) + 1
        self._queries = self._tree = None
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
        return self._query_array().copy()

    def _query_array(self) -> NDArray[np.float64]:
        if self._queries is None:
            queries = np.array([d.query for d in self._demos], dtype=np.float64)
            self._queries = queries.reshape(len(self), self.n_query)
        return self._queries

    def nearest(self, query: ArrayLike, k: int = 2) -> Database:
        """A new database with the ``k`` demonstrations whose queries are nearest ``query``
        (Euclidean distance in query units; ties keep database order). With ``"linear"``
        generalization, which takes n + 1 demos, this gives piecewise-linear generalization
        over a growing database.
        """
        q = self._check_query(query)
        k = as_count(k, "k", 1)
        if k > len(self):
            raise InvalidInputError(f"k = {k} but the database has {len(self)} demonstrations")
        queries = self._query_array()
        if self._tree is None:
            # scipy.spatial loads on the first nearest, not with import dmprs (a tenth of a second)
            from scipy.spatial import cKDTree

            self._tree = cKDTree(queries)
        # The tree finds the k-th distance; every demo within it (a hair more, for the tree's own
        # rounding) is then ranked exactly as a full stable sort would: by the same norm, ties in
        # database order.
        reach, _ = self._tree.query(q, k=[k])
        candidates = np.sort(np.asarray(self._tree.query_ball_point(q, float(reach[0]) * (1 + 1e-9) + 1e-300),
                                        dtype=np.intp))
        distance = np.linalg.norm(queries[candidates] - q, axis=1)
        order = candidates[np.argsort(distance, kind="stable")[:k]]
        out = Database(self._names, self._units)
        for i in sorted(order):
            demo = self._demos[i]
            out._demos.append(demo)
            key = _query_key(demo.query)
            out._query_count[key] = out._query_count.get(key, 0) + 1
        return out

    def __repr__(self) -> str:
        dims = ", ".join(f"{n} [{u}]" if u else n for n, u in zip(self._names, self._units, strict=True))
        return f"Database({len(self)} demos, query=({dims}), n_dof={self.n_dof})"

    # --- persistence ------------------------------------------------------------------------
    def save(self, path: str | os.PathLike[str]) -> None:
        """Writes the database to the directory ``path`` (created if missing) atomically; see the
        module docs. Refuses a non-empty directory that is not a dmprs database, leaving nothing
        in it.
        """
        root = Path(path)
        try:
            root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise DatabaseError(f"cannot create the database directory {root}: {exc}") from None
        synced, self._synced = self._synced, None  # a failed save trusts nothing next time
        try:
            mine = synced if synced is not None and synced.root == root.resolve() else None
            if mine is None or _manifest_identity(root) != mine.manifest:
                mine = None
                _refuse_foreign(root)  # before the lock file: a refused save writes nothing
            with directory_lock(root, shared=False):
                if mine is not None and _manifest_identity(root) != mine.manifest:
                    mine = None  # another process saved meanwhile
                if mine is None:
                    _refuse_foreign(root)
                self._synced = self._save_locked(root, mine)
        except OSError as exc:
            raise DatabaseError(f"{root}: cannot save the database ({exc.strerror or exc})") from None

    def _save_locked(self, root: Path, mine: _Synced | None) -> _Synced:
        """Writes the demo files not known whole and the manifest; ``mine``: the directory as
        this database last left it, if its manifest is still the one written then.
        """
        untouched = mine is not None and _directory_identity(root) == mine.directory
        present = _file_identities(root) if mine is not None and not untouched else {}
        files: dict[str, FileIdentity] = {}
        lines: list[str] = []
        pending: dict[str, bytes] = {}
        written: list[str] = []
        listed = mine.files if mine is not None else {}
        with ThreadPoolExecutor(_WRITERS) as pool:
            for demo in self._demos:  # per demo, the common case costs a few lookups: keep it so
                entry, data = demo._entry, None
                if entry is None or entry.metadata != demo.metadata:
                    entry, data = _entry_of(demo)
                name = entry.file
                lines.append(entry.line)
                if name in files or name in pending:
                    continue
                known = listed.get(name)
                if known is not None and (untouched or present.get(name) == known):
                    files[name] = known
                elif _is_own_demo(root / name, entry.sha256):
                    files[name] = _identity(root / name)
                else:
                    pending[name] = _npz_bytes(demo) if data is None else data
                    if len(pending) >= _WRITE_BATCH:
                        written += _write_all(pool, root, pending)
            written += _write_all(pool, root, pending)
        if written:
            fsync_dir(root)  # the new demo files' names are durable before the manifest names them
        files.update((name, _identity(root / name)) for name in written)
        header = {
            "format": _FORMAT,
            "schema_version": _POSE_SCHEMA if self.is_cartesian else 1,
            "query_names": list(self._names),
            "query_units": list(self._units),
        }
        _atomic_write(root / _MANIFEST, _manifest_text(header, lines).encode("utf-8"))
        # The new manifest is durable: the demo files it does not list can go, and so can the
        # temporary files of an interrupted earlier save (the lock says no save is running). Only
        # files that are provably ours: content-named demo files whose content matches their name
        # (a file merely named like one may be the user's), and our own temporary files. In a
        # directory untouched since this database's last save, those are the files it dropped.
        dropped = sorted(set(mine.files) - set(files)) if untouched and mine is not None else [
            name for name in regular_files(root) if name not in files and _DEMO_FILE.match(name)]
        for name in dropped:
            remove_if(root / name, functools.partial(_named_by_content, name), limit=DEMO_MAX_BYTES)
        if not untouched:
            remove_stale_temp_files(root, _is_own_file_name)
        manifest = _manifest_identity(root)
        if manifest is None:
            raise DatabaseError(f"{root / _MANIFEST}: gone right after it was written")
        return _Synced(root.resolve(), manifest, _directory_identity(root), files)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> Database:
        """Reads a database written by :meth:`save`, verifying every file. A read writes
        nothing (not even the lock file).
        """
        root = Path(path)
        if not root.is_dir():
            raise DatabaseError(f"{root / _MANIFEST}: cannot read the manifest (no directory {root})")
        with directory_lock(root, shared=True):
            manifest = _manifest_identity(root)
            db = cls._load_locked(root)
            directory = _directory_identity(root)
            identities = _file_identities(root)
        if manifest is not None:  # every listed file was just verified against its sha256
            listed = {d._entry.file for d in db._demos if d._entry is not None}
            db._synced = _Synced(root.resolve(), manifest, directory,
                                 {name: identities[name] for name in listed if name in identities})
        return db

    @classmethod
    def _load_locked(cls, root: Path) -> Database:
        mpath = root / _MANIFEST
        manifest = _read_manifest(mpath)
        version = manifest.get("schema_version")
        if not isinstance(version, int) or isinstance(version, bool) or version < 1:
            raise DatabaseError(f"{mpath}: invalid schema_version {version!r:.60}")
        if version > SCHEMA_VERSION:
            raise DatabaseError(
                f"{mpath}: schema version {version} was written by a newer dmprs; this version "
                f"reads up to schema version {SCHEMA_VERSION}. Upgrade dmprs to load it."
            )
        try:
            db = cls(manifest["query_names"], manifest["query_units"])
            entries = manifest["demos"]
        except (KeyError, TypeError, DmprsError) as exc:
            raise DatabaseError(f"{mpath}: malformed manifest ({exc})") from None
        if not isinstance(entries, list):
            raise DatabaseError(f"{mpath}: malformed manifest ('demos' is not a list)")
        for k, entry in enumerate(entries):
            demo = _read_demo(root, mpath, k, entry, db.n_query)
            try:
                added = db.add(demo.query, demo.trajectory, label=demo.label, metadata=demo.metadata,
                               on_duplicate="keep")  # as saved
            except DmprsError as exc:
                raise DatabaseError(f"{root / entry['file']}: {exc}") from None
            # verified by _read_demo: a save of this database need not read the file again
            object.__setattr__(added, "_entry", _entry(entry["file"], entry["sha256"], added.label, added.metadata))
        return db


#: Demo files are written by this many threads: each fsync waits for the disk, and concurrent
#: ones share a journal commit; at most _WRITE_BATCH files' bytes are held at a time.
_WRITERS = 8
_WRITE_BATCH = 256


def _write_all(pool: ThreadPoolExecutor, root: Path, pending: dict[str, bytes]) -> list[str]:
    """Writes the files ``pending`` (name to bytes) into ``root`` on the pool's threads, waits
    for all (raising the first failure), empties ``pending``; the names written.
    """
    writes = [pool.submit(_atomic_write, root / name, data, sync_dir=False) for name, data in pending.items()]
    for w in writes:
        w.result()
    names = list(pending)
    pending.clear()
    return names


def _manifest_text(header: dict[str, Any], lines: list[str]) -> str:
    """The manifest's JSON: the header indented, then one demo entry per line (readable, and
    each line made once per demo, by json's C encoder).
    """
    head = json.dumps(header, indent=2, allow_nan=False).removesuffix("\n}")
    demos = "\n    " + ",\n    ".join(lines) + "\n  " if lines else ""
    return f'{head},\n  "demos": [{demos}]\n}}\n'


def _npz_bytes(demo: Demo) -> bytes:
    # Sorted names after the query: the file's bytes, hence its content name, depend on nothing else.
    arrays = {"query": demo.query, **dict(sorted(demo.trajectory.to_arrays().items()))}
    buf = io.BytesIO()
    savez: Any = np.savez  # numpy's stub types the keyword arrays as its own options
    savez(buf, **arrays)
    return buf.getvalue()


def _read_manifest(mpath: Path) -> dict[str, Any]:
    """The manifest as a dict with this module's format tag, or a DatabaseError naming it."""
    if not os.path.lexists(mpath):
        raise DatabaseError(f"{mpath}: cannot read the manifest (no such file)")
    manifest = read_json(mpath, what="manifest", error=DatabaseError, limit=MANIFEST_MAX_BYTES)
    if not isinstance(manifest, dict) or manifest.get("format") != _FORMAT:
        raise DatabaseError(f"{mpath}: not a dmprs database manifest (no \"format\": \"{_FORMAT}\")")
    return manifest


def _is_own_file_name(name: str) -> bool:
    return name == _MANIFEST or bool(_DEMO_FILE.match(name))


def _is_own_temp(name: str) -> bool:
    """Whether ``name`` is a temporary file of this module's atomic writes."""
    target = atomic_temp_target(name)
    return target is not None and _is_own_file_name(target)


def _named_by_content(name: str, data: bytes) -> bool:
    """Whether ``data`` is the content the demo file name ``name`` was made from."""
    return hashlib.sha256(data).hexdigest()[:16] == name[5:21]


def _is_own_demo(path: Path, digest: str | None = None) -> bool:
    """Whether ``path`` is a regular file (not a link) holding the content of ``digest``, or (without
    one) the content its name was made from.
    """
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return False
        data = read_bytes(path, limit=DEMO_MAX_BYTES, error=DatabaseError)
    except (OSError, DatabaseError):
        return False
    return hashlib.sha256(data).hexdigest() == digest if digest else _named_by_content(path.name, data)


def _refuse_foreign(root: Path) -> None:
    """Raises unless ``root`` may hold this database: empty, a dmprs database (its manifest says
    so), or only the files of an interrupted first save (content-named demo files whose content
    matches their name, our temporary files). Anything else is somebody else's: never overwritten.
    """
    names = [e.name for e in os.scandir(root) if e.name != LOCK_FILE]
    if not names:
        return
    if _MANIFEST in names:
        try:
            _read_manifest(root / _MANIFEST)
        except DatabaseError as exc:
            raise DatabaseError(
                f"{root} holds a {_MANIFEST} that is not a dmprs database's ({exc}); refusing to write "
                "a database into it"
            ) from None
        return
    regular = set(regular_files(root))
    foreign = [n for n in sorted(names) if not (n in regular and (
        _is_own_temp(n) or (_DEMO_FILE.match(n) and _is_own_demo(root / n))))]
    if foreign:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        raise DatabaseError(
            f"{root} is a non-empty directory without a {_MANIFEST} (it holds {shown}); refusing to write "
            "a database into it"
        )


def _atomic_write(target: Path, data: bytes, *, sync_dir: bool = True) -> None:
    """Readers see the old file or the new one, never a partial one (:func:`dmprs._io.write_atomic`)."""
    try:
        write_atomic(target, data, sync_dir=sync_dir)
    except OSError as exc:
        raise DatabaseError(f"{target}: cannot write ({exc.strerror or exc})") from None


def _read_demo(root: Path, mpath: Path, k: int, entry: Any, n_query: int) -> Demo:
    if not isinstance(entry, dict) or not isinstance(entry.get("file"), str) or not isinstance(entry.get("sha256"), str):
        raise DatabaseError(f"{mpath}: demos[{k}] must have string 'file' and 'sha256' entries")
    name = entry["file"]
    if not _DEMO_FILE.match(name):
        raise DatabaseError(f"{mpath}: demos[{k}] names {name!r}, which is not a demo file of a dmprs database")
    fpath = root / name
    data = read_bytes(fpath, limit=DEMO_MAX_BYTES, what=f"file of demonstration {k}", error=DatabaseError)
    digest = hashlib.sha256(data).hexdigest()
    if digest != entry["sha256"]:
        raise DatabaseError(
            f"{fpath}: checksum mismatch (sha256 {digest[:16]}..., the manifest expects "
            f"{entry['sha256'][:16]:.16}...): the file is corrupted, truncated or was replaced"
        )
    try:
        arrays = load_npz(data, str(fpath), limit=DEMO_MAX_BYTES, error=DatabaseError, kinds="fiu")
    except DatabaseError as exc:
        why = str(exc).removeprefix(f"{fpath}: ")
        raise DatabaseError(f"{fpath}: not a readable demonstration file ({why})") from None
    for key, arr in arrays.items():
        if arr.dtype != np.float64:
            raise DatabaseError(f"{fpath}: array {key!r} has dtype {arr.dtype}, expected float64")
    q = arrays.pop("query", None)
    if q is None or q.shape != (n_query,):
        raise DatabaseError(f"{fpath}: query has shape {None if q is None else q.shape}, expected ({n_query},)")
    try:
        traj = from_arrays(arrays)
    except DmprsError as exc:
        raise DatabaseError(f"{fpath}: invalid trajectory ({exc})") from None
    if traj is None:
        raise DatabaseError(f"{fpath}: arrays {sorted(arrays)} hold no trajectory (no 't')")
    label = entry.get("label")
    metadata = entry.get("metadata", {})
    if (label is not None and not isinstance(label, str)) or not isinstance(metadata, dict):
        raise DatabaseError(f"{mpath}: demos[{k}] has a malformed label or metadata")
    return Demo(q, traj, label, metadata)
