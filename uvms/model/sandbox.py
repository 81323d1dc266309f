"""Untrusted xacro: expand it in a child process that the operating system confines.

A xacro file is code: its ``${...}`` expressions are Python, and xacro's name filter can be escaped
(``python.vars(python.type)`` reaches every class, the modules ``os`` and ``sys`` included). A Python-level
guard cannot hold such code, so a model from someone else is expanded in a child process (source:
``uvms/model/sandbox_worker.py``) on which the **kernel** enforces the boundary:

- **seccomp** (libseccomp through ``pyseccomp``; required, else untrusted expansion is refused) refuses,
  with EPERM: new processes and programs (fork, vfork, clone, execve); signals and handles to other
  processes (kill, tgkill, pidfd_*, ptrace, and SIGIO owners: fcntl F_SETOWN/F_SETSIG/F_SETOWN_EX);
  renicing, pinning, rescheduling or migrating another process (setpriority, ioprio_set, sched_set*,
  migrate_pages, move_pages and prlimit64 are allowed only on the caller itself); file locks and leases;
  every ioctl but six harmless requests (reading a terminal's state or window size, bytes waiting,
  close-on-exec, non-blocking; generic numbering as on x86 and arm), so no terminal setting (tcsetattr, TIOCSWINSZ,
  TIOCSTI...) and no FIOASYNC/FIOSETOWN; sockets and System V / POSIX IPC; opening any file for writing (O_WRONLY,
  O_RDWR, O_CREAT, O_TRUNC, O_APPEND); every file-system change (rename, unlink, mkdir, chmod, chown, truncate,
  utime, mknod, xattrs, mount...); io_uring; raising its limits, changing identity or namespaces.
  Syscalls newer than its list are refused with ENOSYS;
- **Landlock** (Linux 5.13+, when the kernel has it): the child may read only the model's folder and
  everything below it, the folders of the packages of its package index (``packages``: the ROS packages of
  the folders the user named, ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, the model's own workspace and
  example-robot-data, see :mod:`uvms.model.packages`; ``$(find pkg)`` resolves through the same index and
  nothing else), the Python installation and its import folders, ``/dev/null`` and ``/dev/urandom``; it may change no
  file, and (ABI 4+/6+) open no TCP connection and signal no process outside its own domain. Outside
  those folders, ``/proc`` and ``/dev/pts`` included, an open fails and the message says what is readable
  (a model lying loose in a home folder therefore exposes that whole folder: keep models in their own);
- **capabilities**: a root child keeps only CAP_DAC_OVERRIDE/CAP_DAC_READ_SEARCH (it reads what its user
  could), so it may not inspect, renice or signal other processes by privilege;
- **where Landlock is missing** the child may read any file its user can, but not ``/proc/<parent>/environ``
  or ``/proc/<parent>/mem``: the parent is made non-dumpable (``PR_SET_DUMPABLE`` 0) for the expansion,
  and the child has no CAP_SYS_PTRACE even as root; what it reads can only come back as the URDF text;
- resource limits: address space (``memory_bytes``), CPU time, no file growth, no core file, no new
  processes, 64 file descriptors;
- it runs ``python -I -B`` with an empty environment in an empty temporary folder, in its own session
  and process group, which is killed as a whole at the timeout and after every expansion; the child dies
  with its parent (``PR_SET_PDEATHSIG`` SIGKILL, and it exits if it was re-parented before that), and a
  SIGTERM/SIGHUP of the parent during the expansion (main thread) kills the child's group first;
- the answer it hands back is read with a size cap (``max_urdf_bytes``); a malformed answer is an error
  of one line;
- a PEP 578 audit hook refuses the same things at the Python level (a second layer, clearer messages).

Where the mechanism is missing (not Linux, no libseccomp, no ``pyseccomp``) untrusted expansion is
refused with a message saying so, never run unconfined. Plain URDF is never executed.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import json
import os
import selectors
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator, Mapping
from pathlib import Path

from ..errors import ModelParseError, XacroError
from .checks import MAX_URDF_BYTES  # the largest URDF the child may hand back [bytes]
from .packages import package_index, unknown_package

#: Seconds an untrusted xacro expansion may take [s].
DEFAULT_TIMEOUT = 30.0
#: Address space of the child [bytes]: xacro needs about 40 MiB.
DEFAULT_MEMORY_BYTES = 1 << 30
#: Longest error message taken from the child [characters].
MAX_MESSAGE_CHARS = 2000

WORKER_SOURCE = (Path(__file__).with_name("sandbox_worker.py")).read_text(encoding="utf-8")

PR_SET_DUMPABLE, PR_GET_DUMPABLE = 4, 3


@functools.lru_cache(maxsize=1)
def confinement_problem() -> str | None:
    """Why untrusted xacro cannot be confined on this machine, or None when it can."""
    if not sys.platform.startswith("linux"):
        return f"untrusted xacro is expanded only under Linux seccomp, and this is {sys.platform}"
    try:
        import pyseccomp  # noqa: F401 - loads libseccomp through ctypes
    except (ImportError, RuntimeError, OSError) as exc:
        return f"untrusted xacro needs libseccomp and pyseccomp (pip install pyseccomp): {exc}"
    return None


@functools.lru_cache(maxsize=1)
def libc() -> ctypes.CDLL:
    """The C library, for prctl and raw syscalls."""
    library = ctypes.CDLL(None, use_errno=True)
    library.syscall.restype = ctypes.c_long
    return library


@functools.lru_cache(maxsize=1)
def landlock_abi() -> int:
    """The Landlock ABI version of this kernel, 0 when it has none (ENOSYS) or it is disabled (EOPNOTSUPP)."""
    if not sys.platform.startswith("linux"):
        return 0
    version = libc().syscall(444, None, ctypes.c_size_t(0), ctypes.c_uint32(1))  # LANDLOCK_CREATE_RULESET_VERSION
    return max(int(version), 0)


def expand_untrusted(
    path: Path,
    mappings: Mapping[str, str],
    timeout: float = DEFAULT_TIMEOUT,
    *,
    memory_bytes: int = DEFAULT_MEMORY_BYTES,
    max_urdf_bytes: int = MAX_URDF_BYTES,
    packages: Mapping[str, Path] | None = None,
    audit_hook: bool = True,
    landlock: bool = True,
) -> str:
    """Expand a xacro file in the confined child process described above.

    Args:
        path: the ``.xacro`` file.
        mappings: xacro args, already checked and formatted as strings.
        timeout: wall-clock limit [s].
        memory_bytes: address-space limit of the child [bytes].
        max_urdf_bytes: largest URDF accepted back [bytes].
        packages: the package index, {name: folder}: ``$(find name)`` is that folder, and the xacro may read
            those folders besides its own; None: :func:`uvms.model.packages.package_index` of the model alone
            (``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``, its workspace, example-robot-data).
        audit_hook: install the Python-level second layer (False only to test the kernel layers alone).
        landlock: restrict reading with Landlock where the kernel has it (False only to test the other
            layers alone; the parent is then non-dumpable during the expansion, as without Landlock).

    Returns:
        The URDF text.

    Raises:
        XacroError: xacro failed, the file tried something it may not, a limit was reached, or this
            machine cannot confine the child.
        ModelParseError: the file is not well-formed XML.
    """
    problem = confinement_problem()
    if problem:
        raise XacroError(f"{path}: {problem}; expand it with trusted=True only if you trust its author")
    resolved = Path(path).resolve()
    packages = package_index(model=path) if packages is None else packages
    roots = [resolved.parent] + [Path(folder).resolve() for folder in packages.values()]
    roots = [str(p) for p in dict.fromkeys(roots) if p.exists()]
    use_landlock = landlock and landlock_abi() > 0
    request = json.dumps({"path": str(resolved), "mappings": dict(mappings), "memory_bytes": int(memory_bytes),
                          "packages": {name: str(folder) for name, folder in packages.items()},
                          "cpu_seconds": int(timeout) + 1, "audit_hook": bool(audit_hook),
                          "parent_pid": os.getpid(), "landlock": use_landlock, "read_roots": roots}).encode()
    guard = contextlib.nullcontext() if use_landlock else not_dumpable()
    with tempfile.TemporaryDirectory(prefix="uvms-xacro-") as folder, guard:
        process = subprocess.Popen(
            [sys.executable, "-I", "-B", "-c", WORKER_SOURCE], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, cwd=folder, env={}, close_fds=True, start_new_session=True,
        )
        try:
            with group_killed_on_termination(process, folder):
                stdout, stderr, stop = collect_output(process, request, timeout, max_urdf_bytes)
        finally:
            kill_process_group(process)
    if stop == "timeout":
        raise XacroError(f"{path}: untrusted xacro expansion took longer than {timeout:g} s and was stopped")
    if stop == "too large":
        raise XacroError(f"{path}: untrusted xacro produced more than {max_urdf_bytes >> 20} MiB of URDF; "
                         "no UVMS model is that large")
    readable = None if not use_landlock else f"the model's folder {roots[0]}, " + (
        f"the package folders {', '.join(roots[1:])} " if roots[1:] else "no package folder ")
    return read_answer(path, stdout, stderr, process.returncode, readable=readable, packages=packages)


_dumpable_lock = threading.Lock()
_dumpable_users = 0
_dumpable_before = 1


@contextlib.contextmanager
def not_dumpable() -> Iterator[None]:
    """Make this process non-dumpable while a child without Landlock runs: its ``/proc/<pid>/environ``,
    ``mem``... are then readable only with CAP_SYS_PTRACE, which the child does not have.

    Counted across threads: the state before the first expansion is restored after the last.
    """
    global _dumpable_users, _dumpable_before
    with _dumpable_lock:
        if _dumpable_users == 0:
            _dumpable_before = max(int(libc().prctl(PR_GET_DUMPABLE, 0, 0, 0, 0)), 0)
            if libc().prctl(PR_SET_DUMPABLE, 0, 0, 0, 0) != 0:
                raise XacroError("untrusted xacro: cannot hide this process's environment from the child "
                                 f"(prctl: {os.strerror(ctypes.get_errno())}); refusing to expand it")
        _dumpable_users += 1
    try:
        yield
    finally:
        with _dumpable_lock:
            _dumpable_users -= 1
            if _dumpable_users == 0:
                libc().prctl(PR_SET_DUMPABLE, _dumpable_before, 0, 0, 0)


@contextlib.contextmanager
def group_killed_on_termination(process: subprocess.Popen, folder: str) -> Iterator[None]:
    """While the child runs, a SIGTERM or SIGHUP of this process kills the child's group first, then has
    the effect it had before (the previous handler runs, or the default action ends this process, after
    removing the child's temporary ``folder``).

    Only in the main thread (Python runs signal handlers there only); an ignored signal stays ignored,
    and a handler set outside Python is left alone.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous: dict[int, object] = {}

    def handler(signum: int, frame: object) -> None:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, signal.SIGKILL)
        before = previous[signum]
        signal.signal(signum, before)
        if callable(before):
            before(signum, frame)
        elif before == signal.SIG_DFL:
            shutil.rmtree(folder, ignore_errors=True)
            os.kill(os.getpid(), signum)  # die of it, as without this handler

    for signum in (signal.SIGTERM, signal.SIGHUP):
        before = signal.getsignal(signum)
        if before is not None and before != signal.SIG_IGN:
            previous[signum] = before
            signal.signal(signum, handler)
    try:
        yield
    finally:
        for signum, before in previous.items():
            signal.signal(signum, before)


def collect_output(
    process: subprocess.Popen, request: bytes, timeout: float, max_bytes: int
) -> tuple[bytes, bytes, str]:
    """Send the request, then read stdout and stderr until both close, the deadline or the size cap.

    Returns:
        (stdout, stderr, why reading stopped: "done", "timeout" or "too large").
    """
    deadline = time.monotonic() + timeout
    try:
        process.stdin.write(request)
        process.stdin.close()
    except BrokenPipeError:
        pass
    received = {process.stdout: bytearray(), process.stderr: bytearray()}
    with selectors.DefaultSelector() as selector:
        for stream in received:
            selector.register(stream, selectors.EVENT_READ)
        while selector.get_map():
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return bytes(received[process.stdout]), bytes(received[process.stderr]), "timeout"
            for key, _ in selector.select(remaining):
                chunk = os.read(key.fd, 1 << 16)
                if not chunk:
                    selector.unregister(key.fileobj)
                    continue
                received[key.fileobj] += chunk
                if len(received[process.stdout]) > max_bytes or len(received[process.stderr]) > 1 << 20:
                    return bytes(received[process.stdout]), bytes(received[process.stderr]), "too large"
    process.wait(max(deadline - time.monotonic(), 0.1))
    return bytes(received[process.stdout]), bytes(received[process.stderr]), "done"


def kill_process_group(process: subprocess.Popen) -> None:
    """Kill the child's whole process group (it leads its own session), then reap the child."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass
    for stream in (process.stdout, process.stderr):
        stream.close()
    process.wait()


def one_line(text: object) -> str:
    """A message from the child (which may be hostile) as one line of bounded length."""
    line = " ".join(str(text).split())
    return line if len(line) <= MAX_MESSAGE_CHARS else line[:MAX_MESSAGE_CHARS] + "..."


def read_answer(path: Path, stdout: bytes, stderr: bytes, returncode: int | None, *,
                readable: str | None = None, packages: Mapping[str, Path] | None = None) -> str:
    """The URDF from the child's JSON answer, or the matching error.

    Args:
        path: the model, for messages.
        stdout, stderr: what the child wrote (it may be hostile: any bytes).
        returncode: its exit status (negative: the signal that ended it).
        readable: what Landlock let it read, for the message when a read was refused (None: no Landlock).
        packages: the package index it was given, for the message of a package it did not find.

    Raises:
        XacroError: anything but a well-formed answer carrying the URDF, in one line.
        ModelParseError: the child reported malformed XML.
    """
    try:
        answer = json.loads(stdout)
    except (ValueError, RecursionError):  # not JSON, not UTF-8, or nested too deep to decode
        answer = None
    if not isinstance(answer, dict) or not (isinstance(answer.get("xml"), str) or (
            isinstance(answer.get("kind"), str) and isinstance(answer.get("message"), str))):
        lines = stderr.decode(errors="replace").strip().splitlines()
        if returncode is not None and returncode < 0:
            try:
                detail = f"killed by {signal.Signals(-returncode).name}"
            except ValueError:
                detail = f"killed by signal {-returncode}"
            if -returncode == signal.SIGXCPU:
                detail += " (CPU-time limit)"
        elif lines:
            detail = lines[-1]
        elif stdout.strip():
            detail = "malformed answer from the child"
        else:
            detail = f"exit status {returncode}"
        raise XacroError(one_line(f"{path}: untrusted xacro expansion failed ({detail})")) from None
    if isinstance(answer.get("xml"), str):
        return answer["xml"]
    message = one_line(answer["message"])
    if answer["kind"] == "parse":
        raise ModelParseError(f"{path}: malformed XML ({message})")
    if answer["kind"] == "unconfined":
        raise XacroError(f"{path}: the sandbox could not confine the child ({message}); "
                         "refusing to expand untrusted xacro unconfined")
    if answer["kind"] == "package":
        raise XacroError(unknown_package(message, packages or {}, path))
    if answer["kind"] == "unreadable" and readable:
        raise XacroError(f"{path}: xacro error: {message}; an untrusted xacro may read only {readable}"
                         "and the Python installation: name the package holding that file (--package-path DIR, "
                         "load(package_path=[...]) or ROS_PACKAGE_PATH), or "
                         "load the model with trusted=True if you trust its author")
    raise XacroError(f"{path}: xacro error: {message}")
