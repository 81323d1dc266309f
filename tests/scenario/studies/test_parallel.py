"""The executor of sweeps and studies (uvms.scenario.studies.parallel): remote Dask schedulers that are not tls:// only
when the user says so, and a scheduler that stays silent or speaks another protocol ends the command within the
timeout, in one line."""

from __future__ import annotations

import contextlib
import importlib.util
import socket
import struct
import threading
import time
from collections.abc import Iterator

import pytest

from uvms.cli import main
from uvms.errors import StudyError, SweepError
from uvms.scenario.studies import parallel
from uvms.scenario.studies.study import study
from uvms.scenario.studies.sweep import sweep

from conftest import SCENARIOS

SCENARIO = SCENARIOS / "santos2006_task_priority.toml"
GRID = ["solver.gain=0.5:1.5:2"]


def test_a_scheduler_that_is_not_tls_is_refused_unless_the_user_says_so(tmp_path, capsys):
    words = (r"the Dask scheduler tcp://127.0.0.1:9 is not tls://, so neither encrypted nor authenticated: anyone who "
             r"can reach it can join it as a worker and run any code on its workers and, through the pickled results "
             r"it sends back, inside this uvms process, as you; use a tls:// scheduler with credentials .* or, on a "
             r"network that only you can reach, say so with --insecure-scheduler \(insecure_scheduler=True\)")
    with pytest.raises(SweepError, match=words):
        sweep(SCENARIO, GRID, backend="dask", scheduler="tcp://127.0.0.1:9", out=tmp_path / "s")
    with pytest.raises(StudyError, match=words):
        study(SCENARIO, ["solver.gain=uniform(0.5, 1.5)"], n=2, backend="dask", scheduler="tcp://127.0.0.1:9",
              out=tmp_path / "s")
    with pytest.raises(StudyError, match="is not tls://"):  # Dask reads a bare host:port as tcp://
        study(SCENARIO, ["solver.gain=uniform(0.5, 1.5)"], n=2, backend="dask", scheduler="127.0.0.1:9",
              out=tmp_path / "s")
    assert not list(tmp_path.iterdir())  # refused before anything ran or was written
    commands = [["sweep", str(SCENARIO), "--grid", GRID[0]],
                ["study", str(SCENARIO), "--samples", "solver.gain=uniform(0.5, 1.5)", "-n", "2"]]
    if importlib.util.find_spec("optuna"):
        commands.append(["tune", str(SCENARIO), "--param", "solver.gain=0.5:1.5", "--trials", "1"])
    for command in commands:
        assert main([*command, "--backend", "dask", "--scheduler", "tcp://127.0.0.1:9", "--out",
                     str(tmp_path / "s")]) == 2
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 1 and err[0].startswith("uvms: error: the Dask scheduler tcp://127.0.0.1:9 is not tls://")
        assert "inside this uvms process" in err[0] and "--insecure-scheduler" in err[0]
    assert not list(tmp_path.iterdir())


@contextlib.contextmanager
def peer(reply: bytes | None) -> Iterator[str]:
    """A TCP server on 127.0.0.1 that accepts every connection, sends ``reply`` (None: nothing) and never closes it
    until the block ends: its address."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.1)
    stop, held = threading.Event(), []

    def serve() -> None:
        while not stop.is_set():
            try:
                connection, _ = server.accept()
            except TimeoutError:
                continue
            held.append(connection)
            if reply:
                connection.sendall(reply)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join(5)
        for connection in [*held, server]:
            connection.close()


@pytest.mark.parametrize(("reply", "words"), [
    (None, "did not answer within 1 s (something accepts the connection but does not speak Dask's protocol"),
    (struct.pack("<Q", 2**62) + bytes(64), "answered with something that is not Dask's protocol (MemoryError"),
    (struct.pack("<Q", 1) + b"\x05", "answered with something that is not Dask's protocol (error: "),
])
def test_a_silent_or_foreign_scheduler_ends_the_command_in_one_line_within_the_timeout(reply, words, tmp_path,
                                                                                        capsys, monkeypatch):
    pytest.importorskip("dask.distributed")
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 1.0)
    status = []
    with peer(reply) as address:
        command = ["sweep", str(SCENARIO), "--grid", GRID[0], "--backend", "dask", "--scheduler", address,
                   "--insecure-scheduler", "--out", str(tmp_path / "s"), "--quiet"]
        started = time.monotonic()
        runner = threading.Thread(target=lambda: status.append(main(command)), daemon=True)
        runner.start()
        runner.join(15)  # the old code waited for the handshake forever
        elapsed = time.monotonic() - started
    assert status == [2] and elapsed < 5
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"uvms: error: the Dask scheduler {address} ")
    assert words in err[0]
    assert not (tmp_path / "s").exists()


def test_a_worker_process_is_settled_once_after_its_first_task_and_the_uvms_process_never(monkeypatch):
    calls = []
    monkeypatch.setattr(parallel.gc, "collect", lambda: calls.append("collect"))
    monkeypatch.setattr(parallel.gc, "freeze", lambda: calls.append("freeze"))
    monkeypatch.setattr(parallel, "watch_parent", lambda parent: None)
    monkeypatch.setattr(parallel, "_settled", False)
    ours = parallel.process_identity(parallel.os.getpid())
    assert parallel.in_worker(lambda x: {"x": x}, ours, 1) == {"x": 1}  # joblib's job in the uvms process itself
    assert parallel.in_worker(lambda x: {"x": x}, None, 2) == {"x": 2}  # a remote cluster's worker: not ours
    assert calls == []
    uvms_process = (parallel.os.getpid() + 1, None)  # the task came from another process: this is its worker
    assert parallel.in_worker(lambda x: {"x": x}, uvms_process, 3) == {"x": 3}
    assert calls == ["collect", "freeze"]  # the first task's garbage collected, what survives frozen
    with pytest.raises(ZeroDivisionError):
        parallel.in_worker(lambda x: 1 / x, uvms_process, 0)
    assert calls == ["collect", "freeze"]  # once per process
