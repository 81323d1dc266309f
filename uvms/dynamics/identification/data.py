"""A log for hydrodynamic identification as arrays, checked, and the smoothed states and rates the fit uses.

A log holds, per sample k at time t[k] [s]:

* the vehicle's pose in the world (ENU): position (3,) [m] and orientation quaternion (4,) x, y, z, w of its
  root link (``nav_msgs/Odometry`` pose);
* its body twist (6,) [m/s, rad/s] in its root link's own axes, FLU, [linear; angular] (the Odometry twist,
  REP-105 child frame);
* the arm's joint positions (n,) [rad or m] and, optionally, velocities (n,) (``sensor_msgs/JointState``);
* the body wrench (6,) [N, N m] that the thrusters exert on the vehicle, FLU at the root link's origin
  (``geometry_msgs/WrenchStamped``, what ``uvms run --bag`` writes on ``/body_wrench``).

:mod:`uvms.scenario.bags.reader` fills one from a ROS 2 bag; :func:`read_log_csv` from a CSV whose columns are
:data:`CSV_COLUMNS` plus ``position:<joint>`` (and optionally ``velocity:<joint>``) per arm joint.

Derivatives (:func:`smoothed_states`): Savitzky-Golay (``scipy.signal.savgol_filter``), a least-squares
polynomial of order ``polyorder`` (default 3) over a centred window of ``window`` seconds (default 1 s),
evaluated (order 0) for the smoothed twist and joint velocities and differentiated once (order 1) for the
accelerations; a joint without velocities gets them from its positions the same way. Half a window at each
end of the log is dropped (the filter's edge fits are less accurate).
"""

from __future__ import annotations

import array
import csv
import io
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import IdentificationError
from ...model.resources import read_text

#: The CSV's fixed columns, in this order: time [s], position [m] (ENU), quaternion x, y, z, w (body -> world),
#: body twist [m/s, rad/s] (FLU), body wrench [N, N m] (FLU, at the root link's origin). Then ``position:<joint>``
#: [rad or m] per arm joint and optionally ``velocity:<joint>`` [rad/s or m/s].
CSV_COLUMNS = ("t", "x", "y", "z", "qx", "qy", "qz", "qw", "vx", "vy", "vz", "wx", "wy", "wz",
               "fx", "fy", "fz", "mx", "my", "mz")
#: The fewest samples a log must keep after the filter's edges are dropped.
MIN_SAMPLES = 50
#: The largest gap between samples, in median steps, that is bridged by interpolation.
MAX_GAP_STEPS = 5.0
#: The most samples a log may hold (an hour at 50 Hz; the regression holds about 1.3 kB per sample), and the
#: largest CSV log read [bytes] (an hour at 50 Hz of 30 columns of 18 characters).
MAX_LOG_SAMPLES = 200_000
MAX_LOG_BYTES = 128 << 20
#: The largest magnitudes a log's values may have: beyond them a log is not of an underwater vehicle (or not in SI
#: units), and the fit's products overflow. Time [s] (Unix stamps stay below), position [m] (UTM coordinates stay
# below), linear velocity [m/s],
#: angular velocity [rad/s], force [N], moment [N m], joint position [rad or m] (about 160 turns of a continuous
#: joint), joint velocity [rad/s or m/s].
MAX_MAGNITUDES = {"time": 1e10, "position": 1e8, "linear velocity": 100.0, "angular velocity": 100.0, "force": 1e7,
                  "moment": 1e7, "joint position": 1e3, "joint velocity": 100.0}


@dataclass(frozen=True)
class IdentificationLog:
    """What identification reads from a log, checked (see the module docstring for frames and units).

    Attributes:
        t: (N,) [s], strictly increasing.
        position: (N, 3) [m]; quaternion: (N, 4) x, y, z, w (normalised here).
        twist: (N, 6) body twist [m/s, rad/s]; wrench: (N, 6) body wrench [N, N m].
        joint_names: the arm joints of the columns below.
        joint_position: (N, n) [rad or m]; joint_velocity: (N, n) or None (differentiated from the positions).
        source: where the log was read (for messages).

    Raises:
        IdentificationError: wrong shapes, non-finite entries (the first such sample is named), values beyond
            :data:`MAX_MAGNITUDES`, times not strictly increasing, fewer than :data:`MIN_SAMPLES` or more than
            :data:`MAX_LOG_SAMPLES` samples, a zero quaternion.
    """

    t: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    twist: np.ndarray
    wrench: np.ndarray
    joint_names: tuple[str, ...] = ()
    joint_position: np.ndarray | None = None
    joint_velocity: np.ndarray | None = None
    source: str = "<arrays>"

    def __post_init__(self) -> None:
        t = _series(self.t, "t", None, self.source).ravel()
        count = len(t)
        if count < MIN_SAMPLES:
            raise IdentificationError(f"{self.source}: the log holds {count} samples; identification needs at least "
                                      f"{MIN_SAMPLES} (a log of tens of seconds at 10-50 Hz)")
        if count > MAX_LOG_SAMPLES:
            raise IdentificationError(f"{self.source}: the log holds {count:,} samples; identification reads at most "
                                      f"{MAX_LOG_SAMPLES:,} (cut the log to its excitation)")
        steps = np.diff(t)
        if np.any(steps <= 0):
            k = int(np.flatnonzero(steps <= 0)[0]) + 1
            raise IdentificationError(f"{self.source}: the times must increase strictly; sample {k} (t = {t[k]:.6g} s) "
                                      f"does not follow t = {t[k - 1]:.6g} s")
        names = tuple(str(name) for name in self.joint_names)
        width = len(names)
        values = {"t": t, "position": _series(self.position, "position", (count, 3), self.source, t),
                  "quaternion": _series(self.quaternion, "quaternion", (count, 4), self.source, t),
                  "twist": _series(self.twist, "twist", (count, 6), self.source, t),
                  "wrench": _series(self.wrench, "wrench", (count, 6), self.source, t),
                  "joint_position": _series(np.zeros((count, 0)) if self.joint_position is None
                                            else self.joint_position, "joint_position", (count, width), self.source, t),
                  "joint_velocity": None if self.joint_velocity is None else
                  _series(self.joint_velocity, "joint_velocity", (count, width), self.source, t)}
        norms = np.linalg.norm(values["quaternion"], axis=1)
        if np.any(norms < 1e-6):
            k = int(np.flatnonzero(norms < 1e-6)[0])
            raise IdentificationError(f"{self.source}: the orientation quaternion of sample {k} (t = {t[k]:.6g} s) "
                                      "is zero; a pose needs a unit quaternion x, y, z, w")
        values["quaternion"] = values["quaternion"] / norms[:, None]
        _check_magnitudes(values, self.source)
        for name, value in values.items():
            object.__setattr__(self, name, value)
        object.__setattr__(self, "joint_names", names)

    @property
    def duration(self) -> float:
        """t[-1] - t[0] [s]."""
        return float(self.t[-1] - self.t[0])

    def segment(self, start: int, stop: int) -> IdentificationLog:
        """The samples [start, stop) as a log of their own."""
        pick = slice(start, stop)
        velocity = None if self.joint_velocity is None else self.joint_velocity[pick]
        return IdentificationLog(self.t[pick], self.position[pick], self.quaternion[pick], self.twist[pick],
                                 self.wrench[pick], self.joint_names, self.joint_position[pick], velocity, self.source)


def _check_magnitudes(values: dict[str, np.ndarray], source: str) -> None:
    """Refuse a value beyond :data:`MAX_MAGNITUDES` (naming the first such sample and the bound)."""
    parts = {"time": values["t"][:, None], "position": values["position"], "linear velocity": values["twist"][:, :3],
             "angular velocity": values["twist"][:, 3:], "force": values["wrench"][:, :3],
             "moment": values["wrench"][:, 3:], "joint position": values["joint_position"],
             "joint velocity": values["joint_velocity"]}
    for what, part in parts.items():
        if part is None or not part.size:
            continue
        over = np.abs(part) > MAX_MAGNITUDES[what]
        if np.any(over):
            k = int(np.flatnonzero(over.any(axis=1))[0])
            raise IdentificationError(f"{source}: the {what} of sample {k} (t = {values['t'][k]:.6g} s) is "
                                      f"{part[k][over[k]][0]:.6g}; a log's {what} must be within +-"
                                      f"{MAX_MAGNITUDES[what]:g} (SI units)")


def _series(value: object, what: str, shape: tuple[int, int] | None, source: str,
            t: np.ndarray | None = None) -> np.ndarray:
    """A float array of ``shape``, or IdentificationError naming the first non-finite sample (its time)."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise IdentificationError(f"{source}: {what} must be numbers, got {type(value).__name__}") from None
    if shape is not None and array.shape != shape:
        raise IdentificationError(f"{source}: {what} must have shape {shape} (samples, values), got {array.shape}")
    bad = ~np.isfinite(array)
    if np.any(bad):
        k = int(np.flatnonzero(bad.reshape(len(array), -1).any(axis=1))[0])
        when = f" (t = {t[k]:.6g} s)" if t is not None else ""
        raise IdentificationError(f"{source}: {what} has a non-finite value (NaN or inf) in sample {k}{when}; "
                                  "remove or repair the row")
    array.setflags(write=False)
    return array


# ------------------------------------------------------------------ CSV
def read_log_csv(path: str | os.PathLike) -> IdentificationLog:
    """A log from a CSV file: a header row with :data:`CSV_COLUMNS` and ``position:<joint>`` (optionally
    ``velocity:<joint>``) per arm joint, then one row of numbers per sample.

    The file is read by :func:`uvms.model.resources.read_text`: a regular file of at most :data:`MAX_LOG_BYTES`,
    at most :data:`MAX_LOG_SAMPLES` rows.

    Raises:
        IdentificationError: the file cannot be read (not a regular file, too large), a column is missing, a cell
            is not a number, a row is short or long, too many rows, non-finite values (via :class:`IdentificationLog`).
    """
    path = Path(path)
    rows = csv.reader(io.StringIO(read_text(path, "CSV log", MAX_LOG_BYTES, IdentificationError)))
    header = [name.strip() for name in next(rows, [])]
    if not header:
        raise IdentificationError(f"{path}: the CSV is empty; expected a header with {', '.join(CSV_COLUMNS)}")
    missing = [name for name in CSV_COLUMNS if name not in header]
    if missing:
        raise IdentificationError(f"{path}: the CSV has no column(s) {', '.join(missing)}; expected "
                                  f"{', '.join(CSV_COLUMNS)} and position:<joint> per arm joint")
    cells = array.array("d")  # 8 bytes a cell, whatever the text
    count = 0
    try:
        for row in rows:
            if not row:
                continue
            if len(row) != len(header):
                raise IdentificationError(f"{path}: every row must have {len(header)} cells like the header; row "
                                          f"{count + 2} has {len(row)}")
            count += 1
            if count > MAX_LOG_SAMPLES:
                raise IdentificationError(f"{path}: the CSV holds more than {MAX_LOG_SAMPLES:,} rows; identification "
                                          "reads at most that many (cut the log to its excitation)")
            cells.extend(float(cell) for cell in row)
    except ValueError as exc:
        raise IdentificationError(f"{path}: a cell is not a number ({exc})") from None
    except csv.Error as exc:
        raise IdentificationError(f"{path}: not a CSV file ({exc})") from None
    table = np.frombuffer(cells, dtype=float).reshape(count, len(header))
    column = {name: index for index, name in enumerate(header)}
    joints = [name.split(":", 1)[1] for name in header if name.startswith("position:")]
    velocities = [f"velocity:{joint}" for joint in joints]
    has_velocity = all(name in column for name in velocities) and bool(joints)

    def take(names: list[str] | tuple[str, ...]) -> np.ndarray:
        return table[:, [column[name] for name in names]]

    return IdentificationLog(
        take(["t"]).ravel(), take(CSV_COLUMNS[1:4]), take(CSV_COLUMNS[4:8]), take(CSV_COLUMNS[8:14]),
        take(CSV_COLUMNS[14:20]), tuple(joints), take([f"position:{joint}" for joint in joints]),
        take(velocities) if has_velocity else None, str(path))


def log_csv_text(log: IdentificationLog) -> str:
    """The CSV text of a log (the inverse of :func:`read_log_csv`)."""
    header = list(CSV_COLUMNS) + [f"position:{name}" for name in log.joint_names]
    blocks = [log.t[:, None], log.position, log.quaternion, log.twist, log.wrench, log.joint_position]
    if log.joint_velocity is not None:
        header += [f"velocity:{name}" for name in log.joint_names]
        blocks.append(log.joint_velocity)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(np.hstack(blocks).tolist())
    return buffer.getvalue()


# ------------------------------------------------------------------ uniform sampling and smoothing
def uniform_log(log: IdentificationLog) -> IdentificationLog:
    """The log on a uniform time grid at its median step (linear interpolation; quaternions renormalised).

    A log already uniform within 1 % of its step is returned as it is.

    Raises:
        IdentificationError: a gap longer than :data:`MAX_GAP_STEPS` median steps (a dropout to cut out first).
    """
    steps = np.diff(log.t)
    step = float(np.median(steps))
    if np.max(steps) > MAX_GAP_STEPS * step:
        k = int(np.argmax(steps))
        raise IdentificationError(
            f"{log.source}: a gap of {steps[k]:.3g} s after t = {log.t[k]:.6g} s ({steps[k] / step:.1f} median steps "
            f"of {step:.3g} s); cut the log there or repair it (at most {MAX_GAP_STEPS:g} steps are bridged)")
    if np.max(np.abs(steps - step)) <= 0.01 * step:
        return log
    grid = log.t[0] + step * np.arange(int(np.floor(log.duration / step + 1e-9)) + 1)

    def resample(values: np.ndarray | None) -> np.ndarray | None:
        if values is None:
            return None
        return np.column_stack([np.interp(grid, log.t, values[:, i]) for i in range(values.shape[1])]) \
            if values.shape[1] else np.zeros((len(grid), 0))

    quaternion = log.quaternion * np.sign(np.sum(log.quaternion * log.quaternion[0], axis=1))[:, None]
    return IdentificationLog(grid, resample(log.position), resample(quaternion), resample(log.twist),
                             resample(log.wrench), log.joint_names, resample(log.joint_position),
                             resample(log.joint_velocity), log.source)


@dataclass(frozen=True)
class SmoothedStates:
    """The states and rates of a log after Savitzky-Golay smoothing, its edges dropped (module docstring).

    Attributes:
        t: (K,) [s]; position (K, 3); quaternion (K, 4) x, y, z, w; measured_twist (K, 6): as logged (on
            the uniform grid).
        wrench: (K, 6) smoothed by the same filter as the twist, so both sides of the equations of motion see
            the same filter (its lag and attenuation cancel on the linear terms).
        twist, twist_rate: (K, 6) smoothed body twist and its derivative [m/s^2, rad/s^2].
        joint_position, joint_velocity, joint_acceleration: (K, n).
        twist_rate_noise: (6,) the variance of the noise left in twist_rate [(m/s^2)^2, (rad/s^2)^2], from the
            logged twist's white-noise variance (its residual about the smoothed twist, divided by 1 - h_0 of the
            smoothing filter) times the sum of the squared coefficients of the derivative filter.
        window: the filter's window [samples, odd]; dt: the sample step [s].
    """

    t: np.ndarray
    position: np.ndarray
    quaternion: np.ndarray
    wrench: np.ndarray
    measured_twist: np.ndarray
    twist: np.ndarray
    twist_rate: np.ndarray
    joint_position: np.ndarray
    joint_velocity: np.ndarray
    joint_acceleration: np.ndarray
    twist_rate_noise: np.ndarray
    window: int
    dt: float


def window_samples(window: float, dt: float, polyorder: int, duration: float | None = None) -> int:
    """The Savitzky-Golay window [samples, odd, > polyorder] of ``window`` seconds at the step dt [s].

    Raises:
        IdentificationError: a window shorter than polyorder + 2 samples or longer than ``duration`` [s] (the
            log's), or a polyorder outside 1..6.
    """
    if not (isinstance(polyorder, (int, np.integer)) and 1 <= polyorder <= 6):
        raise IdentificationError(f"polyorder must be an integer in 1..6 (3: cubic), got {polyorder!r}")
    longest = np.inf if duration is None else duration
    if not (isinstance(window, (int, float, np.number)) and np.isfinite(window) and 0 < window <= longest):
        within = "> 0 s" if duration is None else f"in (0, {duration:.6g}] s (the log's duration)"
        raise IdentificationError(f"the smoothing window must be {within}, got {window!r}")
    samples = int(round(window / dt)) | 1
    if samples < polyorder + 2:
        raise IdentificationError(f"the smoothing window {window:g} s holds {samples} samples at dt = {dt:.3g} s; "
                                  f"a polynomial of order {polyorder} needs at least {polyorder + 2} (make it longer)")
    return samples


def smoothed_states(log: IdentificationLog, window: float = 0.3, polyorder: int = 3) -> SmoothedStates:
    """Smoothed twist, accelerations and joint rates of a (uniformly resampled) log (module docstring).

    Args:
        log: the log; window: the filter's window [s]; polyorder: its polynomial order.

    Raises:
        IdentificationError: a bad window (:func:`window_samples`), a log too short for it, a gap.
    """
    from scipy.signal import savgol_filter

    log = uniform_log(log)
    dt = float(np.median(np.diff(log.t)))
    samples = window_samples(window, dt, polyorder, log.duration)
    half = samples // 2
    if len(log.t) - 2 * half < MIN_SAMPLES:
        raise IdentificationError(f"{log.source}: {len(log.t)} samples leave fewer than {MIN_SAMPLES} once the "
                                  f"smoothing window ({samples} samples) is dropped at both ends; use a longer log")

    def smooth(values: np.ndarray, deriv: int) -> np.ndarray:
        if values.shape[1] == 0:
            return values.copy()
        return savgol_filter(values, samples, polyorder, deriv=deriv, delta=dt, axis=0, mode="interp")

    joint_velocity = smooth(log.joint_position, 1) if log.joint_velocity is None else smooth(log.joint_velocity, 0)
    joint_rate_source = log.joint_position if log.joint_velocity is None else log.joint_velocity
    joint_acceleration = smooth(joint_rate_source, 2 if log.joint_velocity is None else 1) \
        if polyorder >= 2 or log.joint_velocity is not None else np.zeros_like(joint_velocity)
    keep = slice(half, len(log.t) - half)
    twist = smooth(log.twist, 0)
    quaternion = smooth(log.quaternion * np.sign(log.quaternion @ log.quaternion[0])[:, None], 0)
    quaternion /= np.linalg.norm(quaternion, axis=1)[:, None]
    return SmoothedStates(log.t[keep], log.position[keep], quaternion[keep], smooth(log.wrench, 0)[keep],
                          log.twist[keep], twist[keep], smooth(log.twist, 1)[keep], log.joint_position[keep],
                          joint_velocity[keep], joint_acceleration[keep],
                          _rate_noise(log.twist[keep] - twist[keep], samples, polyorder, dt), samples, dt)


def _rate_noise(residual: np.ndarray, samples: int, polyorder: int, dt: float) -> np.ndarray:
    """The variance (6,) of the white noise of the logged twist carried into its Savitzky-Golay derivative."""
    from scipy.signal import savgol_coeffs

    smoothing = savgol_coeffs(samples, polyorder)
    derivative = savgol_coeffs(samples, polyorder, deriv=1, delta=dt)
    # E|x - S x|^2 = sigma^2 (1 - h_0) for the projection S of a least-squares polynomial fit
    variance = np.mean(residual ** 2, axis=0) / max(1.0 - smoothing[samples // 2], 1e-12)
    return variance * float(np.sum(derivative ** 2))
