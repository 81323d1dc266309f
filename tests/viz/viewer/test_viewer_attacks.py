"""Attacks on the viewer (uvms.viz.viewer), `uvms view` and `uvms workspace`: meshes and run folders from strangers,
the browser viewer's Host and Origin, values a page sends, and out-of-range arguments (one line, exit 2, no hang)."""

from __future__ import annotations

import http.client
import io
import math
import resource
import threading
import time
import zipfile

import numpy as np
import pytest

import uvms
from uvms.cli import main
from uvms.errors import ViewerInputError, WorkspaceInputError
from uvms.model import meshes
from uvms.viz import viewer

from conftest import MISSING_MESH, shipped

PORT = 18480  # first port tried by the live tests (the next free one is taken when busy)

MESHED = MISSING_MESH.replace("package://no_such_pkg/hull.stl", "{mesh}")  # the same robot, a mesh of ours
DAE_HEAD = b'<?xml version="1.0"?>\n<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1"><!-- '


def zip_bomb(path, inflated: int) -> None:
    """A Collada zip (.zae layout: manifest + model.dae) whose model.dae inflates to ``inflated`` bytes."""
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED, compresslevel=1) as archive:
        with archive.open("model.dae", "w") as member:
            member.write(DAE_HEAD)
            chunk = b" " * (1 << 20)
            for _ in range(inflated >> 20):
                member.write(chunk)
            member.write(b"--></COLLADA>")
        archive.writestr("manifest.xml", "<dae_root>./model.dae</dae_root>")


def run_in_thread(target, timeout: float):
    """target() in a daemon thread; (finished, result or exception)."""
    box = {}

    def body():
        try:
            box["value"] = target()
        except BaseException as exc:  # noqa: BLE001 - reported to the test
            box["value"] = exc

    thread = threading.Thread(target=body, daemon=True)
    thread.start()
    thread.join(timeout)
    return not thread.is_alive(), box.get("value")


def wait_until(condition, timeout: float = 10.0) -> bool:
    """Poll ``condition()`` until it holds (True) or ``timeout`` [s] passes (its last value)."""
    deadline = time.monotonic() + timeout
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.02)
    return condition()


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("uvms: error: ") and "internal error" not in err, err
    return err


# ------------------------------------------------------------------ 10. meshes
def test_a_zae_zip_bomb_mesh_is_left_out_with_a_warning_before_it_is_inflated(tmp_path):
    bomb = tmp_path / "hull.zae"
    zip_bomb(bomb, 256 << 20)  # 1 MB on disk, 256 MiB inflated (the finding's was 4 GiB)
    assert bomb.stat().st_size < 2 << 20
    robot = uvms.load(MESHED.format(mesh=bomb), base="floating")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    started = time.perf_counter()
    with pytest.warns(UserWarning, match=r"hull\.zae.*not shown: format '\.zae' is not loaded; uvms loads "
                                         r"\.stl, \.dae, \.obj, \.ply"):
        visual, _ = viewer.geometry_models(robot)
    assert time.perf_counter() - started < 1.0
    assert (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) < 100 << 10  # [KiB]: nothing inflated
    assert [item.geometry.__class__.__name__ for item in visual.geometryObjects] == ["Box"]  # the rest is shown


@pytest.mark.parametrize(("name", "rule"), [
    ("hull.dae", "a compressed archive"),  # a zip under a mesh's name: assimp and pycollada open it as a .zae
    ("hull.STL", "65.0 MiB on disk; uvms loads meshes of at most 64 MiB"),
    ("hull.glb", "format '.glb' is not loaded"),
])
def test_archives_oversized_and_other_formats_are_refused_by_name_and_rule(tmp_path, name, rule):
    mesh = tmp_path / name
    if name.endswith(".dae"):
        zip_bomb(mesh, 1 << 20)
    elif name.endswith(".STL"):
        with open(mesh, "wb") as handle:  # sparse: 65 MiB on disk, no time to write
            handle.truncate(65 << 20)
    else:
        mesh.write_bytes(b"glTF")
    robot = uvms.load(MESHED.format(mesh=mesh), base="floating")
    with pytest.warns(UserWarning, match=f"{name}.*not shown: {rule}"):
        xml, missing = meshes.resolved_urdf(robot)
    assert name not in xml and not missing
    assert meshes.mesh_refusal(mesh) is not None


def test_a_plain_mesh_within_the_rules_is_still_shown(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    mesh = tmp_path / "hull.stl"
    trimesh.creation.box(extents=(0.4, 0.3, 0.2)).export(mesh)
    assert meshes.mesh_refusal(mesh) is None
    robot = uvms.load(MESHED.format(mesh=mesh), base="floating")
    visual, _ = viewer.geometry_models(robot)
    assert len(visual.geometryObjects) == 2 and visual.geometryObjects[0].meshPath == str(mesh.resolve())


def test_uvms_view_says_which_mesh_it_left_out_while_the_viewer_runs(tmp_path, capsys, monkeypatch):
    pytest.importorskip("viser")
    import uvms.cli

    (tmp_path / "hull.zae").write_bytes(b"PK\x03\x04")
    model = tmp_path / "meshed.urdf"
    model.write_text(MESHED.format(mesh="hull.zae"))
    said = []

    def interrupt():  # the viewer runs: what has been said on stderr by now
        said.append(capsys.readouterr())
        raise KeyboardInterrupt

    monkeypatch.setattr(uvms.cli.view, "wait_for_interrupt", interrupt)
    assert main(["view", str(model), "--base", "floating", "--port", str(PORT)]) == 0
    warning = [line for line in said[0].err.splitlines() if "hull.zae" in line]
    assert len(warning) == 1 and warning[0].startswith("uvms: warning: ")
    assert "format '.zae' is not loaded; uvms loads .stl, .dae, .obj, .ply" in warning[0]
    assert "viewer      http://127.0.0.1:" in said[0].out


# ------------------------------------------------------------------ 10. foreign run folders
def npy(shape, descr: str = "<f8", data: bytes = b"") -> bytes:
    """A .npy member: its header says ``shape`` and ``descr``, whatever ``data`` follows."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(buffer, {"descr": descr, "fortran_order": False, "shape": shape})
    return buffer.getvalue() + data


@pytest.mark.parametrize(("members", "words"), [
    ({"t.npy": npy((10**9,)), "q.npy": npy((10**9, 7))}, "1 <= N <= 1,000,000"),  # 56 GB claimed in 300 bytes
    ({"t.npy": npy((3,), data=bytes(24)), "q.npy": npy((3, 7), data=bytes(4 << 20))}, "the file is corrupt"),
    ({"t.npy": npy((3,), "|O"), "q.npy": npy((3, 7))}, "float64"),
    ({"t.npy": npy((3,)), "q.npy": npy((3, 7)), "payload.npy": npy((1,))}, "only the series"),
    ({"q.npy": npy((3, 7))}, "holds t.npy and q.npy"),
])
def test_a_foreign_trajectory_is_refused_from_its_headers_before_loading(tmp_path, capsys, monkeypatch, members,
                                                                          words):
    run = tmp_path / "run"
    run.mkdir()
    with zipfile.ZipFile(run / "trajectory.npz", "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in members.items():
            archive.writestr(name, data)

    def no_load(*args, **kwargs):
        raise AssertionError("np.load called on a trajectory.npz that its headers refuse")

    monkeypatch.setattr(np, "load", no_load)
    started = time.perf_counter()
    assert main(["view", "hoang2011", "--result", str(run), "--headless", str(tmp_path / "x.png")]) == 2
    assert time.perf_counter() - started < 10.0
    assert words in one_error_line(capsys)
    with pytest.raises(ViewerInputError, match="trajectory.npz"):
        uvms.cli.read_result(shipped("hoang2011"), str(run))


# ------------------------------------------------------------------ 11. Host, Origin and page values
def http_get(port: int, host: str) -> int:
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=10)
    try:
        connection.putrequest("GET", "/", skip_host=True)
        connection.putheader("Host", host)
        connection.endheaders()
        return connection.getresponse().status
    finally:
        connection.close()


def page(port: int, origin: str | None):
    """A WebSocket to the viewer as a page opens it (viser's subprotocol), with the Origin header given."""
    import viser
    from websockets.sync.client import connect

    return connect(f"ws://127.0.0.1:{port}", subprotocols=[f"viser-v{viser.__version__}"], open_timeout=10,
                   **({"origin": origin} if origin else {}))


def message(kind: str, **fields) -> bytes:
    """A message of a page to viser (msgpack, as its client sends it)."""
    import msgspec

    return msgspec.msgpack.encode({"type": kind, **fields})


#: The page's first camera: viser counts a page as a client (whose panel changes it applies) from then on.
CAMERA = message("ViewerCameraMessage", wxyz=(1.0, 0.0, 0.0, 0.0), position=(3.0, 0.0, 1.0), fov=1.3, near=0.01,
                 far=100.0, image_height=600, image_width=900, look_at=(0.0, 0.0, 0.0), up_direction=(0.0, 0.0, 1.0))


def test_only_pages_of_the_viewer_itself_may_connect():
    pytest.importorskip("viser")
    from websockets.exceptions import InvalidStatus

    with viewer.Viewer(shipped("hoang2011"), port=PORT) as shown:
        port = shown.server.get_port()
        for origin in ("http://evil.example", f"http://evil.example:{port}", f"http://127.0.0.1:{port + 1}", "null",
                       f"https://127.0.0.1:{port}"):
            with pytest.raises(InvalidStatus) as refused:
                page(port, origin)
            assert refused.value.response.status_code == 403
        assert not shown.server.get_clients()
        for origin in (f"http://127.0.0.1:{port}", f"http://localhost:{port}"):
            with page(port, origin) as socket:
                assert isinstance(socket.recv(timeout=10), bytes)  # the scene is streamed
        assert http_get(port, "evil.example") == 403
        assert http_get(port, f"evil.example:{port}") == 403
        assert http_get(port, f"127.0.0.1:{port}") == 200
        assert http_get(port, f"localhost:{port}") == 200


def test_values_a_page_sends_are_clamped_to_the_sliders_and_finite():
    pytest.importorskip("viser")
    robot = shipped("hoang2011")  # planar: q = (x, y, cos yaw, sin yaw, q1, q2, q3)
    lower, upper = robot.arm_limits
    with viewer.Viewer(robot, port=PORT) as shown:
        port, sliders = shown.server.get_port(), shown.teach.sliders
        x_max = shown.teach.ranges["base_x"][1]
        with page(port, f"http://127.0.0.1:{port}") as socket:
            socket.send(CAMERA)
            assert wait_until(lambda: len(shown.server.get_clients()) == 1)

            def send(name: str, value: float) -> None:
                socket.send(message("GuiUpdateMessage", uuid=sliders[name]._impl.uuid, updates={"value": value}))

            send("base_x", 1e308)
            assert wait_until(lambda: shown.q[0] != 0.0)
            assert shown.q[0] == x_max and x_max < 100  # the slider's end, not 1e308
            send("q2", -1e308)
            assert wait_until(lambda: shown.q[5] == lower[1])  # q2 at its lower limit
            send("base_y", math.nan)
            assert wait_until(lambda: sliders["base_y"].value == 0.0)  # NaN: the value shown stays
        assert np.all(np.isfinite(shown.q)) and shown.q[1] == 0.0
        sliders["q1"].value = math.nan  # the same from Python
        sliders["q3"].value = 1e308
        assert np.all(np.isfinite(shown.q)) and shown.q[6] == pytest.approx(upper[2])


def test_a_page_time_or_speed_that_is_not_a_number_does_not_reach_the_playback():
    pytest.importorskip("viser")
    robot = shipped("hoang2011")
    t = np.linspace(0.0, 1.0, 5)
    qs = np.array([robot.configuration(base=[0.1 * k, 0.0, 0.0], arm=[0.2 * k, 0.0, 0.0]) for k in range(5)])
    with viewer.Viewer(robot, port=PORT) as shown:
        shown.load(t, qs)
        shown.playback.time_slider.value = math.inf
        np.testing.assert_array_equal(shown.q, qs[0])
        shown.playback.speed_input.value = math.nan
        shown.playback.run(fps=50.0, progress=False)  # plays at speed 1 to the end
        np.testing.assert_array_equal(shown.q, qs[-1])


# ------------------------------------------------------------------ 15. arguments out of range: one line, exit 2
@pytest.mark.parametrize(("argv", "words"), [
    (["view", "hoang2011", "--port", "-1"], "port must be an integer in 1..65535"),
    (["view", "hoang2011", "--port", "65536"], "port must be an integer in 1..65535"),
    (["workspace", "hoang2011", "-n", "100", "--seed", "-1"], "seed must be an integer >= 0"),
    (["workspace", "hoang2011", "-n", "100", "--dexterity", "--directions", str(10**9)], "[1, 1,000,000]"),
    (["workspace", "hoang2011", "-n", "100", "--dexterity", "--roll-bins", str(10**12)], "[1, 36,000]"),
])
def test_out_of_range_arguments_are_one_line_and_return_promptly(argv, words, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    finished, status = run_in_thread(lambda: main(argv), timeout=60)
    assert finished, f"uvms {' '.join(argv)} still running after 60 s"
    assert status == 2
    assert words in one_error_line(capsys)
    assert not (tmp_path / "out").exists()


def test_the_library_functions_refuse_the_same_arguments():
    with pytest.raises(WorkspaceInputError, match="seed"):
        uvms.workspace.monte_carlo(shipped("hoang2011"), shipped("hoang2011").ee_frames, 10, seed=-1)
    with pytest.raises(WorkspaceInputError, match="directions"):
        uvms.workspace.OrientationGrid(10**9)
    for port in (-1, 65536, 80.0, True):
        with pytest.raises(ViewerInputError, match="1..65535"):
            viewer.check_port(port)
    pytest.importorskip("viser")
    finished, outcome = run_in_thread(lambda: viewer.Viewer(shipped("hoang2011"), port=-1), timeout=30)
    assert finished and isinstance(outcome, ViewerInputError)
