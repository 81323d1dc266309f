"""Untrusted xacro: expand it in a child process that the operating system confines.

A xacro file is code: its ``${...}`` expressions are Python, and xacro's name filter can be escaped
(``python.vars(python.type)`` reaches every class, the modules ``os`` and ``sys`` included). A Python-level
guard cannot hold such code, so a model from someone else is expanded in a child process (source:
``uvms/model/sandbox_worker.py``) on which the **kernel** enforces the boundary:

- a seccomp filter (libseccomp through ``pyseccomp``) refuses, with EPERM: new processes and programs
  (fork, vfork, clone, execve), signals and handles to other processes (kill, tgkill, pidfd_*, ptrace),
  sockets and System V / POSIX IPC, opening any file for writing (O_WRONLY, O_RDWR, O_CREAT, O_TRUNC,
  O_APPEND), every file-system change (rename, unlink, mkdir, chmod, chown, truncate, utime, mknod,
  xattrs, mount...), io_uring, raising its limits, changing identity or namespaces; syscalls newer than
  its list are refused with ENOSYS;
- resource limits: address space (``memory_bytes``), CPU time, no file growth, no core file, no new
  processes, 64 file descriptors;
- it runs ``python -I -B`` with an empty environment in an empty temporary folder, in its own session
  and process group, which is killed as a whole at the timeout and after every expansion;
- the URDF it hands back is read with a size cap (``max_urdf_bytes``);
- a PEP 578 audit hook refuses the same things at the Python level (a second layer, clearer messages).

The child may read files the user can read (xacro reads its includes); what it reads can only come back
as the URDF text. Where the mechanism is missing (not Linux, no libseccomp, no ``pyseccomp``) untrusted
expansion is refused with a message saying so, never run unconfined. Plain URDF is never executed.
"""

from __future__ import annotations

import functools
import json
import os
import selectors
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping
from pathlib import Path

from ..errors import ModelParseError, XacroError

#: Seconds an untrusted xacro expansion may take [s].
DEFAULT_TIMEOUT = 30.0
#: Address space of the child [bytes]: xacro needs about 40 MiB.
DEFAULT_MEMORY_BYTES = 1 << 30
#: Largest URDF the child may hand back [bytes].
MAX_URDF_BYTES = 32 << 20

WORKER_SOURCE = (Path(__file__).with_name("sandbox_worker.py")).read_text(encoding="utf-8")


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


def expand_untrusted(
    path: Path,
    mappings: Mapping[str, str],
    timeout: float = DEFAULT_TIMEOUT,
    *,
    memory_bytes: int = DEFAULT_MEMORY_BYTES,
    max_urdf_bytes: int = MAX_URDF_BYTES,
    audit_hook: bool = True,
) -> str:
    """Expand a xacro file in the confined child process described above.

    Args:
        path: the ``.xacro`` file.
        mappings: xacro args, already checked and formatted as strings.
        timeout: wall-clock limit [s].
        memory_bytes: address-space limit of the child [bytes].
        max_urdf_bytes: largest URDF accepted back [bytes].
        audit_hook: install the Python-level second layer (False only to test the kernel layer alone).

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
    request = json.dumps({"path": str(Path(path).resolve()), "mappings": dict(mappings),
                          "memory_bytes": int(memory_bytes), "cpu_seconds": int(timeout) + 1,
                          "audit_hook": bool(audit_hook)}).encode()
    with tempfile.TemporaryDirectory(prefix="uvms-xacro-") as folder:
        process = subprocess.Popen(
            [sys.executable, "-I", "-B", "-c", WORKER_SOURCE], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, cwd=folder, env={}, close_fds=True, start_new_session=True,
        )
        try:
            stdout, stderr, stop = collect_output(process, request, timeout, max_urdf_bytes)
        finally:
            kill_process_group(process)
    if stop == "timeout":
        raise XacroError(f"{path}: untrusted xacro expansion took longer than {timeout:g} s and was stopped")
    if stop == "too large":
        raise XacroError(f"{path}: untrusted xacro produced more than {max_urdf_bytes >> 20} MiB of URDF; "
                         "no UVMS model is that large")
    return read_answer(path, stdout, stderr, process.returncode)


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


def read_answer(path: Path, stdout: bytes, stderr: bytes, returncode: int | None) -> str:
    """The URDF from the child's JSON answer, or the matching error."""
    try:
        answer = json.loads(stdout)
    except (json.JSONDecodeError, UnicodeDecodeError):
        if returncode is not None and returncode < 0:
            detail = f"killed by {signal.Signals(-returncode).name}"
            if -returncode == signal.SIGXCPU:
                detail += " (CPU-time limit)"
        else:
            lines = stderr.decode(errors="replace").strip().splitlines()
            detail = lines[-1] if lines else f"exit status {returncode}"
        raise XacroError(f"{path}: untrusted xacro expansion failed ({detail})") from None
    if "xml" in answer:
        return answer["xml"]
    if answer["kind"] == "parse":
        raise ModelParseError(f"{path}: malformed XML ({answer['message']})")
    if answer["kind"] == "unconfined":
        raise XacroError(f"{path}: the sandbox could not confine the child ({answer['message']}); "
                         "refusing to expand untrusted xacro unconfined")
    raise XacroError(f"{path}: xacro error: {answer['message']}")
