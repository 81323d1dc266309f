"""Mesh files from strangers (uvms.model.meshes.mesh_refusal): a mesh that is a FIFO or a device, and a file a mesh
names for its loader to open next (materials, textures) that is one, are refused before any loader opens them.

assimp (coal, Pinocchio) opens an OBJ's ``mtllib`` (and ``<stem>.mtl`` when that is missing), trimesh (the viewer)
the materials' ``map_Kd``, a PLY's ``TextureFile`` and a Collada image; a FIFO there blocks the loader inside C
code, where neither Ctrl-C nor SIGTERM stops it. The end-to-end tests run ``uvms`` in a child process with a
timeout, so the old hang fails the test instead of hanging the suite.
"""

from __future__ import annotations

import os
import resource
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from uvms.model.meshes import MAX_NAMED_FILES, mesh_refusal

from conftest import FLOATING_ROOT, ROOT, deadline, uvms_command

FIXTURES = Path(__file__).parents[1] / "fixtures" / "collision"
#: A tetrahedron (unit legs along x, y, z), then {tail}.
TETRAHEDRON = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"
PLY = ("ply\nformat ascii 1.0\ncomment TextureFile {texture}\nelement vertex 3\nproperty float x\nproperty float y\n"
       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
       "3 0 1 2\n")
DAE = ('<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">'
       '<library_images><image id="t"><init_from>{texture}</init_from></image></library_images></COLLADA>')


def obj(folder: Path, head: str, name: str = "rock.obj") -> Path:
    path = folder / name
    path.write_text(head + TETRAHEDRON)
    return path


@pytest.mark.parametrize("make", ["fifo", "null"])
def test_a_mesh_that_is_a_fifo_or_a_device_is_refused_before_it_is_opened(tmp_path, make):
    mesh = tmp_path / "hull.stl"
    if make == "fifo":
        os.mkfifo(mesh)  # no writer ever comes: an open for reading would wait for ever
    else:
        mesh.symlink_to("/dev/null")
    with deadline(2.0):
        reason = mesh_refusal(mesh)
    assert reason == f"the mesh file is {'a FIFO' if make == 'fifo' else 'a device or socket'}, not a regular file; " \
                     "give a file"


def test_a_mesh_that_is_dev_zero_is_refused_in_bounded_memory(tmp_path):
    """In a child limited to 2 GiB of address space: reading /dev/zero as a zip (zipfile.is_zipfile) never ends."""
    mesh = tmp_path / "hull.stl"
    mesh.symlink_to("/dev/zero")
    code = ("from pathlib import Path; from uvms.model.meshes import mesh_refusal; "
            f"print(mesh_refusal(Path({str(mesh)!r})))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False,
                          cwd=ROOT,
                          preexec_fn=lambda: resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30)))
    assert done.stdout == "the mesh file is a device or socket, not a regular file; give a file\n", done.stderr


@pytest.mark.parametrize("case", ["mtllib", "fallback", "absolute", "comment", "texture", "ply", "dae", "dae uri"])
def test_a_mesh_naming_a_fifo_for_its_loader_is_refused(tmp_path, case):
    fifo = tmp_path / ("rock.mtl" if case == "fallback" else "trap.png" if case in ("texture", "ply", "dae", "dae uri")
                       else "trap.mtl")
    os.mkfifo(fifo)
    if case == "mtllib":
        mesh = obj(tmp_path, "mtllib trap.mtl\n")
    elif case == "fallback":  # assimp opens <stem>.mtl when the named material file is missing
        mesh = obj(tmp_path, "mtllib missing.mtl\n")
    elif case == "absolute":
        mesh = obj(tmp_path, f"mtllib {fifo}\n")
    elif case == "comment":  # trimesh takes the first "mtllib" anywhere, a comment's too
        mesh = obj(tmp_path, "# exported without a mtllib trap.mtl\n")
    elif case == "texture":  # a regular material file whose texture map is the FIFO (trimesh opens it)
        (tmp_path / "rock.mtl").write_text("newmtl stone\nKd 0.5 0.5 0.5\nmap_Kd -s 1 1 1 trap.png\n")
        mesh = obj(tmp_path, "mtllib rock.mtl\nusemtl stone\n")
    elif case == "ply":
        mesh = tmp_path / "rock.ply"
        mesh.write_text(PLY.format(texture="trap.png"))
    else:
        mesh = tmp_path / "rock.dae"
        mesh.write_text(DAE.format(texture="trap.png" if case == "dae" else f"file://{tmp_path}/trap%2Epng"))
    with deadline(2.0):
        reason = mesh_refusal(mesh)
    assert reason == f"it names {str(fifo)!r}, a FIFO, for its loader to open next"


def test_a_mesh_naming_a_huge_material_or_too_many_files_is_refused(tmp_path):
    with open(tmp_path / "big.mtl", "wb") as handle:
        handle.truncate(65 << 20)  # sparse: 65 MiB on disk
    assert "(65.0 MiB) for its loader to open next; at most 64 MiB" in mesh_refusal(obj(tmp_path, "mtllib big.mtl\n"))
    many = "".join(f"mtllib m{index}.mtl\n" for index in range(MAX_NAMED_FILES + 1))
    assert mesh_refusal(obj(tmp_path, many, "many.obj")) == (f"it names more than {MAX_NAMED_FILES} files "
                                                             "(materials, textures) for its loader to open")


def test_a_textured_mesh_of_regular_files_still_loads(tmp_path):
    coal = pytest.importorskip("coal")
    (tmp_path / "stone.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    (tmp_path / "rock.mtl").write_text("newmtl stone\nKd 0.5 0.5 0.5\nmap_Kd stone.png\n")
    mesh = obj(tmp_path, "mtllib rock.mtl\nusemtl stone\n")
    (tmp_path / "textures").mkdir()  # a folder named like a texture is skipped: a loader's open fails at once
    (tmp_path / "hull.dae").write_text(DAE.format(texture="textures"))
    assert mesh_refusal(mesh) is None and mesh_refusal(tmp_path / "hull.dae") is None
    assert mesh_refusal(FIXTURES / "rock.stl") is None
    assert coal.MeshLoader().load(str(mesh)).num_vertices == 4


def run_uvms(*args: str) -> subprocess.CompletedProcess:
    """``uvms ARGS`` in a child process (this checkout's uvms); a hang fails the test after 60 s (the child is
    killed)."""
    try:
        return subprocess.run(uvms_command(*args), capture_output=True, text=True, timeout=60, cwd=ROOT, check=False)
    except subprocess.TimeoutExpired:
        pytest.fail(f"uvms {' '.join(args)} still running after 60 s")


def test_uvms_run_refuses_an_obstacle_mesh_whose_material_is_a_fifo(tmp_path):
    shutil.copy(FIXTURES / "box_arm.urdf", tmp_path)
    os.mkfifo(tmp_path / "rock.mtl")
    obj(tmp_path, "mtllib rock.mtl\n")
    scenario = tmp_path / "fold.toml"
    scenario.write_text((FIXTURES / "box_arm_fold.toml").read_text().replace('mesh = "rock.stl"', 'mesh = "rock.obj"'))
    done = run_uvms("run", str(scenario), "--out", str(tmp_path / "out"), "--quiet")
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert f"rock.obj' is refused: it names {str(tmp_path / 'rock.mtl')!r}, a FIFO" in done.stderr
    assert not (tmp_path / "out").exists()


def test_uvms_view_headless_leaves_out_a_visual_mesh_whose_material_is_a_fifo(tmp_path):
    os.mkfifo(tmp_path / "hull.mtl")
    obj(tmp_path, "mtllib hull.mtl\n", "hull.obj")
    inertial = '<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
    model = tmp_path / "rov.urdf"
    model.write_text(f'<robot name="rov">{FLOATING_ROOT}<link name="base_link">{inertial}<visual><geometry>'
                     '<mesh filename="hull.obj"/></geometry></visual></link></robot>')
    done = run_uvms("view", str(model), "--headless", str(tmp_path / "rov.png"))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "rov.png").stat().st_size > 1000


def test_a_missing_meshs_warning_says_why_per_cause(tmp_path):
    """The Girona 500 case: UWSim's .osg scenes are a format uvms does not read, said as such even when their
    package is named (before: 'Name the folder of their package', which is not the cause); a package not found says
    where it was looked for; a package found says where, and that it lacks the file; a relative path says from where."""
    import warnings

    import uvms
    from uvms.errors import MissingMeshWarning

    for name in ("uwsim", "known_pkg"):
        (tmp_path / "share" / name / "meshes").mkdir(parents=True)
        (tmp_path / "share" / name / "package.xml").write_text(f"<package><name>{name}</name></package>")
    meshes = ["package://uwsim/data/objects/g500.osg", "package://uwsim/data/objects/arm5e.osg",
              "package://known_pkg/meshes/none.stl", "package://unknown_pkg/meshes/hull.stl", "meshes/missing.dae"]
    visuals = "".join(f'<visual><geometry><mesh filename="{uri}"/></geometry></visual>' for uri in meshes)
    model = tmp_path / "girona.urdf"
    model.write_text(f'<robot name="girona_like">{FLOATING_ROOT}<link name="base_link"><inertial><mass value="140"/>'
                     f'<inertia ixx="10" iyy="20" izz="20" ixy="0" ixz="0" iyz="0"/></inertial>{visuals}</link>'
                     f'</robot>')
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        uvms.load(model, package_path=[tmp_path / "share"])
    [message] = [str(warning.message) for warning in caught if issubclass(warning.category, MissingMeshWarning)]
    assert message.startswith(f"{model}: 5 mesh file(s) not found, not shown (kinematics is unaffected): ")
    assert ("2 (e.g. 'package://uwsim/data/objects/arm5e.osg'): '.osg' files are OpenSceneGraph (UWSim) scenes, not "
            "meshes: uvms reads .stl, .dae, .obj, .ply meshes; convert them (e.g. to .stl or .dae) to show them"
            in message)
    assert (f"1 ('package://known_pkg/meshes/none.stl'): package 'known_pkg' "
            f"(searched at {tmp_path / 'share'}") in message
    assert "1 ('package://unknown_pkg/meshes/hull.stl'): no ROS package 'unknown_pkg' (looked in: " in message
    assert f"1 ('meshes/missing.dae'): no such file (relative paths from {tmp_path})" in message
    assert "Name the folder" not in message
