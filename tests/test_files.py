"""The file layer every reader and writer goes through (dmprs._io): regular files only, sizes and
JSON bounded before anything is allocated, and no write through a link.
"""

from __future__ import annotations

import io
import json
import os
import struct
import zipfile

import numpy as np
import pytest

from dmprs._io import (
    append_jsonl,
    atomic_temp_target,
    create_empty,
    directory_lock,
    inflate_bounded,
    load_npz,
    parse_json,
    read_bytes,
    read_json,
    read_jsonl,
    regular_files,
    remove_if,
    remove_stale_temp_files,
    truncate_cut_line,
    write_atomic,
)
from dmprs.errors import DatabaseError, InvalidInputError


def test_a_fifo_is_refused_at_once_without_blocking(tmp_path):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    with pytest.raises(InvalidInputError, match=r"pipe: is a FIFO \(named pipe\); a manifest must be a regular file"):
        read_bytes(fifo, limit=100, what="manifest")


def test_a_link_to_a_device_is_refused_naming_the_path(tmp_path):
    link = tmp_path / "zero.json"
    link.symlink_to("/dev/zero")
    with pytest.raises(DatabaseError, match=r"zero\.json: is a character device"):
        read_json(link, error=DatabaseError)


def test_a_link_to_a_regular_file_is_read(tmp_path):
    (tmp_path / "a.json").write_text('{"x": 1}')
    (tmp_path / "b.json").symlink_to(tmp_path / "a.json")
    assert read_json(tmp_path / "b.json") == {"x": 1}


def test_size_is_bounded_before_reading(tmp_path):
    f = tmp_path / "big"
    f.write_bytes(b"x" * 101)
    with pytest.raises(InvalidInputError, match="101 bytes, more than the 100 bytes"):
        read_bytes(f, limit=100)
    assert read_bytes(f, limit=101) == b"x" * 101


def test_a_directory_and_a_missing_file_say_so(tmp_path):
    with pytest.raises(InvalidInputError, match="is a directory"):
        read_bytes(tmp_path, limit=10)
    with pytest.raises(InvalidInputError, match="no such file"):
        read_bytes(tmp_path / "nope", limit=10)


def test_text_that_is_not_utf8_names_the_encoding_and_offset(tmp_path):
    f = tmp_path / "t.json"
    f.write_bytes(b'{"a": "\xff"}')
    with pytest.raises(InvalidInputError, match=r"not utf-8 text \(byte 7"):
        read_json(f)


@pytest.mark.parametrize(("text", "why"), [
    ("[" * 100 + "]" * 100, "nested too deeply"),
    ("[" * 100000 + "]" * 100000, "nested too deeply"),
    ("1" * 5000, "too large"),
    ("1e999", "too large for a float"),
    ("NaN", "not valid JSON"),
    ('{"a": Infinity}', "not valid JSON"),
    ('{"a": ', "not valid JSON"),
])
def test_json_is_bounded(text, why):
    with pytest.raises(InvalidInputError, match=why):
        parse_json(text, "f.json")


def test_json_within_bounds_parses_exactly():
    value = {"a": [1, -2.5e-300, "NaN"], "b": {"c": [[[]]]}, "n": 2**63 - 1}
    assert parse_json(json.dumps(value), "f") == value


def _npz(**arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def test_npz_round_trip_and_dtype_check():
    data = _npz(a=np.arange(6.0).reshape(2, 3), b=np.asarray(3.5), c=np.asfortranarray(np.eye(3)))
    out = load_npz(data, "x.npz", limit=10**6)
    assert np.array_equal(out["a"], np.arange(6.0).reshape(2, 3)) and out["b"].shape == ()
    assert np.array_equal(out["c"], np.eye(3))
    with pytest.raises(InvalidInputError, match="dtype <U"):
        load_npz(_npz(s=np.array(["x"])), "x.npz", limit=10**6)


def test_an_npy_header_claiming_terabytes_is_refused_before_allocating():
    data = bytearray(_npz(a=np.zeros(4)))
    header = b"{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000,), }"
    # rewrite the member: same header length is not needed, build a fresh zip
    npy = b"\x93NUMPY\x01\x00" + struct.pack("<H", 118) + header.ljust(117) + b"\n" + bytes(32)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("a.npy", npy)
    with pytest.raises(InvalidInputError, match="claims 8000000000000 bytes of data"):
        load_npz(buf.getvalue(), "bomb.npz", limit=10**9)
    assert data  # the valid file above was well formed


def test_a_deflate_bomb_is_refused_by_its_declared_size():
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as z:
        z.writestr("a.npy", b"\x00" * (50 * 2**20))
    assert len(buf.getvalue()) < 2**20
    with pytest.raises(InvalidInputError, match="would inflate to 52428800 bytes"):
        load_npz(buf.getvalue(), "bomb.npz", limit=2**20)


def test_garbage_is_a_clear_error():
    with pytest.raises(InvalidInputError, match="not a readable npz file"):
        load_npz(b"PK\x03\x04garbage", "g.npz", limit=100)


def test_no_write_follows_a_link(tmp_path, outside):
    inside = tmp_path / "db"
    inside.mkdir()
    (inside / ".dmprs.lock").symlink_to(outside / "created-by-a-lock")
    with pytest.raises(OSError, match="symbolic link"), directory_lock(inside, shared=False):
        pass
    (inside / "log.jsonl").symlink_to(outside / "created-by-an-append")
    with pytest.raises(OSError, match="symbolic link"):
        append_jsonl(inside / "log.jsonl", {"a": 1})
    with pytest.raises(OSError, match="symbolic link"):
        truncate_cut_line(inside / "log.jsonl")
    (inside / "m.json").symlink_to(outside / "target.json")
    write_atomic(inside / "m.json", b"{}")  # replaces the link itself
    assert not (inside / "m.json").is_symlink() and list(outside.iterdir()) == []


def test_a_read_never_creates_the_lock_file(tmp_path):
    with directory_lock(tmp_path, shared=True):
        pass
    assert list(tmp_path.iterdir()) == []
    with directory_lock(tmp_path, shared=False):
        pass
    with directory_lock(tmp_path, shared=True):
        pass
    assert [p.name for p in tmp_path.iterdir()] == [".dmprs.lock"]


def test_an_append_into_a_fifo_is_refused_without_blocking(tmp_path):
    os.mkfifo(tmp_path / "log.jsonl")
    with pytest.raises(OSError, match="is a FIFO"):
        append_jsonl(tmp_path / "log.jsonl", {"a": 1})


def test_read_jsonl_names_the_line_and_tolerates_only_a_cut_last_line(tmp_path):
    f = tmp_path / "t.jsonl"
    f.write_text('{"a": 1}\n[1]\n{"b": 2}\n')
    with pytest.raises(InvalidInputError, match=r"t\.jsonl, line 2: not a JSON record"):
        read_jsonl(f)
    f.write_text('{"a": 1}\n{"b": ')
    records, cut = read_jsonl(f)
    assert records == [{"a": 1}] and "line 2" in cut


def test_the_temp_files_of_atomic_writes_are_recognised_by_name(tmp_path, monkeypatch):
    import tempfile

    names = []
    real = tempfile.mkstemp

    def spy(*args, **kwargs):
        fd, name = real(*args, **kwargs)
        names.append(os.path.basename(name))
        return fd, name

    monkeypatch.setattr(tempfile, "mkstemp", spy)
    write_atomic(tmp_path / "manifest.json", b"{}")
    assert atomic_temp_target(names[0]) == "manifest.json"  # the name write_atomic really used
    assert atomic_temp_target("manifest.json") is None and atomic_temp_target(".x.tmp") is None


def test_regular_files_follow_no_link_and_skip_fifos_and_folders(tmp_path):
    (tmp_path / "a").write_text("a")
    (tmp_path / "link").symlink_to(tmp_path / "a")
    os.mkfifo(tmp_path / "fifo")
    (tmp_path / "dir").mkdir()
    assert regular_files(tmp_path) == ["a"]


def test_create_empty_never_through_a_link_nor_into_a_fifo(tmp_path):
    create_empty(tmp_path / "new")
    (tmp_path / "new").write_text("kept")
    create_empty(tmp_path / "new")  # an existing file is left as it is
    assert (tmp_path / "new").read_text() == "kept"
    (tmp_path / "link").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(OSError, match="symbolic link"):
        create_empty(tmp_path / "link")
    assert not (tmp_path / "elsewhere").exists()
    os.mkfifo(tmp_path / "fifo")
    with pytest.raises(OSError, match="FIFO"):
        create_empty(tmp_path / "fifo")


def test_remove_if_removes_only_regular_files_whose_content_is_ours(tmp_path):
    (tmp_path / "ours").write_bytes(b"ours")
    (tmp_path / "theirs").write_bytes(b"theirs")
    (tmp_path / "big").write_bytes(b"ours" * 100)
    (tmp_path / "link").symlink_to(tmp_path / "ours")
    os.mkfifo(tmp_path / "fifo")
    ours = lambda data: data.startswith(b"ours")
    assert [remove_if(tmp_path / n, ours, limit=10) for n in ("link", "fifo", "theirs", "big", "ours")] == [
        False, False, False, False, True]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big", "fifo", "link", "theirs"]


def test_stale_temp_files_are_removed_only_for_the_targets_named(tmp_path):
    for name in (".manifest.json.abcd_123.tmp", ".notes.txt.abcd_123.tmp", ".manifest.json.tmp", "x.tmp"):
        (tmp_path / name).write_text("")
    (tmp_path / ".manifest.json.zzzz_999.tmp").symlink_to(tmp_path / "x.tmp")
    removed = remove_stale_temp_files(tmp_path, lambda target: target == "manifest.json")
    assert removed == [".manifest.json.abcd_123.tmp"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        ".manifest.json.tmp", ".manifest.json.zzzz_999.tmp", ".notes.txt.abcd_123.tmp", "x.tmp"]


@pytest.mark.parametrize("codec", ["zstd", "bz2", "lz4"])
def test_inflation_is_bounded_piece_by_piece(codec):
    import bz2

    import lz4.frame
    from backports import zstd

    compress = {"zstd": zstd.compress, "bz2": bz2.compress, "lz4": lz4.frame.compress}[codec]
    data = bytes(range(256)) * 4096  # 1 MiB
    packed = compress(data)
    assert inflate_bounded(packed, codec, limit=len(data), where="x") == (len(data), b"")
    assert inflate_bounded(packed, codec, limit=len(data), where="x", keep=True)[1] == data
    bomb = compress(bytes(8 * 2**20))
    with pytest.raises(InvalidInputError, match=rf"bomb: {codec} data inflates to more than 1048576 bytes, the limit; why"):
        inflate_bounded(bomb, codec, limit=2**20, where="bomb", why="; why")
    with pytest.raises(InvalidInputError, match=rf"cut: corrupt {codec} data"):
        inflate_bounded(packed[: len(packed) // 2], codec, limit=2**30, where="cut")
