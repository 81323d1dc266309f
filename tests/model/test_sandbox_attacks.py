"""Attacks on the xacro sandbox (uvms.model.sandbox) that once got through: each must now fail and leave no effect on
its target.

The hostile expressions reach ``os``, ``fcntl``, ``ctypes``... from xacro's restricted eval as in
``tests/model/test_sandbox.py``; they are written without ``<``, ``&`` and braces (they sit in an XML attribute of a
``${...}``). "seccomp alone" turns off the audit hook and Landlock to show the seccomp filter holds by itself.
"""

from __future__ import annotations

import ctypes
import json
import os
import shutil
import signal
import subprocess
import sys
import termios
import threading
import time
from pathlib import Path

import pytest

import uvms
from uvms.model import sandbox
from uvms.model.sandbox import expand_untrusted, read_answer

from conftest import IMPORT, xacro_file

OS = f"{IMPORT}('os')"
FCNTL = f"{IMPORT}('fcntl')"
CTYPES = f"{IMPORT}('ctypes')"
SYSCALL = f"{CTYPES}.CDLL(None, use_errno=True).syscall"
X86_64 = os.uname().machine == "x86_64"  # the raw syscall numbers below are x86_64's
REFUSED = "not permitted|may not|refused errno 1'|Permission denied"
LAYERS = {"all layers": {}, "kernel alone": {"audit_hook": False},
          "seccomp alone": {"audit_hook": False, "landlock": False}}


def checked(call: str) -> str:
    """A raw syscall that raises (naming errno) when the kernel refuses it, and is 0 when it succeeds."""
    return f"(python.int('refused errno %d' % {CTYPES}.get_errno()) if 0 > ({call}) else 0)"


def refused(path: Path, layers: str, name: str) -> None:
    """Expanding ``path`` fails with a one-line XacroError that says the kernel or the hook refused."""
    with pytest.raises(uvms.errors.XacroError, match=REFUSED) as raised:
        expand_untrusted(path, {}, timeout=20.0, **LAYERS[layers])
    assert len(str(raised.value).splitlines()) == 1, name


@pytest.fixture
def victim():
    """A process of this user, in its own session and process group, that the attacks aim at."""
    process = subprocess.Popen(["sleep", "120"], start_new_session=True)
    yield process
    process.kill()
    process.wait()


# --- 3. signals through SIGIO ----------------------------------------------------------------------------

def sigio_attacks(pid: int) -> dict[str, str]:
    struct = f"{IMPORT}('struct')"
    pipe_written = f"[{OS}.write(p[1], b'x') for p in [{OS}.pipe()] if "
    return {
        "F_SETOWN, F_SETSIG SIGKILL, O_ASYNC": pipe_written + f"{FCNTL}.fcntl(p[0], 8, {pid}) + "
        f"{FCNTL}.fcntl(p[0], 10, 9) + {FCNTL}.fcntl(p[0], 4, 0o20000) == 0]",
        "F_SETOWN_EX, FIOASYNC, default SIGIO": pipe_written + f"{FCNTL}.fcntl(p[0], 15, {struct}.pack('ii', 1, "
        f"{pid})) and {FCNTL}.ioctl(p[0], 0x5452, {struct}.pack('i', 1))]",
    } | ({} if not X86_64 else {
        "F_SETOWN with high bits set, default SIGIO": pipe_written + checked(
            f"{SYSCALL}(72, p[0], {CTYPES}.c_long(8 + 2 ** 32), {pid})") + " + " +
        checked(f"{SYSCALL}(72, p[0], 4, 0o20000)") + " == 0]",
    })


@pytest.mark.parametrize("layers", ["all layers", "kernel alone", "seccomp alone"])
def test_no_signal_reaches_another_process_through_sigio(tmp_path, victim, layers):
    for name, attack in sigio_attacks(victim.pid).items():
        refused(xacro_file(tmp_path, attack), layers, name)
        time.sleep(0.1)
        assert victim.poll() is None, name  # SIGIO/SIGKILL never reached it


# --- 4. scheduling of other processes --------------------------------------------------------------------

STRANGER_UID = 54321  # a user with no other process: PRIO_USER aimed at it touches only the victim below


def scheduling_attacks(pid: int) -> dict[str, str]:
    sched_attr = f"{CTYPES}.byref(({CTYPES}.c_uint32 * 14)(56, 5))"  # size 56, SCHED_IDLE
    node = f"{CTYPES}.byref({CTYPES}.c_ulong(1))"
    return {
        "setpriority PRIO_PROCESS": f"{OS}.setpriority(0, {pid}, 19)",
        "setpriority PRIO_PGRP": f"{OS}.setpriority(1, {pid}, 19)",
        "setpriority PRIO_USER": f"{OS}.setpriority(2, {STRANGER_UID}, 19)",
        "sched_setaffinity": f"{OS}.sched_setaffinity({pid}, [{min(os.sched_getaffinity(0))}])",
        "sched_setscheduler": f"{OS}.sched_setscheduler({pid}, {os.SCHED_IDLE}, {OS}.sched_param(0))",
        "sched_setparam": f"{OS}.sched_setparam({pid}, {OS}.sched_param(0))",
        "prlimit64 of another": f"{IMPORT}('resource').prlimit({pid}, 7)",
    } | ({} if not X86_64 else {
        "sched_setattr": checked(f"{SYSCALL}(314, {pid}, {sched_attr}, 0)"),
        "ioprio_set": checked(f"{SYSCALL}(251, 1, {pid}, 3 * 8192)"),  # IOPRIO_CLASS_IDLE
        "migrate_pages": checked(f"{SYSCALL}(256, {pid}, 64, {node}, {node})"),
        "move_pages": checked(f"{SYSCALL}(279, {pid}, 0, None, None, None, 0)"),
    })


def ioprio(pid: int) -> int:
    return ctypes.CDLL(None).syscall(252, 1, pid) if X86_64 else 0  # ioprio_get(IOPRIO_WHO_PROCESS, pid)


@pytest.mark.parametrize("layers", ["all layers", "seccomp alone"])
def test_other_processes_keep_their_scheduling(tmp_path, victim, layers):
    if os.geteuid() != 0:
        pytest.skip("starts a process as another user")
    stranger = subprocess.Popen(["sleep", "120"], start_new_session=True, user=STRANGER_UID)
    try:
        def state() -> tuple:
            return (os.getpriority(os.PRIO_PROCESS, victim.pid), os.getpriority(os.PRIO_PROCESS, stranger.pid),
                    os.sched_getaffinity(victim.pid), os.sched_getscheduler(victim.pid), ioprio(victim.pid))

        before = state()
        for name, attack in scheduling_attacks(victim.pid).items():
            refused(xacro_file(tmp_path, attack), layers, name)
            assert state() == before, name
    finally:
        stranger.kill()
        stranger.wait()
    # its own scheduling stays the child's to set
    own = f"{OS}.setpriority(0, 0, 5) or {OS}.sched_setaffinity(0, {OS}.sched_getaffinity(0))"
    assert "hullNone" in expand_untrusted(xacro_file(tmp_path, own), {}, **LAYERS[layers])


# --- 5. the child dies with its parent -------------------------------------------------------------------

PARENT = """
import sys
from pathlib import Path
from uvms.model import sandbox
if sys.argv[2] == "no landlock":  # as on a kernel without Landlock
    sandbox.landlock_abi = lambda: 0
try:
    print("RESULT", sandbox.expand_untrusted(Path(sys.argv[1]), {}, timeout=120))
except Exception as exc:
    print("ERROR", type(exc).__name__, exc)
"""


def children_of(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if int((entry / "stat").read_text().rpartition(")")[2].split()[1]) == pid:
                    found.append(int(entry.name))
            except (OSError, IndexError, ValueError):
                continue
    return found


def confined(pid: int) -> bool:
    """The child has loaded its seccomp filter (so it is in xacro, past its start-up)."""
    try:
        return "Seccomp:\t2" in Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False


def alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()[0] != "Z"
    except OSError:
        return False


def sleeping_child(parent: subprocess.Popen) -> int:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        ready = [pid for pid in children_of(parent.pid) if confined(pid)]
        if ready:
            time.sleep(0.5)  # into the sleep
            return ready[0]
        time.sleep(0.1)
    raise AssertionError(f"no confined child appeared: {parent.communicate(timeout=5)}")


@pytest.mark.parametrize("signum", [signal.SIGKILL, signal.SIGTERM, signal.SIGHUP], ids=lambda s: s.name)
def test_the_child_dies_with_its_parent(tmp_path, signum):
    path = xacro_file(tmp_path, f"{IMPORT}('time').sleep(100)")
    parent = subprocess.Popen([sys.executable, "-c", PARENT, str(path), "all layers"], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE)
    child = None
    try:
        child = sleeping_child(parent)
        parent.send_signal(signum)
        assert parent.wait(10) == -signum  # the parent still dies of the signal
        deadline = time.monotonic() + 3
        while alive(child) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not alive(child)
    finally:
        parent.kill()
        parent.communicate()
        if child is not None and alive(child):
            os.kill(child, signal.SIGKILL)


def test_a_child_whose_parent_is_already_gone_stops_at_once(tmp_path):
    # the parent may die before the child asks to die with it: the child then has another parent, and exits
    request = {"path": str(xacro_file(tmp_path, "1")), "mappings": {}, "memory_bytes": 1 << 30,
               "cpu_seconds": 10, "audit_hook": True, "landlock": True, "read_roots": [],
               "parent_pid": os.getpid() + 1_000_000}  # not its parent
    run = subprocess.run([sys.executable, "-I", "-B", "-c", sandbox.WORKER_SOURCE], input=json.dumps(request),
                         capture_output=True, text=True, timeout=60, env={})
    assert (run.returncode, run.stdout) == (1, "")


def test_a_handler_of_the_caller_still_runs_and_is_restored(tmp_path):
    if threading.current_thread() is not threading.main_thread():
        pytest.skip("Python runs signal handlers in the main thread only")
    received = []

    def handler(signum: int, frame: object) -> None:
        received.append(signum)

    before = signal.signal(signal.SIGHUP, handler)
    try:
        timer = threading.Timer(3.0, os.kill, (os.getpid(), signal.SIGHUP))
        timer.start()
        with pytest.raises(uvms.errors.XacroError, match="killed by SIGKILL"):  # the handler killed the child first
            expand_untrusted(xacro_file(tmp_path, f"{IMPORT}('time').sleep(100)"), {}, timeout=20.0)
        timer.join()
        assert received == [signal.SIGHUP] and signal.getsignal(signal.SIGHUP) is handler
    finally:
        signal.signal(signal.SIGHUP, before)


# --- 6. what the child may read --------------------------------------------------------------------------

SECRET = "uvms-test-secret-7f3a9c"


# Root without capabilities stands for an ordinary user: the child then has no capability to give up, and
# only the parent's being non-dumpable keeps its /proc files from a child of the same user without Landlock.
NO_CAPABILITIES = ["setpriv", "--bounding-set=-all", "--inh-caps=-all"]


@pytest.mark.parametrize("user", ["root", "no capabilities"])
@pytest.mark.parametrize("kernel", ["landlock", "no landlock"])
def test_the_parent_environment_does_not_leak(tmp_path, kernel, user):
    if user != "root" and (os.geteuid() != 0 or shutil.which("setpriv") is None):
        pytest.skip("needs root and setpriv to drop the capabilities")
    environ = f"'/proc/%d/environ' % {OS}.getppid()"
    attacks = [f"{IMPORT}('io').open({environ}, 'rb').read().hex()",
               f"{OS}.read({OS}.open({environ}, 0), 65536).hex()"]
    prefix = NO_CAPABILITIES if user != "root" else []
    for attack in attacks:
        path = xacro_file(tmp_path, attack)
        run = subprocess.run([*prefix, sys.executable, "-c", PARENT, str(path), kernel], capture_output=True,
                             text=True, timeout=120, env={**os.environ, "UVMS_SECRET": SECRET})
        said = run.stdout + run.stderr
        assert run.stdout.startswith("ERROR XacroError") and "Permission denied" in run.stdout, said
        assert SECRET not in said and SECRET.encode().hex() not in said
    # and a legitimate model still expands there
    run = subprocess.run([*prefix, sys.executable, "-c", PARENT, str(xacro_file(tmp_path, "1 + 1")), kernel],
                         capture_output=True, text=True, timeout=120)
    assert run.stdout.startswith("RESULT") and 'name="hull2"' in run.stdout, run.stdout + run.stderr


def include_model(folder: Path, filename: Path | str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "main.urdf.xacro"
    path.write_text(f"""<?xml version="1.0"?>
<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <link name="world"/>
  <xacro:include filename="{filename}"/>
</robot>
""")
    return path


def part(path: Path, link: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'<robot xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="{link}"/></robot>')


def test_includes_inside_the_model_folder_work(tmp_path):
    part(tmp_path / "model" / "parts" / "arm.xacro", "arm_from_subfolder")
    urdf = expand_untrusted(include_model(tmp_path / "model", "parts/arm.xacro"), {})
    assert 'name="arm_from_subfolder"' in urdf


def test_includes_outside_the_named_folders_are_refused_clearly(tmp_path, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    part(elsewhere / "pkg" / "arm.xacro", "arm_from_elsewhere")
    path = include_model(tmp_path / "model", elsewhere / "pkg" / "arm.xacro")
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    with pytest.raises(uvms.errors.XacroError) as raised:
        expand_untrusted(path, {})
    message = str(raised.value)
    assert len(message.splitlines()) == 1
    for said in ("Permission denied", str(elsewhere / "pkg" / "arm.xacro"), "may read only",
                 str(tmp_path / "model"), "ROS_PACKAGE_PATH", "trusted=True"):
        assert said in message
    assert 'name="arm_from_elsewhere"' in expand_untrusted(path, {}, packages={"pkg": elsewhere / "pkg"})
    (elsewhere / "pkg" / "package.xml").write_text("<package><name>pkg</name></package>")
    monkeypatch.setenv("ROS_PACKAGE_PATH", str(elsewhere))
    assert 'name="arm_from_elsewhere"' in expand_untrusted(path, {})


def test_load_package_path_names_the_folders_an_untrusted_xacro_may_include_from(tmp_path, monkeypatch):
    elsewhere = tmp_path / "elsewhere"
    part(elsewhere / "pkg" / "arm.xacro", "arm_from_elsewhere")
    (elsewhere / "pkg" / "package.xml").write_text("<package><name>pkg</name></package>")
    path = include_model(tmp_path / "model", elsewhere / "pkg" / "arm.xacro")
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    from uvms.model.loader import read_model_text

    with pytest.raises(uvms.errors.XacroError, match="package_path"):
        read_model_text(path, trusted=False)
    xml, _, _ = read_model_text(path, trusted=False, packages=uvms.model.package_index([elsewhere]))
    assert 'name="arm_from_elsewhere"' in xml


# --- 7. the user's terminal ------------------------------------------------------------------------------

def terminal_attacks(tty: str) -> dict[str, str]:
    termios_ = f"{IMPORT}('termios')"
    opened = f"for T in [{termios_}] for f in [{OS}.open('{tty}', {os.O_RDONLY | os.O_NOCTTY})]"
    return {
        "echo off": f"[T.tcsetattr(f, 0, a[:3] + [(a[3] | 8) ^ 8] + a[4:]) {opened} for a in [T.tcgetattr(f)]]",
        "window size": f"[T.tcsetwinsize(f, (3, 7)) {opened}]",
        "flush the typed input": f"[T.tcflush(f, T.TCIFLUSH) {opened}]",
        "inject input": f"[{FCNTL}.ioctl(f, 0x5412, b'x') {opened}]",  # TIOCSTI
    }


@pytest.mark.parametrize("layers", ["all layers", "seccomp alone"])
def test_the_terminal_is_left_alone(tmp_path, layers):
    master, slave = os.openpty()
    try:
        termios.tcsetwinsize(slave, (24, 80))
        before = termios.tcgetattr(slave), termios.tcgetwinsize(slave)
        os.write(master, b"typed\n")
        for name, attack in terminal_attacks(os.ttyname(slave)).items():
            refused(xacro_file(tmp_path, attack), layers, name)
            assert (termios.tcgetattr(slave), termios.tcgetwinsize(slave)) == before, name
        os.set_blocking(slave, False)
        assert os.read(slave, 100) == b"typed\n"  # neither flushed nor added to
    finally:
        os.close(master)
        os.close(slave)


# --- 15. a hostile answer --------------------------------------------------------------------------------

MALFORMED = {"200000 [": b"[" * 200_000, "100000 {": b'{"a":' * 100_000, "list": b"[]", "string": b'"text"',
             "kind not text": b'{"kind": 1}', "xml not text": b'{"xml": 5}', "no message": b'{"kind": "xacro"}',
             "not UTF-8": b"\xff\xfe", "null": b"null"}


@pytest.mark.parametrize("stdout", MALFORMED.values(), ids=MALFORMED.keys())
def test_a_malformed_answer_is_a_one_line_error(tmp_path, stdout):
    with pytest.raises(uvms.errors.XacroError, match="untrusted xacro expansion failed") as raised:
        read_answer(tmp_path / "m.xacro", stdout, b"", 0)
    assert len(str(raised.value).splitlines()) == 1 and len(str(raised.value)) < 500


def test_a_hostile_message_is_one_bounded_line(tmp_path):
    stdout = b'{"kind": "xacro", "message": "first\\nsecond\\r\\n' + b"x" * 100_000 + b'"}'
    with pytest.raises(uvms.errors.XacroError, match="xacro error: first second") as raised:
        read_answer(tmp_path / "m.xacro", stdout, b"", 0)
    assert len(str(raised.value).splitlines()) == 1 and len(str(raised.value)) < 3000
