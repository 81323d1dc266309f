"""The browser viewer's panel: the teach sliders (vehicle pose and arm joints) and the playback of a run; and
what a page may do: who may connect (:func:`request_refusal`, checked on every request by
:func:`guarded_servers`) and the values it may set (clamped to the sliders' ranges, finite).

The slider ranges and the configuration of slider values are those of the notebook teach panel
(:func:`uvms.viz.viewer.teach.sliders`, :func:`uvms.viz.viewer.teach.teach_state`): one implementation for both.

viser calls every callback synchronously when Python assigns a value, and in its thread pool when a page
changes one; a thread-local flag tells the two apart, so showing a configuration on the sliders never
re-enters the robot.
"""

from __future__ import annotations

import contextlib
import http
import math
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping

import numpy as np
import pinocchio as pin

from ...errors import UVMSError
from ...io.progress import tqdm
from ...robot.robot import Robot
from . import teach

#: Panel order of the groups (smallest first).
ORDER_PLAYBACK, ORDER_POSES, ORDER_VEHICLE, ORDER_ARM, ORDER_RESET = 10.0, 20.0, 30.0, 40.0, 50.0
SLIDER_STEPS = 400  # steps across a slider's range
#: Playback speeds a page may set [x]: the range of the speed input.
SPEED_RANGE = (1e-3, 1e6)
#: The names a page may use for the viewer (in its Host, and in its Origin after ``http://``), with ``:PORT``.
LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
_SERVE_LOCK = threading.Lock()  # one viewer starts its server at a time (websockets.asyncio.server.serve wrapped)


# ------------------------------------------------------------------ who may connect
def request_refusal(headers, port: int) -> str | None:
    """Why a request to the viewer on ``port`` is refused, None if it is not.

    Its one Host header must be one of :data:`LOOPBACK_NAMES` with ``:port`` (bare at port 80), and its
    Origin header, when there is one, ``http://`` and the same: a foreign Host is a DNS-rebinding page, a
    foreign Origin any web page opening a WebSocket to 127.0.0.1. A request without Origin is not from a
    page (the browser sends it on every WebSocket) and is accepted.

    Args:
        headers: the request's ``websockets.datastructures.Headers``.
        port: the port the server listens on.
    """
    hosts = {f"{name}:{port}" for name in LOOPBACK_NAMES} | (set(LOOPBACK_NAMES) if port == 80 else set())
    host, origin = headers.get_all("Host"), headers.get_all("Origin")
    if len(host) != 1 or host[0].strip().lower() not in hosts:
        return f"Host {', '.join(host) or '(none)'} is not this viewer, which answers http://127.0.0.1:{port} only"
    if origin and (len(origin) != 1 or origin[0].strip().lower() not in {f"http://{name}" for name in hosts}):
        return f"Origin {', '.join(origin)} is not this viewer's page (http://127.0.0.1:{port})"
    return None


def _guard(process_request: Callable | None) -> Callable:
    """A websockets ``process_request`` answering 403 to what :func:`request_refusal` refuses, else viser's."""

    def checked(connection, request):
        reason = request_refusal(request.headers, connection.local_address[1])
        if reason is not None:
            return connection.respond(http.HTTPStatus.FORBIDDEN, f"{reason}\n")
        return None if process_request is None else process_request(connection, request)

    return checked


@contextlib.contextmanager
def guarded_servers() -> Iterator[list[bool]]:
    """While open, the websockets servers viser starts check Host and Origin first (:func:`_guard`).

    viser hands its HTTP file server to ``websockets.asyncio.server.serve`` as ``process_request`` and offers
    no hook: the function is wrapped for callers in viser, only while a Viewer starts its server. Yields a
    list that gets an item per server guarded (empty: viser started no server through it; fail closed).
    """
    import websockets.asyncio.server as module

    original, guarded = module.serve, []

    def serve(*args, **kwargs):
        if sys._getframe(1).f_globals.get("__name__", "").startswith("viser."):
            kwargs["process_request"] = _guard(kwargs.get("process_request"))
            guarded.append(True)
        return original(*args, **kwargs)

    with _SERVE_LOCK:
        module.serve = serve
        try:
            yield guarded
        finally:
            module.serve = original


# ------------------------------------------------------------------ the panel
def poses_markdown(poses: Mapping[str, pin.SE3]) -> str:
    """The end-effector poses as panel markdown: per frame, position [m] and roll, pitch, yaw [deg] (world)."""
    lines = []
    for frame, pose in poses.items():
        rpy = np.degrees(pin.rpy.matrixToRpy(pose.rotation))
        lines.append(f"**{frame}**  \n`xyz [m]   {' '.join(f'{v:+.3f}' for v in pose.translation)}`  \n"
                     f"`rpy [deg] {' '.join(f'{v:+.1f}' for v in rpy)}`")
    return "\n\n".join(lines)


def _marks(lower: float, upper: float) -> tuple[tuple[float, str], ...]:
    """Slider marks: the ends (and 0 when inside), to 3 significant digits."""
    values = [lower, *([0.0] if lower < 0 < upper else []), upper]
    return tuple((value, f"{value:.3g}") for value in values)


def _label(name: str, unit: str) -> str:
    short = name.removeprefix("base_")
    return f"{short} [{unit}]"


class TeachControls:
    """Teach panel in the page: a slider per vehicle pose coordinate [m, rad] and per one-DOF arm joint
    (its limits; an unbounded or continuous joint spans [-pi, pi]), the end-effector poses and a reset button.

    Args:
        server: the viser server.
        robot: the robot.
        q: the starting configuration (nq,), also the one "reset" returns to.
        show: called with the new configuration (nq,) whenever a slider moves.

    Attributes:
        sliders: {slider name (``base_x``... or joint name): viser slider handle}.
        specs: {slider name: :class:`uvms.viz.viewer.teach.Slider`} at the start.
        ranges: {slider name: (lower, upper)} the slider values are clamped to (a page can send any number):
            the joint limits, the vehicle's range (widened when the robot is shown beyond it).
    """

    def __init__(self, server, robot: Robot, q: np.ndarray, show: Callable[[np.ndarray], None]) -> None:
        self.robot, self.start, self._show = robot, robot.check_configuration(q).copy(), show
        self._local = threading.local()
        self.q = self.start.copy()
        gui = server.gui
        self.specs = {spec.name: spec for spec in teach.sliders(robot, self.start)}
        vehicle = set(teach.VEHICLE_SLIDERS[robot.base_type])
        self.folders = []
        self.sliders = {}
        self.ranges = {name: (spec.lower, spec.upper) for name, spec in self.specs.items()}
        self.folders.append(gui.add_folder("End effectors", order=ORDER_POSES))
        with self.folders[-1]:
            self.poses = gui.add_markdown("", order=ORDER_POSES)
        for title, order, names in (
                (f"Vehicle ({robot.base_type})", ORDER_VEHICLE, [n for n in self.specs if n in vehicle]),
                ("Arm joints", ORDER_ARM, [n for n in self.specs if n not in vehicle])):
            if not names:
                continue
            self.folders.append(gui.add_folder(title, order=order))
            with self.folders[-1]:
                for name in names:
                    spec = self.specs[name]
                    step = (spec.upper - spec.lower) / SLIDER_STEPS if spec.upper > spec.lower else 1e-3
                    handle = gui.add_slider(_label(name, spec.unit), min=spec.lower, max=spec.upper, step=step,
                                            initial_value=spec.value, hint=f"{name} [{spec.unit}]",
                                            marks=None if spec.unit == "m" and name in vehicle
                                            else _marks(spec.lower, spec.upper))  # a widened range: own ends
                    handle.on_update(self._moved)
                    self.sliders[name] = handle
        self.reset_button = gui.add_button("Reset configuration", order=ORDER_RESET,
                                           hint="back to the configuration the viewer started with")
        self.reset_button.on_click(lambda _event: self._show(self.start.copy()))

    def values(self) -> dict[str, float]:
        """The slider values {name: value} [m, rad], clamped to :attr:`ranges`; a value that is not a finite
        number (NaN from a page) is the one shown."""
        shown = {spec.name: spec.value for spec in teach.sliders(self.robot, self.q)}
        values = {}
        for name, handle in self.sliders.items():
            lower, upper = self.ranges[name]
            try:
                value = float(handle.value)
            except (TypeError, ValueError):
                value = math.nan
            values[name] = min(max(value, lower), upper) if math.isfinite(value) else shown[name]
        return values

    def configuration(self) -> np.ndarray:
        """The configuration (nq,) of the slider values (joints without a slider keep their value)."""
        q, _ = teach.teach_state(self.robot, self.values(), self.q)
        return q

    def _moved(self, _event) -> None:
        if getattr(self._local, "syncing", False):
            return
        self._show(self.configuration())

    def sync(self, q: np.ndarray, poses: Mapping[str, pin.SE3]) -> None:
        """Put the sliders at configuration q (nq,) and show the end-effector poses, without moving the robot.

        A vehicle position outside a slider's range widens the range.

        Args:
            q: the configuration shown (nq,).
            poses: {end-effector frame: world pose} at q.
        """
        self.q = np.array(q, dtype=float)
        self._local.syncing = True
        try:
            for spec in teach.sliders(self.robot, self.q):
                handle = self.sliders.get(spec.name)
                if handle is None:
                    continue
                lower, upper = self.ranges[spec.name]
                lower, upper = self.ranges[spec.name] = min(lower, spec.lower), max(upper, spec.upper)
                if (handle.min, handle.max) != (lower, upper):
                    handle.min, handle.max = lower, upper
                handle.value = spec.value
            self.poses.content = poses_markdown(poses)
        finally:
            self._local.syncing = False

    def remove(self) -> None:
        """Take the controls off the page."""
        for folder in self.folders:
            folder.remove()
        self.reset_button.remove()


class Playback:
    """A run in the page: a "time [s]" slider, play and pause buttons and the playback speed.

    Args:
        server: the viser server.
        show_time: shows the configuration of the run at a time [s] and returns its index k.
        speed: simulated seconds per wall-clock second, at the start.

    Attributes:
        time_slider, speed_input, play_button, pause_button: the viser handles.
        t: the times of the run (N,) [s].
    """

    def __init__(self, server, show_time: Callable[[float], int], speed: float = 1.0) -> None:
        gui = server.gui
        self._show_time = show_time
        self._stop = threading.Event()  # set: the run in progress (if any) must stop
        self._idle = threading.Event()  # set: no run in progress
        self._idle.set()
        self._begin = threading.Lock()  # one run begins at a time
        self._runner: int | None = None  # thread ident of the run in progress
        self.t = np.zeros(1)
        self.folder = gui.add_folder("Run", order=ORDER_PLAYBACK)
        with self.folder:
            self.time_slider = gui.add_slider("time [s]", min=0.0, max=1.0, step=1e-3, initial_value=0.0)
            self.play_button = gui.add_button("Play", icon="player-play", hint="play the run from the time shown")
            self.pause_button = gui.add_button("Pause", icon="player-pause", disabled=True)
            self.speed_input = gui.add_number("speed [x]", initial_value=float(speed), min=1e-3, step=0.1,
                                              hint="simulated seconds per second")
        self.time_slider.on_update(lambda _event: self._show_time(self.slider_time()))
        self.play_button.on_click(lambda _event: self.start())
        self.pause_button.on_click(lambda _event: self.pause())

    def load(self, t: np.ndarray) -> None:
        """Scrub through times t (N,) [s] (non-decreasing); shows the first configuration."""
        self.pause()
        self.t = np.asarray(t, dtype=float)
        start, end = float(self.t[0]), float(self.t[-1])
        step = max((end - start) / 1000, 1e-6)
        self.time_slider.min, self.time_slider.max, self.time_slider.step = start, max(end, start + step), step
        self.time_slider.value = start
        self._show_time(start)

    def slider_time(self) -> float:
        """The time slider's value [s] clamped to the run (a page can send any number; not finite: the start)."""
        value = float(self.time_slider.value)
        return min(max(value, float(self.t[0])), float(self.t[-1])) if math.isfinite(value) else float(self.t[0])

    def page_speed(self) -> float:
        """The speed input's value clamped to :data:`SPEED_RANGE` (not finite: 1)."""
        value = float(self.speed_input.value)
        return min(max(value, SPEED_RANGE[0]), SPEED_RANGE[1]) if math.isfinite(value) else 1.0

    @property
    def playing(self) -> bool:
        """True while the run plays (from :meth:`start` or :meth:`run`)."""
        return not self._idle.is_set()

    def run(self, speed: float | None = None, fps: float = 30.0, progress: bool | None = None) -> None:
        """Play from the time shown to the end; returns there or on :meth:`pause` (or the page's Pause).

        Moving the time slider while playing continues from the new time.

        Args:
            speed: simulated seconds per wall-clock second (None: the page's speed).
            fps: frames shown per wall-clock second.
            progress: progress bar (None: only on a terminal).
        """
        speed = self.page_speed() if speed is None else float(speed)
        if not (speed > 0 and fps > 0 and math.isfinite(speed) and math.isfinite(fps)):
            raise UVMSError(f"speed and fps must be finite and > 0, got speed={speed}, fps={fps}")
        with self._begin:
            self.pause()  # a run in progress (the page's Play, or another call) ends first
            self._stop.clear()
            self._idle.clear()
            self._runner = threading.get_ident()
        self.play_button.disabled, self.pause_button.disabled = True, False
        start, end = float(self.t[0]), float(self.t[-1])
        anchor = self.slider_time()
        if anchor >= end:  # at the end: play again from the start
            anchor = start
        began, shown = time.perf_counter(), None
        bar = tqdm(total=round(end - anchor, 6), disable=(not progress) if progress is not None else None,
                   desc="playing", unit="s", leave=False)
        try:
            while not self._stop.is_set():
                if shown is not None and float(self.time_slider.value) != shown:  # scrubbed in the page
                    anchor, began = self.slider_time(), time.perf_counter()
                now = min(anchor + (time.perf_counter() - began) * speed, end)
                self.time_slider.value = now  # shows it (the slider's callback)
                if shown is None:
                    self._show_time(now)  # the slider may already have been there
                bar.n = round(now - anchor, 6)
                bar.refresh()
                shown = float(self.time_slider.value)
                if now >= end:
                    break
                self._stop.wait(1.0 / fps)
        finally:
            bar.close()
            self.play_button.disabled, self.pause_button.disabled = False, True
            self._runner = None
            self._idle.set()

    def start(self, speed: float | None = None, fps: float = 30.0) -> threading.Thread:
        """Play in a background thread (the page's Play button); returns the thread."""
        thread = threading.Thread(target=self.run, kwargs={"speed": speed, "fps": fps, "progress": False},
                                  daemon=True, name="uvms-viewer-playback")
        thread.start()
        return thread

    def pause(self) -> None:
        """Stop playing and wait until the run in progress has stopped (the time shown stays)."""
        self._stop.set()
        if self._runner != threading.get_ident():
            self._idle.wait()

    def remove(self) -> None:
        """Stop and take the controls off the page."""
        self.pause()
        self.folder.remove()
