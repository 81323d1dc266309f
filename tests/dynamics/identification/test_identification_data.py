"""The log of an identification as arrays (uvms.dynamics.identification.data): checks, CSV, smoothing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import savgol_coeffs

from uvms.dynamics.identification import data as identification_data
from uvms.dynamics.identification.data import (
    CSV_COLUMNS,
    IdentificationLog,
    log_csv_text,
    read_log_csv,
    smoothed_states,
    uniform_log,
)
from uvms.errors import IdentificationError


def make_log(count: int = 200, dt: float = 0.02, twist=None, joints: int = 2) -> IdentificationLog:
    t = np.arange(count) * dt
    quaternion = np.column_stack([np.zeros((count, 2)), np.sin(0.1 * t), np.cos(0.1 * t)])  # a slow yaw
    twist = np.column_stack([np.sin(t + k) for k in range(6)]) if twist is None else twist
    names = tuple(f"j{k}" for k in range(joints))
    positions = np.column_stack([np.cos(t + k) for k in range(joints)]) if joints else np.zeros((count, 0))
    return IdentificationLog(t, np.column_stack([t, 2 * t, -t]), quaternion, twist, np.ones((count, 6)), names,
                             positions, None, "test log")


def test_a_nan_row_is_refused_naming_the_sample_and_its_time():
    log = make_log()
    twist = np.array(log.twist)
    twist[57, 3] = np.nan
    with pytest.raises(IdentificationError, match=r"twist has a non-finite value .* sample 57 \(t = 1\.14 s\)"):
        IdentificationLog(log.t, log.position, log.quaternion, twist, log.wrench, log.joint_names,
                          log.joint_position, None, "test log")


@pytest.mark.parametrize("change, message", [
    (lambda a: a.update(t=np.r_[a["t"][:10], a["t"][9], a["t"][11:]]), "times must increase strictly; sample 10"),
    (lambda a: a.update(wrench=a["wrench"][:, :5]), r"wrench must have shape \(200, 6\)"),
    (lambda a: a.update(quaternion=0 * a["quaternion"]), "quaternion of sample 0"),
    (lambda a: a.update(**{k: v[:20] for k, v in a.items() if hasattr(v, "__len__") and len(v) == 200}),
     "holds 20 samples"),
    # values no underwater vehicle logs: the fit's products overflowed (LinAlgError) or a joint's sin/cos was garbage
    (lambda a: a["twist"].__setitem__((7, 1), 1e200), (r"linear velocity of sample 7 \(t = 0.14 s\) is 1e\+200; "
                                                       r".* within \+-100")),
    (lambda a: a["joint_position"].__setitem__(slice(None), 1e300), "joint position of sample 0 .* within \\+-1000"),
    (lambda a: a.update(t=a["t"] + 1e12), "time of sample 0"),
])
def test_bad_arrays_are_refused(change, message):
    log = make_log()
    arrays = {"t": log.t, "position": log.position, "quaternion": log.quaternion, "twist": np.array(log.twist),
              "wrench": log.wrench, "joint_position": np.array(log.joint_position)}
    change(arrays)
    with pytest.raises(IdentificationError, match=message):
        IdentificationLog(joint_names=log.joint_names, source="test log", **arrays)


def test_the_csv_round_trip_is_exact(tmp_path):
    log = make_log()
    path = tmp_path / "log.csv"
    path.write_text(log_csv_text(log))
    back = read_log_csv(path)
    assert back.joint_names == log.joint_names and back.joint_velocity is None
    for name in ("t", "position", "quaternion", "twist", "wrench", "joint_position"):
        np.testing.assert_array_equal(getattr(back, name), getattr(log, name))
    assert path.read_text().splitlines()[0].split(",")[:len(CSV_COLUMNS)] == list(CSV_COLUMNS)


@pytest.mark.parametrize("text, message", [
    ("", "the CSV is empty"),
    ("t,x,y\n0,1,2\n", "has no column"),
    (",".join(CSV_COLUMNS) + "\n" + ",".join(["0"] * 19) + ",abc\n", "not a number"),
    (",".join(CSV_COLUMNS) + "\n" + ",".join(["0"] * 19) + "\n", "every row must have 20 cells"),
])
def test_a_bad_csv_gets_one_clear_error(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(IdentificationError, match=message):
        read_log_csv(path)


def test_a_csv_log_is_read_bounded(tmp_path, monkeypatch):
    """Not a regular file (a device), larger than MAX_LOG_BYTES (a sparse file: nothing on disk), or more rows than
    MAX_LOG_SAMPLES: refused before the text is parsed (a device reached MemoryError before)."""
    zero = tmp_path / "zero.csv"
    zero.symlink_to("/dev/zero")
    with pytest.raises(IdentificationError, match=r"zero.csv: the CSV log file is a device or socket, not a regular"):
        read_log_csv(zero)
    sparse = tmp_path / "sparse.csv"
    with open(sparse, "wb") as handle:
        handle.truncate(identification_data.MAX_LOG_BYTES + 1)
    with pytest.raises(IdentificationError, match=r"the CSV log file holds 128.0 MiB; at most 128 MiB"):
        read_log_csv(sparse)
    rows = tmp_path / "rows.csv"
    rows.write_text(log_csv_text(make_log(count=60)))
    monkeypatch.setattr(identification_data, "MAX_LOG_SAMPLES", 59)
    with pytest.raises(IdentificationError, match=r"rows.csv: the CSV holds more than 59 rows"):
        read_log_csv(rows)


def test_a_csv_log_that_is_a_fifo_is_refused_not_waited_on(tmp_path):
    fifo = tmp_path / "log.csv"
    os.mkfifo(fifo)
    code = (f"from uvms.dynamics.identification.data import read_log_csv\ntry:\n    read_log_csv({str(fifo)!r})\n"
            "except Exception as exc:\n    print(exc)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False,
                          env={**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[3])})
    assert "the CSV log file is a FIFO, not a regular file" in done.stdout, done.stderr[-2000:]


def test_the_savitzky_golay_derivative_of_a_cubic_is_exact():
    t = np.arange(300) * 0.02
    twist = np.column_stack([0.1 * t ** 3 - t + k for k in range(6)])
    states = smoothed_states(make_log(300, twist=twist), window=0.3, polyorder=3)
    np.testing.assert_allclose(states.twist, np.column_stack([0.1 * states.t ** 3 - states.t + k for k in range(6)]),
                               atol=1e-9)
    np.testing.assert_allclose(states.twist_rate, np.tile(0.3 * states.t[:, None] ** 2 - 1.0, (1, 6)), atol=1e-9)
    assert states.window == 15 and len(states.t) == 300 - 14  # half a window dropped at each end
    # joints without velocities: differentiated from their positions (cos -> -sin)
    np.testing.assert_allclose(states.joint_velocity[:, 0], -np.sin(states.t), atol=1e-5)
    np.testing.assert_allclose(states.joint_acceleration[:, 0], -np.cos(states.t), atol=2e-3)  # cubic: O(h^2) error


def test_the_noise_variance_carried_into_the_derivative_is_estimated(rng):
    """White noise of 0.01 on a smooth twist: the variance of the derivative's noise is sigma^2 sum(h1^2)."""
    t = np.arange(5000) * 0.02
    clean = np.column_stack([0.3 * np.sin(0.5 * t + k) for k in range(6)])
    sigma = 0.01
    states = smoothed_states(make_log(5000, twist=clean + rng.normal(0.0, sigma, clean.shape)), window=0.3)
    expected = sigma ** 2 * np.sum(savgol_coeffs(15, 3, deriv=1, delta=0.02) ** 2)
    np.testing.assert_allclose(states.twist_rate_noise, expected, rtol=0.1)
    actual = np.var(states.twist_rate - np.column_stack([0.15 * np.cos(0.5 * states.t + k) for k in range(6)]), axis=0)
    np.testing.assert_allclose(actual, expected, rtol=0.15)


def test_a_jittery_log_is_resampled_and_a_gap_refused(rng):
    log = make_log()
    jittered = log.t + np.r_[0.0, rng.uniform(-0.003, 0.003, len(log.t) - 2), 0.0]
    uneven = IdentificationLog(jittered, log.position, log.quaternion, log.twist, log.wrench, log.joint_names,
                               log.joint_position, None, "jitter")
    even = uniform_log(uneven)
    np.testing.assert_allclose(np.diff(even.t), np.median(np.diff(jittered)), rtol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(even.quaternion, axis=1), 1.0)
    gap = np.r_[log.t[:100], log.t[100:] + 1.0]
    with pytest.raises(IdentificationError, match="a gap of 1.02 s"):
        uniform_log(IdentificationLog(gap, log.position, log.quaternion, log.twist, log.wrench, log.joint_names,
                                      log.joint_position, None, "gap"))
