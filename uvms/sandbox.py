"""Untrusted xacro: expand it in a separate, restricted process.

A xacro file is code: its ``${...}`` expressions are Python, and xacro's name
filter can be escaped (``python.vars(python.type)`` reaches every class, file
objects included). A model from someone else is therefore expanded in a child
process that

- runs ``python -I -B`` (isolated: no environment variables, no user site, no
  bytecode written) with an empty environment, in an empty temporary folder;
- installs an audit hook (PEP 578) before xacro is imported that refuses every
  write-mode ``open``, file-system change, process creation, network access and
  ``ctypes``;
- may not grow any file (``RLIMIT_FSIZE = 0``) and has a CPU-time limit;
- is killed after ``timeout`` seconds.

It can still read files (xacro needs to read its includes). This is defence in
depth for model files from colleagues and the internet, not a security boundary
against a determined attacker: run models of unknown origin in a container.
Plain URDF is never executed and is always safe to load.
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path

from .errors import ModelParseError, XacroError

#: Seconds an untrusted xacro expansion may take.
DEFAULT_TIMEOUT = 30.0

#: The child: audit hook first, then xacro; the result as one JSON document on stdout.
WORKER = r"""
import json, sys

FORBIDDEN_PREFIXES = ("os.remove", "os.unlink", "os.rename", "os.replace", "os.mkdir", "os.rmdir", "os.chmod",
                      "os.chown", "os.link", "os.symlink", "os.truncate", "os.utime", "os.system", "os.exec",
                      "os.posix_spawn", "os.spawn", "os.fork", "os.forkpty", "os.kill", "os.putenv", "os.unsetenv",
                      "os.chdir", "os.startfile", "subprocess.", "shutil.", "socket.", "ctypes.", "pty.", "fcntl.",
                      "sqlite3.", "webbrowser.", "winreg.")
WRITE_FLAGS = 0o1 | 0o2 | 0o100 | 0o1000 | 0o2000  # O_WRONLY | O_RDWR | O_CREAT | O_TRUNC | O_APPEND


def hook(event, args):
    if event == "open":
        mode, flags = args[1], args[2]
        if (isinstance(mode, str) and any(c in mode for c in "wax+")) or (isinstance(flags, int) and flags & WRITE_FLAGS):
            raise PermissionError(f"untrusted xacro may not write files (tried {args[0]!r})")
    elif event.startswith(FORBIDDEN_PREFIXES):
        raise PermissionError(f"untrusted xacro may not do {event}")


sys.addaudithook(hook)
request = json.loads(sys.stdin.read())
try:
    import xacro
    from xml.parsers.expat import ExpatError
    try:
        document = xacro.process_file(request["path"], mappings=request["mappings"])
        print(json.dumps({"xml": document.toprettyxml(indent="  ")}))
    except ExpatError as exc:
        print(json.dumps({"kind": "parse", "message": str(exc)}))
    except Exception as exc:  # xacro errors, and what the hook refused
        print(json.dumps({"kind": "xacro", "message": " ".join(str(exc).split())}))
except BaseException as exc:
    print(json.dumps({"kind": "xacro", "message": f"{type(exc).__name__}: {exc}"}))
"""


def _limit_resources(cpu_seconds: int) -> None:  # pragma: no cover - runs in the child
    import resource

    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))
    resource.setrlimit(resource.RLIMIT_CPU, (cpu_seconds, cpu_seconds))


def expand_untrusted(path: Path, mappings: Mapping[str, str], timeout: float = DEFAULT_TIMEOUT) -> str:
    """Expand a xacro file in the restricted child process described above.

    Args:
        path: the ``.xacro`` file.
        mappings: xacro args, already formatted as strings.
        timeout: wall-clock limit [s].

    Returns:
        The URDF text.

    Raises:
        XacroError: xacro failed, the file tried something it may not, or the time ran out.
        ModelParseError: the file is not well-formed XML.
    """
    request = json.dumps({"path": str(Path(path).resolve()), "mappings": dict(mappings)})
    with tempfile.TemporaryDirectory(prefix="uvms-xacro-") as folder:
        try:
            completed = subprocess.run(
                [sys.executable, "-I", "-B", "-c", WORKER], input=request, capture_output=True, text=True,
                cwd=folder, env={}, timeout=timeout, check=False,
                preexec_fn=functools.partial(_limit_resources, int(timeout) + 1) if os.name == "posix" else None,
            )
        except subprocess.TimeoutExpired:
            raise XacroError(f"{path}: untrusted xacro expansion took longer than {timeout:g} s and was stopped") from None
    try:
        answer = json.loads(completed.stdout)
    except json.JSONDecodeError:
        detail = (completed.stderr.strip().splitlines() or [f"exit status {completed.returncode}"])[-1]
        raise XacroError(f"{path}: untrusted xacro expansion failed ({detail})") from None
    if "xml" in answer:
        return answer["xml"]
    if answer["kind"] == "parse":
        raise ModelParseError(f"{path}: malformed XML ({answer['message']})")
    raise XacroError(f"{path}: xacro error: {answer['message']}")
