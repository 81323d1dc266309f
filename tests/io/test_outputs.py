"""Writing outputs (uvms.io.outputs), no lost results: atomic writes, usual permissions, and a killed `uvms run`
never leaves a truncated file."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from uvms import UVMSError
from uvms.io import outputs

from conftest import SCENARIOS

SCENARIO = SCENARIOS / "santos2006_task_priority.toml"


def test_an_npz_is_numpys_deflated_archive_of_the_arrays_bit_for_bit(tmp_path, rng):
    """``write_npz``: ``np.load`` gives every array back bit for bit (dtype, shape, order), each member deflated (at
    :data:`outputs.NPZ_LEVEL`, smaller than the stored arrays); an array of objects is refused, never pickled."""
    import zipfile

    arrays = {"t": np.linspace(0.0, 1.0, 501), "q": rng.normal(size=(501, 7)), "flags": np.arange(501) % 3 == 0,
              "counts": np.arange(12, dtype=np.int64).reshape(3, 4), "empty": np.zeros((0, 6)),
              "columns": np.asfortranarray(rng.normal(size=(40, 3))), "names": np.array(["x", "yaw"])}
    arrays["q"][::7, 2] = 0.25  # a series with repeats, as a run's are
    path = tmp_path / "run.npz"
    outputs.write_npz(path, **arrays)
    with np.load(path) as loaded:
        assert loaded.files == list(arrays)
        for name, value in arrays.items():
            assert loaded[name].dtype == value.dtype and loaded[name].shape == value.shape
            assert loaded[name].tobytes() == value.tobytes(), name
    with zipfile.ZipFile(path) as archive:
        assert {info.compress_type for info in archive.infolist()} == {zipfile.ZIP_DEFLATED}
        assert sum(info.compress_size for info in archive.infolist()) < sum(info.file_size for info in
                                                                            archive.infolist())
    with pytest.raises(ValueError, match="pickle"):
        outputs.write_npz(tmp_path / "objects.npz", rows=np.array([{"a": 1}, None], dtype=object))
    assert not (tmp_path / "objects.npz").exists()


def test_atomic_write_replaces_whole_files_with_usual_permissions(tmp_path):
    path = tmp_path / "metrics.json"
    outputs.write_json(path, {"a": 1})
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask
    with pytest.raises(RuntimeError), outputs.atomic_path(path) as temporary:
        temporary.write_text("{trunc")
        raise RuntimeError("writer died")
    assert json.loads(path.read_text()) == {"a": 1}  # the previous complete file is kept
    assert [p.name for p in tmp_path.iterdir()] == ["metrics.json"]  # no temporary left behind
    with pytest.raises(UVMSError, match="cannot write"):
        outputs.write_text(path / "below_a_file.txt", "x")


def complete(folder: Path) -> dict[str, bool]:
    """Which result files exist, after checking that every one that exists is complete."""
    found = {}
    for name in ("metrics.json", "trajectory.csv", "trajectory.npz"):
        path = folder / name
        found[name] = path.exists()
        if not path.exists():
            continue
        if name.endswith(".json"):
            json.loads(path.read_text())
        elif name.endswith(".csv"):
            rows = path.read_text().splitlines()
            assert len(rows) == 102 and all(row.count(",") == rows[0].count(",") for row in rows)
        else:
            with np.load(path) as arrays:
                assert arrays["t"].shape == (101,)
    return found


@pytest.mark.parametrize("delay", [0.8, 1.6, 2.4, 3.2])
def test_killed_run_leaves_previous_outputs_or_none(tmp_path, delay):
    command = [sys.executable, "-m", "uvms.cli", "run", str(SCENARIO), "--out", str(tmp_path), "--quiet",
               "--set", "outputs.figures=false"]
    subprocess.run(command, check=True, capture_output=True)
    before = {name: (tmp_path / name).read_bytes() for name in ("metrics.json", "trajectory.csv")}
    process = subprocess.Popen(command + ["--set", "solver.gain=2"], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    time.sleep(delay)
    process.send_signal(signal.SIGKILL)
    process.wait()
    assert all(complete(tmp_path).values())  # every file still complete: the old one or the new one
    after = (tmp_path / "metrics.json").read_bytes()
    assert after == before["metrics.json"] or json.loads(after)["steps"] == 100
