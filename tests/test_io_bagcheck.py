"""Bags checked before rosbags opens them (dmprs.io.bagcheck): compressed bags of every kind rosbags
writes read back exactly, compression bombs of every kind are refused after a bounded amount of
work (nothing written to the temporary directory), and FIFOs, devices and crafted metadata are
refused at once, naming the file.
"""

from __future__ import annotations

import os
import re
import struct
import tempfile

import numpy as np
import pytest

from dmprs.errors import InvalidInputError
from dmprs.io import bag_topics, bagcheck, read_joint_states
from tests.bag_writers import (
    compressed_bag,
    file_bomb,
    mcap_chunk_bomb,
    message_bomb,
    ros1_chunk_bomb,
)

KINDS = [("ros2-sqlite3", "file"), ("ros2-sqlite3", "message"), ("ros2-mcap", "file"), ("ros2-mcap", "message"),
         ("ros2-mcap", "storage"), ("ros1", "bz2"), ("ros1", "lz4")]
ZEROS = 2 * 2**20


def bag(tmp_path, fmt, compression):
    return compressed_bag(tmp_path / ("b.bag" if fmt == "ros1" else "b"), fmt, compression)


@pytest.fixture
def small_limits(monkeypatch, tmp_path):
    """Pieces may inflate to 1 MiB + 100 x their size; rosbags' temporary files go to a fresh
    directory, which must stay empty.
    """
    monkeypatch.setattr(bagcheck, "INFLATE_FLOOR_BYTES", 2**20)
    tmp = tmp_path / "tmpdir"
    tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(tmp))
    yield tmp
    assert list(tmp.iterdir()) == []


@pytest.mark.parametrize(("fmt", "compression"), KINDS)
def test_compressed_bags_of_every_kind_read_back_exactly(tmp_path, fmt, compression):
    rec = read_joint_states(bag(tmp_path, fmt, compression))
    np.testing.assert_array_equal(rec.trajectory.y[:, 0], np.sin(np.arange(50) / 10))
    np.testing.assert_allclose(rec.trajectory.t, np.arange(50) * 0.01, atol=1e-12)


@pytest.mark.parametrize(("fmt", "compression", "make"), [
    ("ros2-sqlite3", "file", file_bomb),
    ("ros2-sqlite3", "message", message_bomb),
    ("ros2-mcap", "storage", mcap_chunk_bomb),
    ("ros1", "bz2", ros1_chunk_bomb),
    ("ros1", "lz4", ros1_chunk_bomb),
])
def test_compression_bombs_are_refused_before_rosbags_inflates_them(tmp_path, small_limits, fmt, compression, make):
    path = bag(tmp_path, fmt, compression)
    make(path, ZEROS)
    codec = {"file": "zstd", "message": "zstd", "storage": "zstd"}.get(compression, compression)
    with pytest.raises(InvalidInputError, match=rf"{codec} data inflates to more than \d+ bytes, the limit"
                                                r" for \d+ compressed bytes \(100 x that \+ 1 MiB"):
        read_joint_states(path)
    bagcheck.INFLATE_FLOOR_BYTES = 64 * 2**20  # within the default limits (monkeypatch restores them)
    if make is message_bomb:  # rosbags inflates the padded message, and CDR refuses the padding
        with pytest.raises(InvalidInputError, match=r"not a readable ROS bag.*CDR message size mismatch"):
            read_joint_states(path)
    else:  # the padding is ignored (sqlite pages, empty MCAP records, bytes after the ROS 1 messages)
        assert len(read_joint_states(path).trajectory) == 50


def test_a_chunk_inflating_beyond_its_declared_size_is_refused_at_that_size(tmp_path):
    path = bag(tmp_path, "ros2-mcap", "storage")
    mcap_chunk_bomb(path, ZEROS, declare=1000)
    with pytest.raises(InvalidInputError, match=r"a chunk declaring 1000 bytes\): zstd data inflates to more than 1000 bytes"):
        read_joint_states(path)


def test_a_chunk_index_pointing_elsewhere_is_refused(tmp_path):
    path = bag(tmp_path, "ros2-mcap", "storage")
    (f,) = path.glob("*.mcap")
    data = bytearray(f.read_bytes())
    pos = 8
    while data[pos] != 0x08:  # the first chunk index record, in the summary
        pos += 9 + struct.unpack_from("<Q", data, pos + 1)[0]
    data[pos + 9 + 16:pos + 9 + 24] = struct.pack("<Q", 8)
    f.write_bytes(bytes(data))
    with pytest.raises(InvalidInputError, match=r"b\.mcap: its chunk index points at byte 8, where no such chunk is"):
        read_joint_states(path)


def test_a_fifo_or_a_device_in_a_bag_is_refused_at_once_naming_it(tmp_path):
    path = bag(tmp_path, "ros2-sqlite3", "none")
    (path / "metadata.yaml").rename(tmp_path / "metadata.yaml")
    os.mkfifo(path / "metadata.yaml")
    with pytest.raises(InvalidInputError, match=r"b/metadata\.yaml: is a FIFO"):
        bag_topics(path)
    (path / "metadata.yaml").unlink()
    (tmp_path / "metadata.yaml").rename(path / "metadata.yaml")
    (db3,) = path.glob("*.db3")
    db3.unlink()
    db3.symlink_to("/dev/zero")
    with pytest.raises(InvalidInputError, match=r"b\.db3: is a character device; a bag storage file must be a regular file"):
        bag_topics(path)
    ros1 = tmp_path / "zero.bag"
    ros1.symlink_to("/dev/zero")
    with pytest.raises(InvalidInputError, match=r"zero\.bag: is a character device"):
        bag_topics(ros1)


def test_crafted_metadata_is_a_clear_error_naming_the_file(tmp_path, monkeypatch):
    path = bag(tmp_path, "ros2-sqlite3", "none")
    meta = path / "metadata.yaml"
    good = meta.read_text()
    for text, why in [
        ("a: [unclosed", "not readable YAML"),
        ("- just a list", "no 'rosbag2_bagfile_information' mapping"),
        ("rosbag2_bagfile_information: {relative_file_paths: 7}", "'relative_file_paths' must be a list"),
        ("rosbag2_bagfile_information: {relative_file_paths: [nothing.db3]}", r"nothing\.db3: no such bag storage file"),
        ("\xff", "not utf-8 text"),
        (re.sub(r"nanoseconds_since_epoch: \d+", "nanoseconds_since_epoch: 1180591620717411303424", good),
         "the bag's start time 1180591620717411303424 ns is out of range"),
        (good.replace("version: 9", "version: 99"), "not a readable ROS bag"),
    ]:
        meta.write_bytes(text.encode("latin-1") if text == "\xff" else text.encode())
        with pytest.raises(InvalidInputError, match=why):
            read_joint_states(path)
    monkeypatch.setattr(bagcheck, "METADATA_MAX_BYTES", 100)
    meta.write_text(good)
    with pytest.raises(InvalidInputError, match=r"metadata\.yaml: \d+ bytes, more than the 100 bytes a bag metadata file may have"):
        read_joint_states(path)


@pytest.mark.parametrize(("fmt", "compression"), [("ros2-sqlite3", "none"), ("ros2-mcap", "storage"), ("ros1", "bz2")])
def test_truncated_and_flipped_bags_are_clear_errors(tmp_path, fmt, compression):
    path = bag(tmp_path, fmt, compression)
    (f,) = [path] if fmt == "ros1" else [p for p in path.iterdir() if p.suffix in (".db3", ".mcap")]
    data = f.read_bytes()
    rng = np.random.default_rng(0)
    for k in range(12):
        if k < 6:
            damaged = data[: len(data) * k // 6]
        else:
            damaged = bytearray(data)
            for j in rng.integers(0, len(data), 8):
                damaged[j] ^= 0xFF
        f.write_bytes(bytes(damaged))
        try:
            rec = read_joint_states(path)
        except InvalidInputError as exc:
            assert str(f.name) in str(exc) or str(path) in str(exc)
        else:  # flipped bytes in a value, a name or padding: still a valid recording
            assert np.isfinite(rec.trajectory.y).all()


def test_a_lone_mcap_file_is_checked_too(tmp_path, small_limits):
    path = bag(tmp_path, "ros2-mcap", "storage")
    mcap_chunk_bomb(path, ZEROS)
    (f,) = path.glob("*.mcap")
    with pytest.raises(InvalidInputError, match=r"b\.mcap, record at byte \d+ \(a chunk declaring \d+ bytes\): zstd data "
                                                "inflates to more than"):
        read_joint_states(f)
