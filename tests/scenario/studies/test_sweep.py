"""`uvms sweep` (uvms.scenario.studies.sweep): the same table with 1 and 2 loky jobs and on a local Dask cluster,
failures, bad input."""

from __future__ import annotations

import csv
import gc
import math
import os
import socket
import ssl
import time

import pytest

from uvms import UVMSError
from uvms.cli import main
from uvms.scenario import ScenarioError
from uvms.scenario.studies.parallel import dask_client
from uvms.scenario.studies.sweep import MAX_POINTS, METRICS, SweepError, parse_grid, sweep

from conftest import SCENARIOS

SCENARIO = SCENARIOS / "santos2006_task_priority.toml"  # 100 Euler steps
GRID = ["solver.gain=0.5:1.5:2", "model.args.l1=1.5:2.0:2"]  # l1 moves the start; the gain the tracking


def comparable(result):
    """Every column but wall_time, which is the only one allowed to differ between runs."""
    return [{key: value for key, value in row.items() if key != "wall_time"} for row in result.rows]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return sweep(SCENARIO, GRID, jobs=1, out=tmp_path_factory.mktemp("sweep1"), progress=False)


def test_parse_grid():
    assert parse_grid("solver.gain=0.5:1.5:3") == ("solver.gain", [0.5, 1.0, 1.5])
    assert parse_grid("model.args.n_joints=4:8:3") == ("model.args.n_joints", [4, 6, 8])  # ints stay ints
    assert parse_grid("model.args.l1=0.6:0.6:1") == ("model.args.l1", [0.6])
    assert parse_grid("solver.priority=['robust', 'classic']") == ("solver.priority", ["robust", "classic"])
    for bad in ("solver.gain", "gain=1:2:3", "solver.gain=1:2", "solver.gain=1:2:0", "solver.gain=1:2:x",
                "solver.gain=nan:1:3", "solver.gain=1:inf:3", "solver.gain=[]", "solver.gain=[1, 1]"):
        with pytest.raises(SweepError, match="--grid"):
            parse_grid(bad)


def test_sweep_table_one_row_per_point_and_the_grid_changes_the_runs(reference):
    assert reference.columns == ["point", "solver.gain", "model.args.l1", *METRICS, "error"]
    assert [(row["solver.gain"], row["model.args.l1"]) for row in reference.rows] == [
        (0.5, 1.5), (0.5, 2.0), (1.5, 1.5), (1.5, 2.0)]
    assert not reference.failed
    rows = reference.rows
    assert all(math.isfinite(row[key]) for row in rows for key in METRICS)
    assert len({row["final_position_error"] for row in rows}) == 4  # every point really is another run
    assert rows[0]["final_position_error"] > 1.5 * rows[2]["final_position_error"]  # higher gain, smaller error
    assert abs(rows[0]["vehicle_travel"] - rows[1]["vehicle_travel"]) > 0.3  # a shorter first link moves the vehicle
    assert rows[1]["max_position_error"] < 0.07  # the default point is the README's santos2006 run
    folder = reference.files[0].parent
    assert [path.name for path in reference.files] == ["sweep.csv", "sweep.png"]
    assert (folder / "point_3" / "metrics.json").is_file() and not list(folder.glob("point_*/*.png"))
    table = list(csv.DictReader((folder / "sweep.csv").read_text().splitlines()))
    assert [float(row["final_position_error"]) for row in table] == [row["final_position_error"] for row in rows]
    assert (folder / "sweep.png").read_bytes().startswith(b"\x89PNG")


def test_two_jobs_give_the_same_table(reference, tmp_path):
    assert comparable(sweep(SCENARIO, GRID, jobs=2, out=tmp_path, progress=False)) == comparable(reference)


def test_dask_backend_gives_the_same_table(reference, tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with pytest.warns(UserWarning, match="scheduler tcp://.* is not tls://: neither encrypted nor authenticated: "
                                             "anyone .* inside this uvms process"):
            result = sweep(SCENARIO, GRID, backend="dask", scheduler=cluster.scheduler_address, out=tmp_path,
                           progress=False, insecure_scheduler=True)
    assert comparable(result) == comparable(reference)
    assert (tmp_path / "sweep.csv").read_text().splitlines()[0] == ",".join(reference.columns)


def test_a_failed_point_is_reported_not_fatal(tmp_path, capsys):
    # vehicle_mass -5 passes the scenario schema but the model check rejects it, in the worker
    result = sweep(SCENARIO, ["model.args.vehicle_mass=[2000.0, -5.0]"], out=tmp_path, progress=False)
    ok, bad = result.rows
    assert not ok["error"] and math.isfinite(ok["max_position_error"])
    assert "ModelCheckError" in bad["error"] and "mass" in bad["error"]
    assert all(math.isnan(bad[key]) for key in METRICS) and result.failed == [bad]
    assert main(["sweep", str(SCENARIO), "--grid", "model.args.vehicle_mass=[2000.0, -5.0]", "--out", str(tmp_path),
                 "--quiet"]) == 2
    assert "1 of 2 sweep points failed" in capsys.readouterr().err


def test_bad_keys_are_rejected_before_any_worker_starts(tmp_path):
    with pytest.raises(ScenarioError, match="valid in \\[solver\\]: method, gain"):
        sweep(SCENARIO, ["solver.gian=0.5:1.5:2"], jobs=2, out=tmp_path)
    with pytest.raises(ScenarioError, match="unknown section"):
        sweep(SCENARIO, ["solvr.gain=0.5:1.5:2"], out=tmp_path)
    with pytest.raises(UVMSError, match="l1, l2, l3"):  # an unknown xacro arg: the declared ones are listed
        sweep(SCENARIO, ["model.args.l4=1:2:2"], out=tmp_path)
    with pytest.raises(SweepError, match="backend"):
        sweep(SCENARIO, ["solver.gain=1:2:2"], backend="ray", out=tmp_path)
    with pytest.raises(SweepError, match="distinct"):
        sweep(SCENARIO, ["solver.gain=1:2:2", "solver.gain=3:4:2"], out=tmp_path)
    assert not list(tmp_path.iterdir())  # nothing ran


def test_cli_sweep_writes_the_table_and_the_plot(tmp_path, capsys):
    assert main(["sweep", str(SCENARIO), "--grid", "solver.gain=[0.5, 2]", "--out", str(tmp_path), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].split()[:3] == ["point", "solver.gain", "max_position_error"]
    assert (tmp_path / "sweep.csv").is_file() and (tmp_path / "sweep.png").is_file()
    assert main(["sweep", str(SCENARIO), "--grid", "solver.gain=1:2"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("uvms: error: --grid") and len(err.splitlines()) == 1
    assert main(["sweep", str(SCENARIO), "--grid", "solver.gain=1:2:2", "--scheduler", "tcp://x:1"]) == 2
    assert "needs the dask backend" in capsys.readouterr().err


def test_a_huge_grid_is_refused_at_once(tmp_path, capsys):
    started = time.perf_counter()
    assert main(["sweep", str(SCENARIO), "--grid", "solver.gain=0:1:1000", "--grid", "solver.alpha=0:1:1000",
                 "--out", str(tmp_path / "sweep")]) == 2
    assert time.perf_counter() - started < 1.0
    err = capsys.readouterr().err
    assert err.splitlines() == [
        "uvms: error: the grid has 1,000,000 points (1,000 (solver.gain) x 1,000 (solver.alpha)); a sweep has at most "
        "10,000: split it into several sweeps (e.g. one per value of solver.gain) or take fewer values"]
    with pytest.raises(SweepError, match="N = 1,000,000,000 values; a sweep has at most 10,000 points"):
        parse_grid("solver.gain=0:1:1000000000")  # refused before any array is made
    assert time.perf_counter() - started < 1.0 and not list(tmp_path.iterdir())
    assert MAX_POINTS == 10_000


def test_a_sweep_folder_is_replaced_whole_and_reports_final_paths(tmp_path, monkeypatch):
    folder = tmp_path / "sweep"
    first = sweep(SCENARIO, ["solver.gain=[0.5, 1.0, 1.5]"], out=folder, progress=False)
    assert sorted(path.name for path in folder.iterdir()) == [".uvms-run.json", "point_0", "point_1", "point_2",
                                                              "sweep.csv", "sweep.png"]
    assert first.files == [folder / "sweep.csv", folder / "sweep.png"]

    def failing(scenario, out, **kwargs):  # jobs=1 runs the points in this process
        raise UVMSError(f"cannot write to {out!r}")

    monkeypatch.setattr("uvms.scenario.runs.run_scenario", failing)
    second = sweep(SCENARIO, ["solver.gain=[2.0, 3.0]"], out=folder, progress=False)
    assert sorted(path.name for path in folder.iterdir()) == [".uvms-run.json", "sweep.csv", "sweep.png"]  # no point
    assert [row["error"] for row in second.rows] == [f"UVMSError: cannot write to '{folder / f'point_{k}'}'"
                                                     for k in range(2)]  # the final paths, not the temporary ones
    assert str(folder / "point_0") in (folder / "sweep.csv").read_text()
    assert not list(tmp_path.glob(".sweep.uvms-tmp-*"))


# ------------------------------------------------------------------ the Dask backend is no open door
def listening_ports() -> set[int]:
    """The TCP ports this process and its children listen on."""
    psutil = pytest.importorskip("psutil")
    me = psutil.Process()
    ports = set()
    for process in [me, *me.children(recursive=True)]:
        try:
            ports |= {c.laddr.port for c in process.net_connections("tcp") if c.status == psutil.CONN_LISTEN}
        except psutil.Error:
            continue
    return ports


def test_the_local_dask_cluster_is_tls_only_and_opens_no_http_port():
    pytest.importorskip("dask.distributed")
    from distributed import Client
    from distributed.security import Security

    before = listening_ports()
    with dask_client(None, 2, SweepError) as client:
        address = client.cluster.scheduler_address
        assert address.startswith("tls://127.0.0.1:")
        assert client.submit(os.getpid).result(timeout=30) != os.getpid()  # the cluster works for its client
        info = client.scheduler_info()
        comms = {address, *info["workers"], *(w["nanny"] for w in info["workers"].values())}
        assert all(comm.startswith("tls://") for comm in comms)
        opened = listening_ports() - before
        assert opened == {int(comm.rsplit(":", 1)[1]) for comm in comms}  # no dashboard, no HTTP port at all
        started = time.monotonic()
        for credentials in ({}, {"security": Security.temporary()}):  # none, or another user's own
            with pytest.raises(Exception) as refused:
                stranger = Client(address, timeout="5s", **credentials)
                stranger.submit(os.getuid).result(timeout=5)
            # the refused Client is finalised here, not by a garbage collection inside the next Client's start,
            # where distributed's LoopRunner.stop deadlocks (Client.__del__ during Thread.__init__)
            del refused
            stranger = None
            gc.collect()
        host, port = address[len("tls://"):].rsplit(":", 1)
        context = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
        context.check_hostname, context.verify_mode = False, ssl.CERT_NONE  # trusts anything, has no certificate
        with socket.create_connection((host, int(port)), timeout=5) as raw:
            with pytest.raises((ssl.SSLError, ConnectionError, OSError)):
                with context.wrap_socket(raw) as tls:
                    tls.sendall(b"\x00" * 64)
                    if not tls.recv(1):  # refused after the handshake (TLS 1.3 checks the client's certificate)
                        raise ConnectionError("closed")
        assert time.monotonic() - started < 30


def test_a_tls_scheduler_without_credentials_says_where_they_come_from():
    pytest.importorskip("dask.distributed")
    with pytest.raises(SweepError, match="tls:// scheduler needs credentials .*DASK_DISTRIBUTED__COMM__TLS__CA_FILE"):
        with dask_client("tls://127.0.0.1:9", 1, SweepError):
            pass
