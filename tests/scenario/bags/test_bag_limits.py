"""A stranger's bag checked before rosbags reads it (uvms.scenario.bags.limits, through read_bag): decompression
bombs, compressed bags, message counts, an oversized metadata.yaml, a FIFO for a storage file, SQLite views and a
bag's own definition of a standard message. The bags are a few messages written with rosbags' writer."""

from __future__ import annotations

import os
import sqlite3
import struct
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from uvms.errors import IdentificationError
from uvms.scenario.bags import limits as bag_limits
from uvms.scenario.bags import reader as bag_reader
from uvms.scenario.bags.reader import read_bag
from uvms.scenario.bags.writer import Messages

ROOT = Path(__file__).resolve().parents[3]
STORE = get_typestore(Stores.ROS2_HUMBLE)
MAGIC = b"\x89MCAP0\r\n"


def small_bag(path: Path, storage=StoragePlugin.MCAP, count: int = 3, compression=None, store=STORE) -> Path:
    """``count`` odometry and wrench messages (10 Hz), as ``uvms run --bag`` names their topics; with ``store``,
    the odometry of that typestore's own nav_msgs/msg/Odometry (a header and one number)."""
    messages = Messages(STORE)
    writer = Writer(path, version=8, storage_plugin=storage)
    if compression is not None:
        writer.set_compression(compression, CompressionFormat.ZSTD)
    with writer:
        odom = writer.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)
        wrench = writer.add_connection("/body_wrench", "geometry_msgs/msg/WrenchStamped", typestore=STORE)
        for k in range(count):
            stamp = 100_000_000 * k
            if store is STORE:
                message = messages.odometry(stamp, "base", pin.SE3.Identity(), pin.Motion.Zero())
            else:
                message = store.types["nav_msgs/msg/Odometry"](header=messages.header(stamp, "odom"), x=1.0)
            writer.write(odom, stamp, store.serialize_cdr(message, "nav_msgs/msg/Odometry"))
            writer.write(wrench, stamp, messages.serialize(messages.wrench(stamp, "base", np.zeros(6))))
    return path


def mcap_with_chunk(declared: int, payload: bytes, compression: str = "zstd") -> bytes:
    """A minimal MCAP file (no summary) holding one chunk that declares ``declared`` bytes inflated."""
    def string(text: str) -> bytes:
        return struct.pack("<I", len(text)) + text.encode()

    def record(op: int, content: bytes) -> bytes:
        return struct.pack("<BQ", op, len(content)) + content

    chunk = struct.pack("<QQQI", 0, 1, declared, 0) + string(compression) + struct.pack("<Q", len(payload)) + payload
    footer = record(0x02, struct.pack("<QQI", 0, 0, 0))
    return MAGIC + record(0x01, string("ros2") + string("")) + record(0x06, chunk) + record(0x0F, b"\0" * 4) \
        + footer + MAGIC


def zstd_of_zeros(size: int) -> bytes:
    """zstd frames of ``size`` zero bytes, compressed 1 MiB at a time (a few KiB)."""
    from backports import zstd

    compressor = zstd.ZstdCompressor()
    block = bytes(1 << 20)
    return b"".join(compressor.compress(block) for _ in range(size >> 20)) + compressor.flush()


def in_child(code: str) -> str:
    """What ``code`` prints in a child Python (a bag that blocks or spins cannot hang the suite: 60 s at most)."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False,
                          env={**os.environ, "PYTHONPATH": str(ROOT)}, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


READ_IN_CHILD = """
from uvms.errors import IdentificationError
from uvms.scenario.bags.reader import read_bag
from uvms.scenario.bags.writer import Messages
try:
    read_bag({path!r}, arm_joints=())
except IdentificationError as exc:
    print(exc)
"""


@pytest.mark.parametrize("declared, inflated, message", [
    (1024, 96 << 20, "inflates to more than the 1,024 bytes it declares"),
    (2 << 30, 1024, "declares 2,048 MiB inflated; at most 64 MiB per chunk"),
])
def test_an_mcap_chunk_is_inflated_no_further_than_it_declares_and_the_cap(tmp_path, declared, inflated, message):
    """rosbags inflates a chunk whole whatever it declares (96 MiB from 4 KiB here); uvms refuses within the
    declared size, so the read's memory stays far below the bomb's."""
    bag = small_bag(tmp_path / "bag")
    next(bag.glob("*.mcap")).write_bytes(mcap_with_chunk(declared, zstd_of_zeros(inflated)))
    tracemalloc.start()
    try:
        with pytest.raises(IdentificationError, match=message):
            read_bag(bag, arm_joints=())
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20, f"{peak / 2**20:.1f} MiB"


def test_a_compressed_bag_is_refused_with_how_to_decompress_it(tmp_path):
    """rosbags would inflate a file-compressed bag into $TMPDIR, outside --out and without a bound."""
    bag = small_bag(tmp_path / "bag", compression=CompressionMode.FILE)
    with pytest.raises(IdentificationError, match=r"compressed \(compression_mode: file\).*ros2 bag convert"):
        read_bag(bag, arm_joints=())


def test_more_messages_than_identification_reads_are_refused_however_counted(tmp_path, monkeypatch):
    """The counts metadata.yaml declares, the storage's own (the MCAP's chunks walked), and those read."""
    bag = small_bag(tmp_path / "bag", count=5)
    monkeypatch.setattr(bag_limits, "MAX_LOG_SAMPLES", 4)
    monkeypatch.setattr(bag_reader, "MAX_LOG_SAMPLES", 4)
    with pytest.raises(IdentificationError, match=r"topic '/odom' holds 5 messages; identification reads at most 4"):
        read_bag(bag, arm_joints=())
    metadata = bag / "metadata.yaml"
    metadata.write_text(metadata.read_text().replace("message_count: 5", "message_count: 1")
                        .replace("message_count: 10", "message_count: 2"))  # a bag that lies about its counts
    with pytest.raises(IdentificationError, match=r"topic '/odom' holds 5 messages"):
        read_bag(bag, arm_joints=())  # counted while reading
    monkeypatch.setattr(bag_limits, "MAX_BAG_MESSAGES", 9)
    with pytest.raises(IdentificationError, match=r"holds more than 9 messages"):
        read_bag(bag, arm_joints=())  # counted in the MCAP's chunks before reading


def test_an_oversized_metadata_yaml_is_refused_before_it_is_parsed(tmp_path):
    bag = small_bag(tmp_path / "bag")
    with open(bag / "metadata.yaml", "a") as handle:
        handle.write(("# padding\n" * 1024) * 210)  # 2.1 MiB
    with pytest.raises(IdentificationError, match=r"metadata YAML file holds 2.1 MiB; at most 1 MiB"):
        read_bag(bag, arm_joints=())


def test_a_storage_file_that_is_a_fifo_is_refused_not_waited_on(tmp_path):
    bag = small_bag(tmp_path / "bag")
    storage = next(bag.glob("*.mcap"))
    storage.unlink()
    os.mkfifo(storage)
    assert "is not a regular file (a FIFO" in in_child(READ_IN_CHILD.format(path=str(bag)))


@pytest.mark.parametrize("table, statement, message", [
    ("schema", ("CREATE VIEW schema AS WITH RECURSIVE c(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM c) "
                "SELECT 4 AS schema_version, 'humble' AS ros_distro FROM (SELECT max(x) FROM c)"),
     "'schema' is a view"),
    ("messages", ("CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER, timestamp INTEGER, "
                  "data BLOB GENERATED ALWAYS AS (zeroblob(2000000000)))"), "'messages' has generated columns"),
])
def test_a_sqlite_table_that_runs_a_query_is_refused(tmp_path, table, statement, message):
    """A view over an endless query hung rosbags inside SQLite (only SIGKILL ended it); a generated column would
    hand it 2 GB per row."""
    bag = small_bag(tmp_path / "bag", storage=StoragePlugin.SQLITE3)
    with sqlite3.connect(next(bag.glob("*.db3"))) as connection:
        connection.execute(f"DROP TABLE {table}")
        connection.execute(statement)
    assert message in in_child(READ_IN_CHILD.format(path=str(bag)))


def test_a_bag_with_its_own_definition_of_odometry_is_refused(tmp_path):
    """Before: rosbags read the messages with the bag's definition, and the reader failed on a missing field."""
    own = get_typestore(Stores.EMPTY)
    own.register({name: STORE.fielddefs[name] for name in ("std_msgs/msg/Header", "builtin_interfaces/msg/Time")})
    own.register(get_types_from_msg("std_msgs/Header header\nfloat64 x\n", "nav_msgs/msg/Odometry"))
    bag = small_bag(tmp_path / "bag", count=60, store=own)
    with pytest.raises(IdentificationError, match=r"topic '/odom' carries its own definition of nav_msgs/msg/Odometry"):
        read_bag(bag, arm_joints=())
