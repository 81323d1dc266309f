"""A stranger's rosbag2 folder checked before ``rosbags`` opens it, so that reading it is bounded.

``rosbags`` trusts what a bag says about itself: it inflates an MCAP chunk whole (its zstd and lz4 calls ignore
the size the chunk declares), reads a record of whatever length the record declares, unpacks a file-compressed bag
into ``$TMPDIR``, decompresses each message of a message-compressed one without a bound, and runs its queries on a
SQLite file whose tables may be views over an endless query. :func:`check_bag` refuses, before ``rosbags`` reads a
byte of the storage:

- a ``metadata.yaml`` over :data:`~uvms.model.resources.MAX_YAML_BYTES` (read by the project's bounded YAML reader);
- a compressed bag (``compression_mode: file`` or ``message``): the user decompresses it first;
- a storage file named in ``metadata.yaml`` that is not a regular file (a FIFO would block the read), or storage
  files above :data:`MAX_BAG_BYTES` together;
- more than :data:`MAX_BAG_MESSAGES` messages in the bag, or more than
  :data:`~uvms.dynamics.identification.data.MAX_LOG_SAMPLES` on a topic identification reads (as
  ``metadata.yaml`` declares them and as the storage holds them);
- an MCAP file whose records do not fit in it, a chunk that declares more than :data:`MAX_CHUNK_BYTES` inflated,
  chunks that declare more than :data:`MAX_INFLATED_BYTES` together (counted per chunk index entry, as ``rosbags``
  inflates each), or a chunk that inflates to more than it declares (inflated here with that bound);
- a SQLite file whose tables ``rosbags`` reads are views, virtual tables or have generated columns, or whose
  checks take more than :data:`SQLITE_SECONDS` (a progress handler interrupts SQLite).

:func:`uvms.scenario.bags.reader.read_bag` counts the messages it keeps again while reading.
"""

from __future__ import annotations

import mmap
import os
import sqlite3
import stat
import struct
import time
from collections.abc import Mapping
from pathlib import Path, PurePath
from urllib.parse import quote

from ...dynamics.identification.data import MAX_LOG_SAMPLES
from ...errors import IdentificationError, UVMSError
from ...model.resources import read_yaml

#: The storage files of a bag on disk together [bytes].
MAX_BAG_BYTES = 1 << 30
#: One MCAP chunk inflated [bytes] (rosbag2 writes chunks of 768 KiB).
MAX_CHUNK_BYTES = 64 << 20
#: The MCAP chunks inflated together, as their index entries declare them [bytes].
MAX_INFLATED_BYTES = 512 << 20
#: Messages in a bag, every topic counted (filter a larger one to the topics identification reads).
MAX_BAG_MESSAGES = 2_000_000
#: The MCAP summary section [bytes] (a chunk index entry is about 100 bytes).
MAX_SUMMARY_BYTES = 16 << 20
#: Wall time of the checks of one SQLite file [s].
SQLITE_SECONDS = 10.0
#: The SQLite tables rosbags reads.
SQLITE_TABLES = ("messages", "topics", "schema", "metadata", "message_definitions")

MAGIC = b"\x89MCAP0\r\n"
_RECORD = struct.Struct("<BQ")  # opcode, length
_CHUNK = struct.Struct("<QQQI")  # start, end, uncompressed size, crc
_U32, _U64 = struct.Struct("<I"), struct.Struct("<Q")
_CHUNK_OP, _MESSAGE_OP, _CHUNK_INDEX_OP, _FOOTER_OP, _SUMMARY_OFFSET_OP = 0x06, 0x05, 0x08, 0x02, 0x0E
DECOMPRESS_HINT = ("decompress it first: ros2 bag convert -i BAG -o OUT.yaml, OUT.yaml naming an output bag without "
                   "compression")
FILTER_HINT = "cut it to the topics and the time span identification reads (ros2 bag convert)"


def damaged(folder: Path, detail: str) -> IdentificationError:
    """The error of a bag that cannot be read (the same words as any storage error of ``rosbags``)."""
    return IdentificationError(f"cannot read the bag {str(folder)!r} (truncated or damaged?): {detail}; a complete "
                               "rosbag2 recording is needed (ros2 bag reindex may repair one)")


def check_bag(folder: Path, topics: Mapping[str, str]) -> None:
    """Refuse a bag whose reading by ``rosbags`` would not be bounded (module docstring).

    Args:
        folder: the rosbag2 folder (its ``metadata.yaml`` exists); topics: {role: topic} identification reads.

    Raises:
        IdentificationError: what is wrong and what is valid.
    """
    try:
        document = read_yaml(folder / "metadata.yaml", "rosbag2 metadata")
    except UVMSError as exc:
        raise IdentificationError(" ".join(str(exc).split())) from None
    info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
    if not isinstance(info, dict):
        raise damaged(folder, "metadata.yaml has no rosbag2_bagfile_information mapping")
    mode = str(info.get("compression_mode") or "none").lower()
    if mode != "none":
        raise IdentificationError(f"{folder}: the bag is compressed (compression_mode: {mode}), which uvms does not "
                                  f"inflate (unbounded, and outside the output folder); {DECOMPRESS_HINT}")
    _check_counts(folder, info, topics)
    files = info.get("relative_file_paths")
    if not isinstance(files, list) or not all(isinstance(name, str) for name in files):
        raise damaged(folder, "metadata.yaml's relative_file_paths is not a list of file names")
    paths = [folder / PurePath(name).name for name in files]  # where rosbags looks for them
    total = 0
    for path in paths:
        try:
            status = os.stat(path)
        except OSError:
            continue  # a missing file: rosbags names it
        if not stat.S_ISREG(status.st_mode):
            raise IdentificationError(f"{path}: the bag's storage file is not a regular file (a FIFO, a device or a "
                                      "folder); a rosbag2 storage file is a regular .mcap or .db3 file")
        total += status.st_size
    if total > MAX_BAG_BYTES:
        raise IdentificationError(f"{folder}: the bag's storage files hold {total / 2**20:,.0f} MiB; at most "
                                  f"{MAX_BAG_BYTES >> 20} MiB are read: {FILTER_HINT}")
    storage = info.get("storage_identifier")
    for path in paths:
        if path.is_file() and storage == "mcap":
            check_mcap(path, folder)
        elif path.is_file() and storage == "sqlite3":
            check_sqlite(path, folder, topics)


def _check_counts(folder: Path, info: dict, topics: Mapping[str, str]) -> None:
    """The message counts ``metadata.yaml`` declares, per topic read and in all."""
    total = info.get("message_count")
    if isinstance(total, int) and total > MAX_BAG_MESSAGES:
        raise IdentificationError(f"{folder}: the bag holds {total:,} messages (metadata.yaml); at most "
                                  f"{MAX_BAG_MESSAGES:,} are read: {FILTER_HINT}")
    entries = info.get("topics_with_message_count")
    for entry in entries if isinstance(entries, list) else ():
        name = entry.get("topic_metadata", {}).get("name") if isinstance(entry, dict) else None
        count = entry.get("message_count") if isinstance(entry, dict) else None
        if name in topics.values() and isinstance(count, int):
            check_topic_count(folder, name, count)


def check_topic_count(folder: Path, topic: str, count: int) -> None:
    """Refuse a topic identification reads with more than MAX_LOG_SAMPLES messages."""
    if count > MAX_LOG_SAMPLES:
        raise IdentificationError(f"{folder}: topic {topic!r} holds {count:,} messages; identification reads at "
                                  f"most {MAX_LOG_SAMPLES:,} per topic: {FILTER_HINT}")


# ------------------------------------------------------------------ MCAP
def check_mcap(path: Path, folder: Path) -> None:
    """Walk an MCAP file's records as ``rosbags`` would, each within the file, every chunk inflated within what it
    declares and what the caps allow, the messages counted (module docstring)."""
    size = path.stat().st_size
    if size < 2 * len(MAGIC) + 9 + 29:
        raise damaged(folder, f"{path.name} is too short for an MCAP file")
    with open(path, "rb") as handle, mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ) as data:
        if data[:8] != MAGIC or data[-8:] != MAGIC or data[size - 37] != _FOOTER_OP:
            raise damaged(folder, f"{path.name} has no MCAP magic or footer")
        header_op, header_length = _RECORD.unpack_from(data, 8)
        data_start = 17 + header_length
        footer = size - 37
        summary = _U64.unpack_from(data, footer + 9)[0]
        if header_op != 0x01 or data_start > footer or (summary and not data_start <= summary <= footer):
            raise damaged(folder, f"{path.name}: the MCAP header or summary offset points outside the file")
        chunks, _ = _walk_data(data, data_start, summary or footer, path, folder)
        if summary:
            if footer - summary > MAX_SUMMARY_BYTES:
                raise IdentificationError(f"{path}: the MCAP summary holds {(footer - summary) >> 20} MiB; at most "
                                          f"{MAX_SUMMARY_BYTES >> 20} MiB are read")
            _walk_index(data, summary, footer, chunks, path, folder)


def _records(data: mmap.mmap | bytes, start: int, stop: int, path: Path, folder: Path):
    """(opcode, content start, content end) of each record in [start, stop), each within it."""
    position = start
    while position < stop:
        if position + 9 > stop:
            raise damaged(folder, f"{path.name}: a record header at byte {position} runs past its section")
        op, length = _RECORD.unpack_from(data, position)
        end = position + 9 + length
        if end > stop:
            raise damaged(folder, f"{path.name}: a record at byte {position} declares {length} bytes, past its section")
        yield op, position + 9, end
        position = end


def _walk_data(data: mmap.mmap, start: int, stop: int, path: Path, folder: Path) -> tuple[dict, int]:
    """The data section: {chunk offset: (compression, compressed size, declared size, messages)}, message count."""
    chunks: dict[int, tuple[str, int, int, int]] = {}
    messages = inflated = 0
    for op, begin, end in _records(data, start, stop, path, folder):
        if op == _MESSAGE_OP:
            messages += 1
        elif op == _CHUNK_OP:
            chunk = _chunk(data, begin, end, path, folder)
            inflated += chunk[2]
            if inflated > MAX_INFLATED_BYTES:
                raise IdentificationError(f"{path}: the MCAP chunks declare more than {MAX_INFLATED_BYTES >> 20} MiB "
                                          f"inflated; at most that is read: {FILTER_HINT}")
            chunks[begin - 9] = chunk
            messages += chunk[3]
        if messages > MAX_BAG_MESSAGES:
            raise IdentificationError(f"{path}: the bag holds more than {MAX_BAG_MESSAGES:,} messages; at most that "
                                      f"many are read: {FILTER_HINT}")
    return chunks, messages


def _chunk(data: mmap.mmap, begin: int, end: int, path: Path, folder: Path) -> tuple[str, int, int, int]:
    """(compression, compressed size, declared size, messages) of the chunk record at [begin, end), inflated within
    its declared size and its records walked."""
    if end - begin < _CHUNK.size + 12:
        raise damaged(folder, f"{path.name}: a chunk record at byte {begin - 9} is too short")
    declared = _CHUNK.unpack_from(data, begin)[2]
    name_length = _U32.unpack_from(data, begin + _CHUNK.size)[0]
    cursor = begin + _CHUNK.size + 4 + name_length
    if cursor + 8 > end:
        raise damaged(folder, f"{path.name}: a chunk record at byte {begin - 9} is too short")
    compression = bytes(data[begin + _CHUNK.size + 4:cursor]).decode("utf-8", "replace")
    compressed = _U64.unpack_from(data, cursor)[0]
    if cursor + 8 + compressed > end:
        raise damaged(folder, f"{path.name}: a chunk at byte {begin - 9} declares data past its record")
    if declared > MAX_CHUNK_BYTES:
        raise IdentificationError(f"{path}: an MCAP chunk declares {declared / 2**20:,.0f} MiB inflated; at most "
                                  f"{MAX_CHUNK_BYTES >> 20} MiB per chunk are read (rosbag2 writes chunks of under 1 "
                                  "MiB)")
    raw = inflate(compression, data[cursor + 8:cursor + 8 + compressed], declared, path, folder)
    count = sum(op == _MESSAGE_OP for op, _, _ in _records(raw, 0, len(raw), path, folder))
    return compression, compressed, declared, count


def inflate(compression: str, payload: bytes, declared: int, path: Path, folder: Path) -> bytes:
    """The chunk's bytes, inflated to at most ``declared`` + 1 bytes (every zstd or lz4 frame of it).

    Raises:
        IdentificationError: an unknown compression, damaged data, or more or fewer bytes than declared.
    """
    if compression == "":
        raw = bytes(payload)
    elif compression in ("zstd", "lz4"):
        raw = _inflate_frames(compression, bytes(payload), declared + 1, path, folder)
    else:
        raise damaged(folder, f"{path.name}: an MCAP chunk is compressed with {compression!r}; zstd, lz4 or none "
                              "can be read")
    if len(raw) > declared:
        raise IdentificationError(f"{path}: an MCAP chunk inflates to more than the {declared:,} bytes it declares "
                                  "(a decompression bomb?); uvms inflates no more than a chunk declares")
    if len(raw) != declared:
        raise damaged(folder, f"{path.name}: an MCAP chunk inflates to "
                              f"{len(raw)} bytes, not the {declared} it declares")
    return raw


def _inflate_frames(compression: str, payload: bytes, limit: int, path: Path, folder: Path) -> bytes:
    """Concatenated zstd or lz4 frames inflated to at most ``limit`` bytes."""
    if compression == "zstd":
        try:
            from compression import zstd  # Python >= 3.14, as rosbags
        except ImportError:
            from backports import zstd
        make, errors = zstd.ZstdDecompressor, (zstd.ZstdError, ValueError)
    else:
        from lz4.frame import LZ4FrameDecompressor

        make, errors = LZ4FrameDecompressor, (RuntimeError, ValueError)
    parts, size = [], 0
    try:
        while payload and size < limit:
            decompressor = make()
            part = decompressor.decompress(payload, max_length=limit - size)
            parts.append(part)
            size += len(part)
            if not decompressor.eof:
                if size < limit:
                    raise damaged(folder, f"{path.name}: an MCAP chunk's {compression} data ends inside a frame")
                break
            payload = decompressor.unused_data
    except errors as exc:
        raise damaged(folder, f"{path.name}: an MCAP chunk's {compression} data is damaged ({exc})") from None
    return b"".join(parts)


def _walk_index(data: mmap.mmap, summary: int, footer: int, chunks: dict, path: Path, folder: Path) -> None:
    """The summary section as ``rosbags`` reads it: every chunk index entry names a chunk of the data section, with
    its sizes; the entries' inflated sizes and messages are counted (rosbags inflates a chunk once per entry)."""
    inflated = messages = 0
    for op, begin, end in _records(data, summary, footer + 29, path, folder):
        if op in (_FOOTER_OP, _SUMMARY_OFFSET_OP):
            return
        if op != _CHUNK_INDEX_OP:
            continue
        try:
            offset = _U64.unpack_from(data, begin + 16)[0]
            cursor = begin + 32 + 4 + _U32.unpack_from(data, begin + 32)[0] + 8
            name_length = _U32.unpack_from(data, cursor)[0]
            compression = bytes(data[cursor + 4:cursor + 4 + name_length]).decode("utf-8", "replace")
            compressed, declared = struct.unpack_from("<QQ", data, cursor + 4 + name_length)
        except struct.error:
            raise damaged(folder, f"{path.name}: a chunk index record at byte {begin - 9} is too short") from None
        chunk = chunks.get(offset)
        if chunk is None or chunk[:3] != (compression, compressed, declared) or cursor + 20 + name_length > end:
            raise damaged(folder, f"{path.name}: a chunk index entry does not match the chunk at byte {offset}")
        inflated += declared
        messages += chunk[3]
        if inflated > MAX_INFLATED_BYTES or messages > MAX_BAG_MESSAGES:
            raise IdentificationError(f"{path}: the MCAP chunk index names chunks of more than "
                                      f"{MAX_INFLATED_BYTES >> 20} MiB inflated or {MAX_BAG_MESSAGES:,} messages; at "
                                      f"most that is read: {FILTER_HINT}")


# ------------------------------------------------------------------ SQLite
def check_sqlite(path: Path, folder: Path, topics: Mapping[str, str]) -> None:
    """The tables ``rosbags`` reads are plain tables; the message counts, per topic read and in all, within the caps;
    every query interrupted after :data:`SQLITE_SECONDS` (module docstring)."""
    deadline = time.monotonic() + SQLITE_SECONDS
    try:
        connection = sqlite3.connect(f"file:{quote(str(path))}?mode=ro&immutable=1", uri=True)
    except sqlite3.Error as exc:
        raise damaged(folder, f"{path.name}: {exc}") from None
    connection.set_progress_handler(lambda: time.monotonic() > deadline, 10_000)
    try:
        kinds = {name: (kind, sql or "") for kind, name, sql in
                 connection.execute("SELECT type, name, sql FROM sqlite_master WHERE name IN "
                                    f"({','.join('?' * len(SQLITE_TABLES))})", SQLITE_TABLES)}
        for name, (kind, sql) in kinds.items():
            hidden = [row[1] for row in connection.execute(f'PRAGMA table_xinfo("{name}")') if row[6]]
            if kind != "table" or sql.lstrip().upper().startswith("CREATE VIRTUAL") or hidden:
                shape = "is a view" if kind != "table" else "has generated columns" if hidden else "is virtual"
                raise IdentificationError(f"{path}: the SQLite table {name!r} {shape}; rosbag2 writes plain tables, "
                                          "and uvms runs no query a bag defines")
        if {"messages", "topics"} - set(kinds):
            return  # rosbags says the database misses tables
        total = connection.execute("SELECT count(*) FROM messages").fetchone()[0]
        if total > MAX_BAG_MESSAGES:
            raise IdentificationError(f"{path}: the bag holds {total:,} messages; at most {MAX_BAG_MESSAGES:,} are "
                                      f"read: {FILTER_HINT}")
        for name, count in connection.execute(
                "SELECT topics.name, count(messages.id) FROM topics LEFT JOIN messages ON topics.id = "
                "messages.topic_id GROUP BY topics.id"):
            if name in topics.values():
                check_topic_count(folder, name, count)
    except sqlite3.OperationalError as exc:
        if time.monotonic() > deadline:
            raise IdentificationError(f"{path}: checking the SQLite file took more than {SQLITE_SECONDS:g} s (a query "
                                      "that does not end?); a rosbag2 .db3 is read in a fraction of that") from None
        raise damaged(folder, f"{path.name}: {exc}") from None
    except sqlite3.Error as exc:
        raise damaged(folder, f"{path.name}: {exc}") from None
    finally:
        connection.close()
