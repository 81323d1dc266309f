"""The xacro sandbox (uvms.model.sandbox): untrusted xacro runs in a restricted child process; trusted xacro and
plain URDF load in-process."""

from __future__ import annotations

import os
import resource
import subprocess
import time
from pathlib import Path

import pytest

import uvms
from uvms.model import sandbox
from uvms.model.sandbox import expand_untrusted

from conftest import ESCAPE, IMPORT, urdf, xacro_file


def test_untrusted_xacro_cannot_write_a_file(tmp_path):
    target = tmp_path / "pwned.txt"
    path = xacro_file(tmp_path, ESCAPE.format(target=target))
    with pytest.raises(uvms.errors.XacroError, match="may not write files"):
        uvms.load(path)  # a user file: untrusted by default
    assert not target.exists()
    robot = uvms.load(path, trusted=True)  # what the switch guards against: in-process, the write happens
    assert target.read_bytes() == b"owned" and robot.model.nq == 7


def test_untrusted_xacro_times_out(tmp_path):
    path = xacro_file(tmp_path, "python.sum(python.range(10**11))")
    with pytest.raises(uvms.errors.XacroError, match="longer than 1 s"):
        expand_untrusted(path, {}, timeout=1.0)


def test_untrusted_xacro_gives_the_same_model_and_errors(tmp_path):
    shipped = uvms.model.resources.shipped_models()["xiang2019"]
    inside = uvms.load(shipped, args={"hull_height": 0.8})
    outside = uvms.load(shipped, args={"hull_height": 0.8}, trusted=False)
    assert outside.urdf == inside.urdf
    for path in uvms.model.resources.shipped_models().values():  # the filter refuses nothing real xacro needs
        assert uvms.load(path, trusted=False).urdf == uvms.load(path).urdf
    broken = tmp_path / "broken.urdf.xacro"
    broken.write_text('<robot name="r" xmlns:xacro="http://www.ros.org/wiki/xacro"><link '
                      'name="${undefined_x}"/></robot>')
    with pytest.raises(uvms.errors.XacroError, match="undefined_x"):
        uvms.load(broken)
    malformed = tmp_path / "malformed.urdf.xacro"
    malformed.write_text("<robot name='r'><link name='a'></robot>")
    with pytest.raises(uvms.errors.ModelParseError):
        uvms.load(malformed)


def test_plain_urdf_is_never_executed(tmp_path):
    path = tmp_path / "plain.urdf"
    path.write_text(urdf().replace('"l1"', '"l1${1+1}"'))  # no xacro: the text is a name, not code
    robot = uvms.load(path, ee="l1${1+1}")
    assert robot.ee_frames == ["l1${1+1}"]


def escapes(folder: Path, victim_pid: int) -> dict[str, str]:
    """Attacks the issue lists, each as Python reachable from a xacro expression."""
    os_ = f"{IMPORT}('os')"
    return {
        "write a file": f"{os_}.open('{folder / 'new.txt'}', 65)",
        "rewrite a file": f"{IMPORT}('io').open('{folder / 'precious.txt'}', 'w')",
        "rename over a file": f"{os_}.rename('{folder / 'other.txt'}', '{folder / 'precious.txt'}')",
        "delete a file": f"{os_}.unlink('{folder / 'precious.txt'}')",
        "truncate a file": f"{os_}.truncate('{folder / 'precious.txt'}', 0)",
        "make a directory": f"{os_}.mkdir('{folder / 'dir'}')",
        "mknod": f"{os_}.mknod('{folder / 'node'}')",
        "mkfifo": f"{os_}.mkfifo('{folder / 'fifo'}')",
        "setxattr": f"{os_}.setxattr('{folder / 'precious.txt'}', 'user.x', b'1')",
        "socket": f"{IMPORT}('socket').socket()",
        "fork_exec a shell": f"{IMPORT}('subprocess').Popen(['/bin/sh', '-c', 'sleep 2; touch {folder / 'late.txt'}'])",
        "fork": f"{os_}.fork()",
        "posix_spawn": f"{os_}.posix_spawn('/bin/sh', ['sh', '-c', 'touch {folder / 'spawned.txt'}'], {{}})",
        "kill a process": f"{os_}.kill({victim_pid}, 9)",
        "pidfd_send_signal": f"{IMPORT}('signal').pidfd_send_signal({os_}.pidfd_open({victim_pid}), 9)",
        "raise its file-size limit": f"{IMPORT}('resource').setrlimit(1, (-1, -1))",
        "raw syscall through ctypes": f"{IMPORT}('ctypes').CDLL(None).syscall(2, b'{folder / 'raw.txt'}', 65, 438) + "
                                      f"python.int('refused')",
    }


@pytest.mark.parametrize("audit_hook", [True, False], ids=["with audit hook", "kernel alone"])
def test_every_escape_is_refused_and_leaves_no_trace(tmp_path, audit_hook):
    work = tmp_path / "victim"
    work.mkdir()
    (work / "precious.txt").write_text("keep")
    (work / "other.txt").write_text("other")
    victim = subprocess.Popen(["sleep", "60"])
    try:
        for name, attack in escapes(work, victim.pid).items():
            path = xacro_file(tmp_path, attack)
            with pytest.raises(uvms.errors.XacroError, match="not permitted|may not|refused") as raised:
                expand_untrusted(path, {}, timeout=10.0, audit_hook=audit_hook)
            assert len(str(raised.value).splitlines()) == 1, name
        time.sleep(2.5)  # a detached child, had one been made, would act now
        assert victim.poll() is None  # the victim (and this process) still alive
    finally:
        victim.kill()
    assert sorted(p.name for p in work.iterdir()) == ["other.txt", "precious.txt"]
    assert (work / "precious.txt").read_text() == "keep" and "user.x" not in os.listxattr(work / "precious.txt")


def test_memory_and_output_bombs_are_stopped(tmp_path):
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(uvms.errors.XacroError, match="memory|MemoryError"):
        expand_untrusted(xacro_file(tmp_path, "python.len('x' * 3 * 10**9)"), {}, memory_bytes=256 << 20)
    with pytest.raises(uvms.errors.XacroError, match="more than 1 MiB of URDF"):
        expand_untrusted(xacro_file(tmp_path, "'x' * 3 * 2**20"), {}, max_urdf_bytes=1 << 20)
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss < 200 << 10  # KiB: the parent stayed small


def test_no_confinement_means_no_untrusted_expansion(tmp_path, monkeypatch):
    monkeypatch.setattr(sandbox, "confinement_problem", lambda: "untrusted xacro needs libseccomp (test)")
    with pytest.raises(uvms.errors.XacroError, match="needs libseccomp.*trusted=True only if you trust"):
        uvms.load(xacro_file(tmp_path, "1"))
