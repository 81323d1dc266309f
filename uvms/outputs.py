"""Writing results atomically: files and whole run folders.

A file is written to a temporary file in the same folder, then moved over with ``os.replace``
(:func:`atomic_path`): an interrupted write leaves the previous complete file or none, never a truncated one.

A run folder is replaced whole (:func:`run_folder`): every file of a run is written into a hidden temporary
sibling folder, which is swapped in only when the run completed, so the folder always holds one complete
run — the previous one or the new one, never a mix. A lock next to the folder refuses a second uvms process
on the same folder at once.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import re
import secrets
import shutil
import sys
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from .errors import RunFolderBusy, RunFolderError, UVMSError

#: A run folder ``DIR/NAME`` has two kinds of hidden siblings in ``DIR``: its lock ``.NAME.uvms-lock`` (kept:
#: removing a lock file while another process opens it would break the lock) and the temporary folders
#: ``.NAME.uvms-tmp-<random>`` of a run in progress (removed by the next run that holds the lock, if a run was
#: killed before it could remove its own).
LOCK_SUFFIX = ".uvms-lock"
TEMPORARY_MARK = ".uvms-tmp-"
#: An existing, non-empty folder is replaced only if it holds one of these files, i.e. if uvms wrote it
#: (``uvms run``/``uvms workspace`` write ``metrics.json``, ``uvms sweep`` writes ``sweep.csv``): a mistyped
#: ``--out`` never deletes a folder of the user's own files.
OUTPUT_MARKERS = ("metrics.json", "sweep.csv")
_RENAME_EXCHANGE = 2  # linux/fs.h
_AT_FDCWD = -100


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


def write_text(path: str | os.PathLike, text: str) -> None:
    """Write text atomically."""
    with atomic_path(path) as temporary:
        temporary.write_text(text, encoding="utf-8")


def write_json(path: str | os.PathLike, data: dict) -> None:
    """Write a JSON document atomically (sorted keys, 2-space indent)."""
    write_text(path, json.dumps(data, indent=2, sort_keys=True) + "\n")


def write_npz(path: str | os.PathLike, **arrays: np.ndarray) -> None:
    """Write a compressed ``.npz`` atomically."""
    with atomic_path(path) as temporary:
        with open(temporary, "wb") as handle:
            np.savez_compressed(handle, **arrays)


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
    else:
        with contextlib.suppress(OSError):
            path.unlink()


@contextlib.contextmanager
def run_folder(path: str | os.PathLike, *, lock: bool = True,
               markers: Sequence[str] = OUTPUT_MARKERS) -> Iterator[Path]:
    """Yield a fresh temporary folder beside ``path``; on success it replaces ``path`` as a whole.

    Write every file of a run into the yielded folder (with any writer: the helpers of this module,
    matplotlib, ``shutil.copyfile``...). When the block ends normally the folder is swapped in atomically
    (Linux ``renameat2(RENAME_EXCHANGE)``; two renames elsewhere, see :func:`_swap_in`) and the previous
    contents are deleted. On an exception, KeyboardInterrupt included, the temporary folder is deleted and
    ``path`` is left untouched; a KeyboardInterrupt gets a note saying what ``path`` holds (the CLI prints it).

    Example (the files of ``uvms workspace``)::

        with outputs.run_folder(out) as folder:
            outputs.write_npz(folder / "points.npz", **arrays)
            outputs.write_json(folder / "metrics.json", metrics)
        # out/ now holds exactly points.npz and metrics.json; paths to report are out / name

    Args:
        path: the run folder. Its parent is created if needed. A symbolic link is followed (its target is
            replaced).
        lock: hold the lock ``.NAME.uvms-lock`` beside the folder while writing, so that a second process on
            the same folder is refused at once; False for a folder inside another run folder (the points of
            a sweep), whose parent must then exist.
        markers: an existing non-empty ``path`` is replaced only if it holds one of these files.

    Raises:
        RunFolderBusy: another process holds the lock of ``path``.
        RunFolderError: ``path`` is a file, a non-empty folder without any of ``markers``, or cannot be
            written.
    """
    shown = os.fspath(path)
    final = Path(os.path.realpath(os.path.abspath(path)))
    parent, name = final.parent, final.name
    if not name or final == parent:
        raise RunFolderError(f"{shown!r} cannot be an output folder (a file system root); choose a folder below it")
    try:
        if lock:
            parent.mkdir(parents=True, exist_ok=True)
        elif not parent.is_dir():
            raise RunFolderError(f"cannot write {shown!r}: its parent folder {str(parent)!r} does not exist (any more)")
        holder = None
        if lock:
            from filelock import FileLock, Timeout

            lock_path = parent / f".{name}{LOCK_SUFFIX}"
            os.close(os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o666))  # an unwritable folder: a clear OSError
            holder = FileLock(str(lock_path), timeout=0)
            try:
                holder.acquire()
            except Timeout:
                raise RunFolderBusy(f"another uvms process is writing {shown}; wait for it or choose another "
                                    f"--out") from None
    except OSError as exc:
        raise RunFolderError(f"cannot write to {str(parent)!r}: {exc.strerror or exc}") from None
    try:
        if os.path.lexists(final) and not final.is_dir():
            raise RunFolderError(f"{shown!r} is a file, not a folder; choose another --out")
        existed = final.is_dir() and any(final.iterdir())
        if existed and not any((final / marker).is_file() for marker in markers):
            raise RunFolderError(f"{shown!r} exists and was not written by uvms (it holds no "
                                 f"{' or '.join(markers)}); a run replaces its output folder whole, so choose "
                                 f"a new or empty folder")
        prefix = f".{name}{TEMPORARY_MARK}"
        if lock:  # left by a killed run; nobody else can be writing them while we hold the lock
            ours = re.compile(re.escape(prefix) + r"(old-)?[a-z0-9_]{8}")  # the names mkdtemp and _swap_in make
            for stale in parent.iterdir():
                if ours.fullmatch(stale.name):
                    _remove(stale)
        try:
            temporary = Path(tempfile.mkdtemp(prefix=prefix, dir=parent))
        except OSError as exc:
            raise RunFolderError(f"cannot write to {str(parent)!r}: {exc.strerror or exc}") from None
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temporary, 0o777 & ~umask)  # mkdtemp makes 0700; a result folder gets the usual permissions
        try:
            yield temporary
        except BaseException as exc:
            _remove(temporary)
            if isinstance(exc, KeyboardInterrupt):
                _interrupted_note(exc, f"{shown} keeps the previous complete run" if existed else
                                  f"nothing was written to {shown}")
            raise
        try:
            previous = _swap_in(temporary, final, parent / f"{prefix}old-{secrets.token_hex(4)}")
        except OSError as exc:
            _remove(temporary)
            raise RunFolderError(f"cannot replace {shown!r}: {exc.strerror or exc}") from None
        try:
            if previous is not None:
                _remove(previous)
        except KeyboardInterrupt as exc:
            _interrupted_note(exc, f"{shown} holds the new complete run")
            raise
    finally:
        if holder is not None:
            holder.release()
