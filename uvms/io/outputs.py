"""Writing results atomically: files and whole run folders.

A file is written to a temporary file in the same folder, then moved over with ``os.replace``
(:func:`atomic_path`): an interrupted write leaves the previous complete file or none, never a truncated one.

A run folder is replaced whole (:func:`run_folder`): every file of a run is written into a hidden temporary
sibling folder, which is swapped in only when the run completed, so the folder always holds one complete
run — the previous one or the new one, never a mix. A lock next to the folder refuses a second uvms process
on the same folder at once.

A folder is uvms's own by its manifest ``.uvms-run.json`` (written last, listing every path the run wrote); a folder
is replaced only if it holds that manifest and nothing else, never when an input of the run lies inside it. A
folder of an older uvms (``metrics.json``, no manifest) is refused: the user deletes it or chooses another ``--out``.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import re
import shutil
import stat
import sys
import tempfile
import zipfile
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from ..errors import DiskFullError, RunFolderBusy, RunFolderError, UVMSError

#: Hidden siblings of ``DIR/NAME``: its lock ``.NAME.uvms-lock`` (kept: removing a lock another process opens breaks
#: it) and ``.NAME.uvms-tmp-<random>`` of a run in progress (a killed run's are removed by the next run's lock holder).
LOCK_SUFFIX = ".uvms-lock"
TEMPORARY_MARK = ".uvms-tmp-"
#: The manifest of a run folder, written last by :func:`run_folder`: every path the run wrote (folders end in "/").
MANIFEST = ".uvms-run.json"
#: zlib's level for ``.npz`` files: a run's doubles deflate at level 1 as at 6 in 2/3 of the time (1.47 against 1.45 MB)
NPZ_LEVEL = 1
#: The files by which a folder of an uvms older than the manifest is recognised (to say so when refusing it).
LEGACY_MARKERS = ("metrics.json", "sweep.csv")
DISK_FULL = (errno.ENOSPC, errno.EDQUOT)  # a full disk or an exhausted quota
MAX_MANIFEST_BYTES = 16 << 20  # a manifest of a million paths; a larger one is not uvms's
SHOWN = 5  # foreign files a refusal names before "and N more"
_RENAME_EXCHANGE, _AT_FDCWD = 2, -100  # linux/fs.h


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, keep_suffix: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it replaces ``path`` atomically.

    Args:
        path: the final file.
        keep_suffix: give the temporary file ``path``'s suffix (for writers that pick the format from it,
            e.g. Pillow and ffmpeg); otherwise it ends in ``.tmp``.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(prefix=f".{path.stem if keep_suffix else path.name}.",
                                             suffix=path.suffix if keep_suffix else ".tmp", dir=path.parent)
    except OSError as exc:
        if exc.errno in DISK_FULL:
            raise DiskFullError(f"no space left on the device holding {str(path.parent)!r} ({exc.strerror})") from exc
        raise UVMSError(f"cannot write to {str(path.parent)!r}: {exc.strerror or exc}") from None
    os.close(handle)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)  # mkstemp makes 0600; a result file gets the usual permissions
    try:
        yield Path(temporary)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


def write_text(path: str | os.PathLike, text: str, before_replace: Callable[[], None] | None = None) -> None:
    """Write text atomically; ``before_replace()`` runs just before it replaces ``path`` (a last check)."""
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")
        before_replace and before_replace()


def write_json(path: str | os.PathLike, data: dict, before_replace: Callable[[], None] | None = None) -> None:
    """Write a JSON document atomically (sorted keys, 2-space indent; ``before_replace`` of :func:`write_text`)."""
    write_text(path, json.dumps(data, indent=2, sort_keys=True) + "\n", before_replace)


def write_npz(path: str | os.PathLike, **arrays: np.ndarray) -> None:
    """Write a compressed ``.npz`` atomically, read as ``np.savez_compressed``'s: no pickled objects."""
    with atomic_path(path) as temporary, zipfile.ZipFile(temporary, "w", zipfile.ZIP_DEFLATED,
                                                         compresslevel=NPZ_LEVEL) as archive:
        for name, value in arrays.items():
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)


def save_figure(figure, path: str | os.PathLike, dpi: int = 110) -> None:
    """Save a matplotlib figure atomically (PNG)."""
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=dpi, format=Path(path).suffix.lstrip(".") or "png")


def _exchange(first: Path, second: Path) -> bool:
    """Swap two existing paths atomically with Linux's ``renameat2(RENAME_EXCHANGE)``; False if unavailable."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2  # glibc >= 2.28, musl >= 1.2.3
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    renameat2.restype = ctypes.c_int
    if renameat2(_AT_FDCWD, os.fsencode(first), _AT_FDCWD, os.fsencode(second), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP, errno.ENOTSUP):  # old kernel, or the file system
        return False
    raise OSError(code, os.strerror(code), str(second))


def _swap_in(new: Path, final: Path, old: Path) -> Path | None:
    """Put the folder ``new`` at ``final``; return where the previous ``final`` now is (to delete), or None.

    Where ``final`` exists: one atomic exchange on Linux; elsewhere (or on a file system without it) two
    renames, ``final -> old`` then ``new -> final`` — between them, a few microseconds, ``final`` does not exist,
    and a crash exactly there leaves both runs in hidden siblings, which the next run removes.
    """
    if not os.path.lexists(final):
        os.rename(new, final)  # atomic; fails (ENOTEMPTY) if another writer created final meanwhile
        return None
    if _exchange(new, final):
        return new  # the temporary name now holds the previous run
    os.rename(final, old)
    try:
        os.rename(new, final)
    except BaseException:
        os.rename(old, final)
        raise
    return old


def _interrupted_note(exc: BaseException, note: str) -> None:
    """Attach ``note`` to a KeyboardInterrupt (PEP 678 notes; the CLI prints the last one)."""
    if hasattr(exc, "add_note"):
        exc.add_note(note)
    else:  # pragma: no cover - Python 3.10
        exc.__notes__ = [*getattr(exc, "__notes__", []), note]


def _remove(path: Path) -> None:
    """Remove a folder (or a file or link) if possible; what cannot be removed is left to the next run."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
        return
    with contextlib.suppress(OSError):
        path.unlink()


def _few(names: Sequence[str]) -> str:
    """The first :data:`SHOWN` names, then "and N more"."""
    return ", ".join(names[:SHOWN]) + (f" and {len(names) - SHOWN} more" if len(names) > SHOWN else "")


def _entries(folder: Path) -> tuple[list[str], set[tuple[int, int]]]:
    """Every path below ``folder`` relative to it (folders end in "/"; links are not followed), and the
    (device, inode) of its files."""
    def unreadable(exc: OSError) -> None:
        raise RunFolderError(f"cannot read {exc.filename!r}: {exc.strerror or exc}; uvms replaces only a folder "
                             f"whose every file it can see") from None

    entries, inodes = [], set()
    for root, folders, files in os.walk(folder, onerror=unreadable):
        base = Path(root).relative_to(folder)
        for name in folders + files:
            status = os.lstat(os.path.join(root, name))
            entries.append((base / name).as_posix() + ("/" if stat.S_ISDIR(status.st_mode) else ""))
            inodes.add((status.st_dev, status.st_ino))
    return sorted(entries), inodes


def _listed(folder: Path) -> set[str] | None:
    """The paths the manifest of ``folder`` lists, or None without a valid manifest."""
    manifest = folder / MANIFEST
    if manifest.is_symlink() or not manifest.is_file() or manifest.stat().st_size > MAX_MANIFEST_BYTES:
        return None
    try:
        entries = json.loads(manifest.read_text(encoding="utf-8")).get("entries")
    except (OSError, UnicodeDecodeError, ValueError, AttributeError):
        return None
    return set(entries) if isinstance(entries, list) and all(isinstance(e, str) for e in entries) else None


def holds_run(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a folder holding a complete uvms run (its manifest), which a new run would replace."""
    return Path(path).is_dir() and _listed(Path(path)) is not None


def _check_replaceable(final: Path, shown: str, inputs: Sequence[str | os.PathLike],
                       legacy_markers: Sequence[str]) -> bool:
    """Refuse to replace ``final`` if an input lies inside it or it holds anything uvms did not write there.

    Returns:
        Whether ``final`` exists and is not empty (a previous run is there).
    """
    if not final.is_dir():
        return False
    entries, inodes = _entries(final)
    for given in inputs:  # the same file under another name (a hard link)
        with contextlib.suppress(OSError):
            status = os.stat(given)
            if stat.S_ISREG(status.st_mode) and (status.st_dev, status.st_ino) in inodes:
                raise RunFolderError(f"{shown!r} holds a hard link to {os.fspath(given)!r}, an input of this run, "
                                     f"and a run replaces its output folder whole; choose another --out")
    if not entries:
        return False
    listed = _listed(final)
    if listed is None:
        legacy = [marker for marker in legacy_markers if (final / marker).is_file()]
        if legacy:
            raise RunFolderError(f"{shown!r} holds {legacy[0]} but no {MANIFEST}: it was not written by uvms, or by "
                                 f"an older uvms; a run replaces its output folder whole and would delete "
                                 f"{_few(entries)}: delete the folder yourself or choose another --out")
        raise RunFolderError(f"{shown!r} exists and was not written by uvms (it holds {_few(entries)} and no "
                             f"{MANIFEST}); a run replaces its output folder whole, so choose a new or empty folder")
    foreign = [entry for entry in entries if entry not in listed and entry != MANIFEST]
    if foreign:
        raise RunFolderError(f"{shown!r} holds {len(foreign)} file(s) that uvms did not write there ({_few(foreign)}); "
                             f"a run replaces its output folder whole: move them out or choose another --out")
    return True


def _write_manifest(folder: Path) -> None:
    """List every path of the finished run in ``folder / MANIFEST`` (written last)."""
    write_json(folder / MANIFEST, {"written_by": "uvms", "entries": _entries(folder)[0]})


def _disk_full(exc: BaseException) -> OSError | None:
    """The ENOSPC/EDQUOT OSError that ``exc`` is or was raised from, if any."""
    for _ in range(8):  # a few links of the chain of causes, not a cycle
        if exc is None or isinstance(exc, OSError) and exc.errno in DISK_FULL:
            return exc
        exc = exc.__cause__ or exc.__context__
    return None


def _os_failure(exc: OSError, parent: Path, what: str) -> RunFolderError:
    """A RunFolderError for an OSError while writing into ``parent``; a full disk says so, and ``what`` was kept."""
    cause = _disk_full(exc)
    if cause is not None:
        return DiskFullError(f"no space left on the device holding {str(parent)!r} ({cause.strerror}); {what}")
    return RunFolderError(f"cannot write to {str(parent)!r}: {exc.strerror or exc}")


def hold_lock(lock_path: Path, shown: str) -> Callable[[], None]:
    """Take the lock of a run folder (never through a symbolic link); return its release.

    Raises:
        RunFolderBusy: another process holds it. RunFolderError: it is a link or not a file. OSError: not created.
    """
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows: filelock's msvcrt lock (O_NOFOLLOW does not exist there)
        from filelock import FileLock, Timeout

        holder = FileLock(str(lock_path), timeout=0)
        try:
            holder.acquire()
        except Timeout:
            raise RunFolderBusy(f"another uvms process is writing {shown}; wait for it or choose another "
                                "--out") from None
        return holder.release
    flags = os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_CLOEXEC
    try:
        handle = os.open(lock_path, flags, 0o666)
    except OSError as exc:
        if exc.errno == errno.ELOOP or os.path.islink(lock_path):
            raise RunFolderError(f"the lock {str(lock_path)!r} of {shown!r} is a symbolic link, which uvms never "
                                 f"makes (someone may want uvms to create its target); remove it or choose another "
                                 f"--out") from None
        raise
    try:
        if not stat.S_ISREG(os.fstat(handle).st_mode):
            raise RunFolderError(f"the lock {str(lock_path)!r} of {shown!r} is not a regular file; remove it or "
                                 f"choose another --out")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)  # the same lock as filelock's, on this descriptor
        except BlockingIOError:
            raise RunFolderBusy(f"another uvms process is writing {shown}; wait for it or choose another "
                                f"--out") from None
    except BaseException:
        os.close(handle)
        raise
    return lambda: os.close(handle)  # closing the last descriptor releases the lock


@contextlib.contextmanager
def run_folder(path: str | os.PathLike, *, lock: bool = True, inputs: Iterable[str | os.PathLike] = (),
               legacy_markers: Sequence[str] = LEGACY_MARKERS) -> Iterator[Path]:
    """Yield a fresh temporary folder beside ``path``; on success it replaces ``path`` as a whole.

    Write every file of a run into the yielded folder (with any writer: the helpers of this module,
    matplotlib, ``shutil.copyfile``...). When the block ends normally the manifest :data:`MANIFEST` is written
    into the folder, listing everything in it, and the folder is swapped in atomically (Linux
    ``renameat2(RENAME_EXCHANGE)``; two renames elsewhere, see :func:`_swap_in`) and the previous contents are
    deleted. On an exception, KeyboardInterrupt included, the temporary folder is deleted and ``path`` is left
    untouched; a KeyboardInterrupt gets a note saying what ``path`` holds (the CLI prints it), and a full disk
    becomes a :class:`~uvms.errors.DiskFullError` saying so.

    Example (the files of ``uvms workspace``)::

        with outputs.run_folder(out, inputs=[model_file]) as folder:
            outputs.write_npz(folder / "points.npz", **arrays)
            outputs.write_json(folder / "metrics.json", metrics)
        # out/ now holds exactly points.npz, metrics.json and .uvms-run.json; paths to report are out / name

    Args:
        path: the run folder. Its parent is created if needed. A symbolic link is followed (its target is
            replaced).
        lock: hold the lock ``.NAME.uvms-lock`` beside the folder while writing, so that a second process on
            the same folder is refused at once; False for a folder inside another run folder (the points of
            a sweep), whose parent must then exist.
        inputs: the files and folders the run reads (scenario, model...): ``path`` is refused if one of them
            is ``path`` or lies inside it.
        legacy_markers: files by which a folder of an older uvms (no manifest) is recognised, to say so.

    Raises:
        RunFolderBusy: another process holds the lock of ``path``.
        RunFolderError: ``path`` is a file, holds an input, holds anything its manifest does not list (or has
            no manifest), its lock is a symbolic link, or it cannot be written (DiskFullError: the disk is full).
    """
    shown = os.fspath(path)
    inputs = list(inputs)
    final = Path(os.path.realpath(os.path.abspath(path)))
    parent, name = final.parent, final.name
    if not name or final == parent:
        raise RunFolderError(f"{shown!r} cannot be an output folder (a file system root); choose a folder below it")
    for given in inputs:  # the input must survive the run; checked before the lock, so a refusal leaves no lock
        real = Path(os.path.realpath(os.path.abspath(given)))
        if real == final or final in real.parents:
            raise RunFolderError(f"{shown!r} holds {os.fspath(given)!r}, an input of this run, and a run replaces "
                                 f"its output folder whole; choose another --out")
    release = None
    try:
        if lock:
            parent.mkdir(parents=True, exist_ok=True)
            release = hold_lock(parent / f".{name}{LOCK_SUFFIX}", shown)
        elif not parent.is_dir():
            raise RunFolderError(f"cannot write {shown!r}: its parent folder {str(parent)!r} does not exist (any more)")
    except OSError as exc:
        raise _os_failure(exc, parent, f"nothing was written to {shown}") from None
    try:
        if os.path.lexists(final) and not final.is_dir():
            raise RunFolderError(f"{shown!r} is a file, not a folder; choose another --out")
        existed = _check_replaceable(final, shown, inputs, legacy_markers)
        kept = f"{shown} keeps the previous complete run" if existed else f"nothing was written to {shown}"
        prefix = f".{name}{TEMPORARY_MARK}"
        if lock:  # left by a killed run; nobody else can be writing them while we hold the lock
            ours = re.compile(re.escape(prefix) + r"(old-)?[a-z0-9_]{8}")  # the names mkdtemp and _swap_in make
            for stale in parent.iterdir():
                if ours.fullmatch(stale.name):
                    _remove(stale)
        try:
            temporary = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        except OSError as exc:
            raise _os_failure(exc, parent, kept) from None
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o777 & ~umask)  # mkdtemp makes 0700; a result folder gets the usual permissions
        try:
            yield temporary
            _write_manifest(temporary)  # last: only a complete run has one
        except BaseException as exc:
            _remove(temporary)
            if isinstance(exc, KeyboardInterrupt):
                _interrupted_note(exc, kept)
            elif _disk_full(exc) is not None:
                raise _os_failure(_disk_full(exc), parent, kept) from exc
            raise
        try:
            previous = _swap_in(temporary, final, parent / f"{prefix}old-{os.urandom(4).hex()}")
        except OSError as exc:
            _remove(temporary)
            if _disk_full(exc) is not None:
                raise _os_failure(exc, parent, kept) from None
            raise RunFolderError(f"cannot replace {shown!r}: {exc.strerror or exc}") from None
        try:
            if previous is not None:
                _remove(previous)
        except KeyboardInterrupt as exc:
            _interrupted_note(exc, f"{shown} holds the new complete run")
            raise
    finally:
        if release is not None:
            release()
