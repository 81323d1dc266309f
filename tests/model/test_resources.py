"""Reading model files within bounds (uvms.model.resources, uvms.model.includes): every file from a stranger is read
by one capped reader, before any sandbox.

A xacro's includes are walked once each (never 2**40 times, never a FIFO), YAML aliases are counted, sizes are
checked before a byte is read, and what the parsers cannot take (deep nesting, huge integers, symbolic link
loops) is a one-line UVMSError. A check that blocks or exhausts the memory on unfixed code runs in a child process
with a timeout and an address-space limit, so that the test fails instead of hanging.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

import uvms
import uvms.scenario.watch
from uvms.cli import main
from uvms.errors import ScenarioError
from uvms.model import includes, resources
from uvms.scenario import read_scenario
from uvms.scenario.build import build
from uvms.scenario.watch import WatchedFiles

from conftest import FLOATING_ROOT, ROOT, urdf

XACRO = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


def in_child(code: str, seconds: float = 60.0, stdin: int | None = None) -> dict:
    """Run ``code`` (which prints one JSON line last) in a child with a timeout and 3 GiB of address space."""

    def limit_memory() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))

    try:
        done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                              timeout=seconds, stdin=stdin, preexec_fn=limit_memory, cwd=ROOT / "tests")
    except subprocess.TimeoutExpired:
        pytest.fail(f"blocked: no answer within {seconds:g} s")
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def one_line(capsys, argv: list[str]) -> str:
    """The stderr of a CLI call that must fail with exit status 2 and one line, no internal error."""
    status = main(argv)
    err = capsys.readouterr().err.strip()
    assert status == 2, err
    assert len(err.splitlines()) == 1 and "internal error" not in err, err
    return err


# ------------------------------------------------------------------ 8: the xacro include walk
def doubling_chain(folder: Path, levels: int = 40) -> Path:
    """``levels`` tiny xacro files, each including the next twice (2**levels inclusions for xacro)."""
    for level in range(levels):
        include = f'<xacro:include filename="f{level + 1}.xacro"/>' * 2 if level + 1 < levels else ""
        (folder / f"f{level}.xacro").write_text(
            f'<robot name="r" {XACRO}>{include}<xacro:arg name="a{level}" default="1"/><link name="l{level}"/></robot>')
    return folder / "f0.xacro"


def test_a_doubling_include_chain_is_read_once_per_file_and_refused_at_once(tmp_path):
    top = doubling_chain(tmp_path)
    answer = in_child(f"""
        import json, time, uvms
        from uvms.scenario.watch import WatchedFiles
        started = time.perf_counter()
        try:
            uvms.load({str(top)!r}, trusted=False)
            error = None
        except uvms.UVMSError as exc:
            error = [type(exc).__name__, str(exc)]
        loading = time.perf_counter() - started
        started = time.perf_counter()
        files = WatchedFiles.of(model={str(top)!r}).files
        print(json.dumps({{"error": error, "loading": loading, "watching": time.perf_counter() - started,
                          "files": len(files)}}))
    """)
    assert answer["loading"] < 1.0 and answer["watching"] < 1.0, answer  # 14 levels took 2.5 s, 18 took 30 s
    name, message = answer["error"]
    assert name == "XacroError" and "more than 10000 inclusions" in message and "f0.xacro" in message
    assert answer["files"] == 40  # the watcher still watches every file of the chain


def test_a_file_included_twice_is_read_once_and_its_args_are_known(tmp_path):
    (tmp_path / "macros.xacro").write_text(f'<robot {XACRO}><xacro:arg name="m" default="2"/></robot>')
    for side in ("left", "right"):
        (tmp_path / f"{side}.xacro").write_text(f'<robot {XACRO}><xacro:include filename="macros.xacro"/>'
                                                f'<xacro:arg name="{side}" default="1"/></robot>')
    main_file = tmp_path / "rov.urdf.xacro"
    main_file.write_text(f'<robot name="r" {XACRO}><xacro:include filename="left.xacro"/>'
                         f'<xacro:include filename="right.xacro"/><xacro:arg name="m" default="3"/></robot>')
    walk = includes.walk_xacro(main_file)
    assert walk.problem is None and walk.args == {"m": "3", "left": "1", "right": "1"}
    assert [path.name for path in walk.files] == ["rov.urdf.xacro", "left.xacro", "macros.xacro", "right.xacro"]


def test_an_include_of_a_fifo_or_of_stdin_is_refused_without_blocking(tmp_path):
    os.mkfifo(tmp_path / "pipe.xacro")
    models = []
    for name, target in (("fifo", "pipe.xacro"), ("stdin", "/dev/stdin")):
        model = tmp_path / f"{name}.urdf.xacro"
        model.write_text(f'<robot name="r" {XACRO}><xacro:include filename="{target}"/><link name="a"/></robot>')
        models.append(str(model))
    reading, writing = os.pipe()  # the child's stdin: open, and nothing ever written to it
    try:
        answer = in_child(f"""
            import contextlib, io, json, time, uvms
            from uvms.cli import main
            from uvms.scenario.watch import WatchedFiles
            found = {{}}
            for model in {models!r}:
                started = time.perf_counter()
                errors = []
                for trusted in (True, False):
                    try:
                        uvms.load(model, trusted=trusted)
                    except uvms.UVMSError as exc:
                        errors.append(str(exc))
                files = [str(path) for path in WatchedFiles.of(model=model).files]
                err = io.StringIO()
                with contextlib.redirect_stderr(err):
                    status = main(["info", model])
                found[model] = {{"errors": errors, "files": files, "status": status, "err": err.getvalue(),
                                "seconds": time.perf_counter() - started}}
            print(json.dumps(found))
        """, stdin=reading)
    finally:
        os.close(reading)
        os.close(writing)
    for model, target in zip(models, (str(tmp_path / "pipe.xacro"), "/dev/stdin")):
        result = answer[model]
        assert result["seconds"] < 5, result
        assert len(result["errors"]) == 2, result  # trusted (xacro in this process) and sandboxed alike
        assert all(message.startswith(target) and "is a FIFO, not a regular file" in message
                   for message in result["errors"]), result
        assert result["files"] == [model]  # the model itself is watched, the FIFO is not
        assert result["status"] == 2 and result["err"].count("\n") == 1 and "FIFO" in result["err"]


def test_an_include_of_a_symbolic_link_loop_is_one_line(tmp_path, capsys):
    (tmp_path / "a.xacro").symlink_to(tmp_path / "b.xacro")
    (tmp_path / "b.xacro").symlink_to(tmp_path / "a.xacro")
    model = tmp_path / "rov.urdf.xacro"
    model.write_text(f'<robot name="r" {XACRO}><xacro:include filename="a.xacro"/><link name="a"/></robot>')
    for trusted in (True, False):
        with pytest.raises(uvms.errors.XacroError,
                           match="a.xacro: cannot read the xacro include file .*symbolic links"):
            uvms.load(model, trusted=trusted)  # was RuntimeError: Symlink loop from Path.resolve
    assert "Too many levels of symbolic links" in one_line(capsys, ["info", str(model)])
    assert WatchedFiles.of(model=model).files == {model}


# ------------------------------------------------------------------ 9: YAML aliases
def alias_bomb() -> str:
    """Nine nested anchors of nine items: 9**9 values in a few hundred bytes."""
    rows = ["&a [0, 0, 0, 0, 0, 0, 0, 0, 0]"] + [f"&{name} [{', '.join([f'*{previous}'] * 9)}]"
                                                   for previous, name in zip("abcdefgh", "bcdefghi")]
    return ("links:\n  base_link:\n    volume: 0.01\n    hydrodynamic_model:\n      type: fossen\n"
            f"      added_mass: [{', '.join(rows)}]\n")


def test_a_yaml_alias_bomb_beside_a_model_is_refused_at_once_naming_the_file(tmp_path):
    (tmp_path / "rov.urdf").write_text(urdf(root=FLOATING_ROOT))
    (tmp_path / "hydrodynamics.yaml").write_text(alias_bomb())
    (tmp_path / "thrusters.yaml").write_text(alias_bomb().replace("links:", "thrusters:"))
    assert len(alias_bomb()) < 800
    answer = in_child(f"""
        import json, time, uvms
        robot = uvms.load({str(tmp_path / "rov.urdf")!r})
        found = []
        for read in (uvms.dynamics.hydrodynamics_of, uvms.dynamics.thrusters_of):
            started = time.perf_counter()
            try:
                read(robot)
                found.append(None)
            except uvms.UVMSError as exc:
                found.append([type(exc).__name__, str(exc), time.perf_counter() - started])
        print(json.dumps(found))
    """, seconds=30)  # unfixed: 87 s, then MemoryError
    for (name, message, seconds), file in zip(answer, ("hydrodynamics.yaml", "thrusters.yaml")):
        assert name == "ModelParseError" and seconds < 1.0
        assert message.startswith(str(tmp_path / file)) and "more than 100000 values" in message
        assert "\n" not in message


def test_recursive_and_deeply_nested_yaml_are_one_line(tmp_path):
    recursive = tmp_path / "recursive.yaml"
    recursive.write_text("links: &a {base_link: *a}\n")
    with pytest.raises(uvms.errors.ModelParseError, match="recursive.yaml: a YAML alias is used inside its own anchor"):
        resources.read_yaml(recursive, "hydrodynamics")
    deep = tmp_path / "deep.yaml"
    deep.write_text("links: " + "[" * 100_000 + "]" * 100_000)
    with pytest.raises(uvms.errors.ModelParseError, match="deep.yaml: the YAML is nested too deeply"):
        resources.read_yaml(deep, "hydrodynamics")  # was RecursionError
    plain = tmp_path / "plain.yaml"
    plain.write_text("defaults: &d {volume: 0.01}\nlinks: {base_link: *d, l1: *d}\n")  # a real use of aliases
    assert resources.read_yaml(plain, "hydrodynamics")["links"]["l1"] == {"volume": 0.01}


# ------------------------------------------------------------------ 12: sizes before reading
def test_a_sparse_30_gib_urdf_or_scenario_is_refused_by_its_size(tmp_path):
    for name in ("big.urdf", "big.toml"):
        with open(tmp_path / name, "wb") as handle:
            handle.truncate(30 << 30)
    answer = in_child(f"""
        import contextlib, io, json, time, uvms
        from uvms.cli import main
        from uvms.scenario import read_scenario
        found = {{}}
        for name, read, argv in (
                ("urdf", uvms.load, ["info", {str(tmp_path / "big.urdf")!r}]),
                ("toml", read_scenario, ["run", {str(tmp_path / "big.toml")!r}, "--out", {str(tmp_path / "out")!r}])):
            started = time.perf_counter()
            try:
                read(argv[1])
                error = None
            except uvms.UVMSError as exc:
                error = [type(exc).__name__, str(exc)]
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                status = main(argv)
            found[name] = {{"error": error, "status": status, "err": err.getvalue(),
                           "seconds": time.perf_counter() - started}}
        print(json.dumps(found))
    """)  # unfixed: MemoryError (the whole file is read)
    for name, kind, cap in (("urdf", "ModelFileNotFound", "32 MiB"), ("toml", "ScenarioError", "4 MiB")):
        result = answer[name]
        assert result["seconds"] < 1.0, result
        assert result["error"][0] == kind and f"holds 30,720.0 MiB; at most {cap}" in result["error"][1]
        assert result["status"] == 2 and result["err"].count("\n") == 1 and "at most" in result["err"]


# ------------------------------------------------------------------ 15: what the parsers cannot take
def scenario_text(**replaced: str) -> str:
    text = (ROOT / "scenarios" / "hoang2011_w1.toml").read_text()
    text = text.replace('path = "../models/hoang2011/uvms.urdf.xacro"', 'path = "hoang2011"')
    for old, new in replaced.items():
        assert old in text
        text = text.replace(old, new)
    return text


def test_deep_toml_and_a_huge_integer_are_one_line(tmp_path, capsys):
    deep = tmp_path / "deep.toml"
    deep.write_text(scenario_text() + "x = " + "[" * 100_000 + "]" * 100_000 + "\n")
    huge = tmp_path / "huge.toml"
    huge.write_text(scenario_text(**{"dt = 0.02": "dt = " + "1" * 5000}))
    cases = [(deep, "nested too deeply"), (huge, "a number has too many digits")]
    for path, words in cases:
        with pytest.raises(ScenarioError, match=f"{path.name}: invalid TOML: .*{words}"):
            read_scenario(path)  # was RecursionError, ValueError
        assert words in one_line(capsys, ["run", str(path), "--out", str(tmp_path / "out")])
    with pytest.raises(ScenarioError, match="--set value .*a number has too many digits"):
        read_scenario("hoang2011_w1", ["simulation.dt=" + "1" * 5000])
    err = one_line(capsys,
                   ["run", "hoang2011_w1", "--out", str(tmp_path / "out"), "--set", "simulation.dt=" + "1" * 5000])
    assert "a number has too many digits" in err and len(err) < 400


# ------------------------------------------------------------------ 16: package://, --watch, laps and speed
def test_a_package_uri_stays_inside_its_package(tmp_path):
    package = tmp_path / "share" / "mypkg"
    (package / "meshes").mkdir(parents=True)
    (package / "meshes" / "hull.stl").write_text("solid hull\nendsolid hull\n")
    (package / "package.xml").write_text("<package><name>mypkg</name></package>")
    (tmp_path / "secret.stl").write_text("not a mesh of this package\n")
    roots = uvms.model.package_index([tmp_path / "share"])
    assert resources.resolve_uri("package://mypkg/meshes/hull.stl", None, roots) == package / "meshes" / "hull.stl"
    assert resources.resolve_uri("package://mypkg/meshes/../meshes/hull.stl", None, roots) is not None
    for escape in ("package://mypkg/../../secret.stl", "package://mypkg/meshes/../../../secret.stl",
                   "package://../secret.stl", f"package://mypkg/{tmp_path / 'secret.stl'}",
                   "package://mypkg/" + "../" * 40 + str(tmp_path / "secret.stl").lstrip("/")):
        assert resources.resolve_uri(escape, None, roots) is None, escape
    hostname = "package://example-robot-data/" + "../" * 40 + "etc/hostname"  # the red team's URI
    assert resources.resolve_uri(hostname, None, uvms.model.package_index()) is None
    mesh = '<visual><geometry><mesh filename="package://mypkg/../../secret.stl"/></geometry></visual>'
    with pytest.warns(uvms.errors.MissingMeshWarning, match="1 mesh file"):
        uvms.load(urdf(extra=f'<link name="l2">{mesh}</link><joint name="j2" type="fixed"><parent link="l1"/>'
                               '<child link="l2"/></joint>'), package_path=[tmp_path / "share"])


def test_watch_watches_the_files_a_model_uses_never_a_tree(tmp_path, monkeypatch):
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "part.xacro").write_text(f'<robot {XACRO}><link name="p"/></robot>')
    (tmp_path / "model" / "meshes").mkdir(parents=True)
    model = tmp_path / "model" / "rov.urdf.xacro"
    model.write_text(f'<robot name="r" {XACRO}><xacro:include filename="../lib/part.xacro"/>'
                     f'<xacro:include filename="{"../" * 40}"/><link name="a"/></robot>')  # the second climbs to /
    watched = WatchedFiles.of(model=model)
    assert watched.files == {model, tmp_path / "lib" / "part.xacro"}
    assert watched.roots() == [tmp_path / "lib", tmp_path / "model", tmp_path / "model" / "meshes"]
    assert watched.wants(tmp_path / "model" / "meshes" / "hull.stl") and watched.wants(tmp_path / "lib" / "part.xacro")
    assert not watched.wants(tmp_path / "lib" / "other.xacro")  # an include's folder is not the model's data
    calls = []

    def fake_watch(*paths, **options):
        calls.append((paths, options))
        yield {(1, str(model))}

    monkeypatch.setattr("watchfiles.watch", fake_watch)
    seen: list = []
    uvms.scenario.watch.watch(model, seen.append, once=True)
    assert seen == [[model]] and calls[0][1]["recursive"] is False and Path("/") not in calls[0][0]


def test_laps_and_speed_together_are_refused(tmp_path, capsys):
    # refused where the file is read (the trajectory's settings check themselves), nothing built
    with pytest.raises(ScenarioError, match="trajectory.speed and laps are both set.*keep laps"):
        read_scenario("santos2006_task_priority", ["trajectory.speed=0.5"])
    with pytest.raises(ScenarioError, match="trajectory.speed is the cruise speed of the trapezoid law"):
        read_scenario("hoang2011_w1", ["trajectory.law=quintic"])
    err = one_line(capsys, ["run", "santos2006_task_priority", "--set", "trajectory.speed=0.5", "--out",
                            str(tmp_path / "out"), "--quiet"])
    assert "not both" in err
    assert build(read_scenario("santos2006_task_priority")).trajectory is not None  # laps alone: as shipped


def test_the_caps_hold_every_shipped_model_and_scenario():
    started = time.perf_counter()
    for name, path in resources.shipped_models().items():
        walk = includes.walk_xacro(path)
        assert walk.problem is None and walk.args, name
    for path in sorted((ROOT / "scenarios").glob("*.toml")):
        assert path.stat().st_size < resources.MAX_TOML_BYTES and read_scenario(path)
    for path in [*ROOT.glob("models/**/*.yaml")]:
        assert resources.read_yaml(path, "data")
    assert time.perf_counter() - started < 10


def test_a_foreign_run_record_is_read_within_caps(tmp_path):
    """A run folder's metrics.json from someone else: too deep or too large is one RunRecordError, never a crash."""
    from uvms.errors import RunRecordError
    from uvms.scenario.record import read_run_record
    from uvms.scenario.watch import read_metrics

    deep = tmp_path / "deep"
    deep.mkdir()
    (deep / "metrics.json").write_text("[" * 200_000 + "]" * 200_000)
    with pytest.raises(RunRecordError, match="nested too deeply"):
        read_run_record(deep)
    assert read_metrics(deep) == {}
    huge = tmp_path / "huge"
    huge.mkdir()
    with open(huge / "metrics.json", "wb") as handle:
        handle.truncate(30 << 30)  # sparse: 30 GiB claimed, nothing on disk
    with pytest.raises(RunRecordError, match="MiB"):
        read_run_record(huge)
    assert read_metrics(huge) == {}
