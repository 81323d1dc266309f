"""3-D viewer: a model with its meshes, or a run as an animation, in the browser through Pinocchio's viser viewer.

Optional: ``pip install uvms[viz]`` (viser). The server listens on 127.0.0.1 only; open the printed
URL on the same machine (or through an SSH tunnel, ``ssh -L 8080:127.0.0.1:8080 host``). Listening on the
loopback does not stop a web page in the same browser from reaching it, so every request must name the
viewer: its Host must be ``127.0.0.1:PORT``, ``localhost:PORT`` or ``[::1]:PORT`` and its Origin, if any (a
browser's WebSocket always sends one), ``http://`` one of those; anything else is answered 403
(:func:`~uvms.viz.viewer.gui.request_refusal`). The values a page sends are clamped to the sliders' ranges.

The page opens with the camera framed on the robot, a seabed grid under it and a triad on every end
effector; its panel is the teach panel (sliders for the vehicle pose and every arm joint, moving the robot
live, and the end-effector poses) and, for a run, a time slider with play and pause. The geometry is the
URDF's visuals, or a stick skeleton for a model without any (:mod:`uvms.viz.viewer.geometry`); the camera,
seabed and triads are in :mod:`uvms.viz.viewer.scene`, the panel in :mod:`uvms.viz.viewer.gui`; the collision
shapes (the panel's "Collision shapes" checkbox) and the closest pairs of collision objectives
(:meth:`Viewer.mark_closest`) in :mod:`uvms.viz.viewer.collision`.

Without the extra, :mod:`uvms.viz.drawing` draws the same configurations headless (``uvms view --headless OUT``).
"""

from __future__ import annotations

import math
import socket
import threading
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ...errors import UVMSError, ViewerInputError, ViewerUnavailable
from ...numerics.validate import finite_array, time_vector
from ...robot.robot import Robot
from ...tasks.objectives.collision import NearestPairs
from ..collision_shapes import ClosestPairs
from ..drawing import as_configurations
from .collision import CollisionControls
from .geometry import EE_COLOUR, SKELETON_COLOUR, geometry_models, skeleton_geometry
from .gui import Playback, TeachControls, guarded_servers, request_refusal
from .scene import EndEffectorTriads, Framing, add_lighting, add_seabed, apply_camera, bounding_box, framing

__all__ = ["EE_COLOUR", "SKELETON_COLOUR", "Viewer", "ViewerUnavailable", "check_port", "geometry_models", "play",
           "request_refusal", "require_viser", "skeleton_geometry", "view"]


#: The viewer binds to this address only: never to all interfaces.
HOST = "127.0.0.1"
DEFAULT_PORT = 8080
INSTALL_HINT = "the 3-D viewer needs `pip install uvms[viz]` (viser)"
#: Ports tried from the one asked (viser's own count) when it is busy.
PORT_TRIES = 1000


def require_viser():
    """``(viser, ViserVisualizer)``, imported on first use.

    Raises:
        ViewerUnavailable: viser is missing; the message gives the install command.
    """
    try:
        import viser
        from pinocchio.visualize import ViserVisualizer
    except ImportError as exc:
        raise ViewerUnavailable(f"{INSTALL_HINT}: {exc}; or draw headless with uvms.viz.drawing "
                                f"(`uvms view ... --headless OUT.png|OUT.gif`)") from None
    return viser, ViserVisualizer


# ------------------------------------------------------------------ port, Host and Origin
def check_port(port: int) -> int:
    """``port`` if the viewer can listen on it: an integer in 1..65535, or 0 (any free port).

    Raises:
        ViewerInputError: anything else (a negative port, 65536, a float).
    """
    if isinstance(port, bool) or not isinstance(port, (int, np.integer)) or not 0 <= port <= 65535:
        raise ViewerInputError(f"the viewer's port must be an integer in 1..65535 (or 0: any free port), got {port!r}")
    return int(port)


def first_free_port(port: int) -> int:
    """The first port from ``port`` (at most :data:`PORT_TRIES`, at most 65535) that 127.0.0.1 can bind; 0 stays 0.

    viser would try the next ports itself, but past 65535 its server thread dies and the caller waits forever.
    """
    if check_port(port) == 0:
        return 0
    last = min(port + PORT_TRIES, 65536) - 1
    for candidate in range(port, last + 1):
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as asyncio's server does
            try:
                probe.bind((HOST, candidate))
            except OSError:
                continue
        return candidate
    raise ViewerInputError(f"no free port in {port}..{last} on {HOST}; give another port (0: any free port)")


# ------------------------------------------------------------------ viewer
def check_times(t: np.ndarray, count: int) -> np.ndarray:
    """Times (N,) [s], finite and non-decreasing, one per configuration."""
    return time_vector(finite_array(t, "times (one per configuration)", (count,)), "times", strict=False)


class Viewer:
    """A running viser server on 127.0.0.1 showing one robot through ``pinocchio.visualize.ViserVisualizer``.

    The page opens with the camera framed on the robot (its bounding box at the configuration shown, or
    over a whole run), a seabed grid under it, an x-y-z triad on every end effector and, in the panel, the
    teach sliders (vehicle pose [m, rad] and every one-DOF arm joint within its limits) that move the robot
    live; :meth:`play` adds a time slider with play and pause buttons.

    Use as a context manager, or call :meth:`close` to stop the server.

    Args:
        robot: the robot.
        q: configuration shown first and framed by the camera (nq,); default neutral.
        port: first port tried, 1..65535 (the next free one is taken when busy), or 0 (any free port); the
            host is always 127.0.0.1.
        skeleton: add the stick geometry (None: only when the model has no visual geometry).
        collision: show the collision shapes at first (the panel's "Collision shapes" checkbox toggles them).

    Meshes are found as the robot was loaded (``package://`` through ``robot.packages``).

    Raises:
        ViewerInputError: a port outside 0..65535, or no free port from it.

    Attributes:
        robot: the robot shown; visualizer: the ViserVisualizer; server: the ``viser.ViserServer``.
        q: the configuration shown (nq,). teach: the panel's sliders (:class:`TeachControls`).
        playback: the run's controls (:class:`Playback`), None before :meth:`play`. scene_frame: the
        camera and seabed (:class:`~uvms.viz.viewer.scene.Framing`). collision: the collision shapes' checkbox
        and closest-pair segments (:class:`~uvms.viz.viewer.collision.CollisionControls`); closest: the
        objectives marked (:meth:`mark_closest`), None: none.
    """

    def __init__(self, robot: Robot, q: np.ndarray | None = None, *, port: int = DEFAULT_PORT,
                 skeleton: bool | None = None, collision: bool = False) -> None:
        viser, _ = require_viser()
        port = first_free_port(port)  # the next free port if taken
        with guarded_servers() as guarded:
            self.server = viser.ViserServer(host=HOST, port=port, verbose=False)
        if not guarded:
            self.server.stop()
            raise ViewerUnavailable(f"viser {getattr(viser, '__version__', '?')} starts its server in a way uvms "
                                    f"cannot guard (Host and Origin checks); install the viser of uvms[viz]")
        self.teach: TeachControls | None = None
        self.playback: Playback | None = None
        self.collision: CollisionControls | None = None
        self.closest: ClosestPairs | None = None
        self._collision_shown = collision
        self._trajectory: tuple[np.ndarray, np.ndarray] | None = None
        self._lock = threading.RLock()
        try:
            self.server.gui.configure_theme(show_share_button=False)
            self.server.gui.set_panel_label("uvms")
            self.server.gui.main_panel.dock_right()
            self._show_model(robot, robot.neutral() if q is None else q, skeleton)
        except BaseException:
            self.server.stop()
            raise

    def _show_model(self, robot: Robot, q: np.ndarray, skeleton: bool | None) -> None:
        _, ViserVisualizer = require_viser()
        q = robot.check_configuration(q)
        visual, collision = geometry_models(robot, skeleton)
        visualizer = ViserVisualizer(robot.model, collision, visual)
        if self.playback is not None:  # stopped outside the lock: the playback thread displays under it
            self.playback.remove()
            self.playback = None
        with self._lock:
            if self.collision is not None:  # before the scene's reset, which would take its segments
                self._collision_shown = self.collision.shown
                self.collision.remove()
            self.server.scene.reset()  # the scene only: the page and the camera of open pages stay
            visualizer.initViewer(viewer=self.server, loadModel=True)
            add_lighting(self.server)
            self.robot, self.visualizer = robot, visualizer
            if self.teach is not None:
                self.teach.remove()
            self.closest = None  # built on the previous model
            self.collision = CollisionControls(self.server, visualizer, self._collision_shown,
                                               lambda: self.display(self.q))
            self.frame(q)
            self.triads = EndEffectorTriads(self.server, robot, self.scene_frame.size)
            self.teach = TeachControls(self.server, robot, q, self.display_from_page)
            self.display(q)

    def frame(self, q: np.ndarray | None = None, *, move_cameras: bool = False) -> Framing:
        """Frame the camera on the robot and lay the seabed grid under it.

        Args:
            q: one configuration (nq,) or a run's (N, nq); default the one shown.
            move_cameras: also move the cameras of the pages already open (else only new pages and
                "Reset View" use the new framing).

        Returns:
            The framing (camera position and target, seabed height) [m].
        """
        qs = as_configurations(self.robot, self.q if q is None else q)
        lower, upper = bounding_box(self.robot, self.visualizer.visual_model, qs)
        self.scene_frame = framing(lower, upper, planar=self.robot.base_type == "planar")
        apply_camera(self.server, self.scene_frame, clients=move_cameras)
        self.seabed = add_seabed(self.server, self.scene_frame)
        return self.scene_frame

    def reload(self, robot: Robot, q: np.ndarray | None = None, *, skeleton: bool | None = None) -> None:
        """Show another version of the model (e.g. after an edit of its URDF) in place: same page, same camera.

        The teach sliders are rebuilt for the new model; a run played before is dropped (it may no longer fit).

        Args:
            robot: the new robot.
            q: configuration to show (default: the one shown, if it still fits the model, else neutral).
        """
        if q is None:
            q = self.q if len(self.q) == robot.nq else robot.neutral()
        self._trajectory = None
        self._show_model(robot, q, skeleton)

    @property
    def url(self) -> str:
        """Address of the viewer page (local machine only)."""
        return f"http://{HOST}:{self.server.get_port()}"

    def display(self, q: np.ndarray) -> None:
        """Show configuration q (nq,): the robot, the end-effector triads and the panel's sliders."""
        q = self.robot.check_configuration(q)
        with self._lock:
            self.q = q
            visualizer = self.visualizer
            visualizer.display(q)
            pin.updateFramePlacements(visualizer.model, visualizer.data)
            self.triads.show(visualizer.data)
            if self.closest is not None:
                self.collision.mark(self.closest.at(q))
            if self.teach is not None:
                poses = {name: visualizer.data.oMf[self.robot.frame_id(name)] for name in self.robot.ee_frames}
                self.teach.sync(q, poses)

    def mark_closest(self, objectives: Sequence[NearestPairs]) -> None:
        """Mark the closest pair of each collision objective (built on the robot shown) at every configuration
        shown, a segment between its witness points coloured by its distance (red below the objective's min);
        none: no marks. A :meth:`reload` drops them."""
        with self._lock:
            self.closest = ClosestPairs(self.robot, objectives) if objectives else None
            self.collision.mark([])
            self.display(self.q)

    def display_from_page(self, q: np.ndarray) -> None:
        """Show q (nq,) set in the page (teach sliders, reset): a run that plays is paused first."""
        if self.playback is not None:
            self.playback.pause()
        self.display(q)

    def _show_time(self, time_: float) -> int:
        """Show the run's configuration at time_ [s] (the last one at or before it); returns its index k."""
        if self._trajectory is None:
            return -1
        t, qs = self._trajectory
        k = max(int(min(np.searchsorted(t, time_, side="right") - 1, len(t) - 1)), 0)
        self.display(qs[k])
        return k

    def load(self, t: np.ndarray, q: np.ndarray, *, speed: float = 1.0) -> None:
        """Put a run in the page without playing it: configurations q (N, nq) at times t (N,) [s].

        The time slider, play/pause buttons and speed appear in the panel; the camera and the seabed are
        framed on the whole run; the first configuration is shown.

        Args:
            t: times (N,) [s], non-decreasing.
            q: configurations (N, nq).
            speed: the page's playback speed, simulated seconds per wall-clock second.
        """
        qs = as_configurations(self.robot, q)
        times = check_times(t, len(qs))
        if not (speed > 0 and math.isfinite(speed)):
            raise UVMSError(f"speed must be finite and > 0, got speed={speed}")
        if self.playback is None:
            self.playback = Playback(self.server, self._show_time, speed)
        else:
            self.playback.pause()
            self.playback.speed_input.value = float(speed)
        self._trajectory = (times, qs)
        self.frame(qs)
        self.playback.load(times)

    def play(self, t: np.ndarray, q: np.ndarray, *, speed: float = 1.0, fps: float = 30.0,
             progress: bool | None = None) -> None:
        """Play configurations q (N, nq) at times t (N,) [s]; returns when the last one is shown.

        Returns earlier when the page's Pause button is pressed. The run then stays in the page: its
        time slider scrubs through it, Play plays it again.

        Args:
            t: times (N,) [s], non-decreasing.
            q: configurations (N, nq).
            speed: simulated seconds per wall-clock second.
            fps: frames shown per wall-clock second.
            progress: progress bar (None: only on a terminal).
        """
        if not (fps > 0 and math.isfinite(fps)):
            raise UVMSError(f"speed and fps must be finite and > 0, got speed={speed}, fps={fps}")
        self.load(t, q, speed=speed)
        self.playback.run(speed, fps, progress)

    def close(self) -> None:
        """Stop the playback and the server."""
        if self.playback is not None:
            self.playback.pause()
        self.server.stop()

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Viewer({self.robot.name!r}, {self.url})"


def view(robot: Robot, q: np.ndarray | None = None, *, port: int = DEFAULT_PORT, skeleton: bool | None = None,
         open_browser: bool = False) -> Viewer:
    """Show a robot at configuration q (default neutral) in the browser; the server keeps running.

    Args:
        robot: any Robot (loaded, or composed by :func:`uvms.model.mount_arm`).
        q: configuration (nq,).
        port: first port tried, 1..65535 (the next free one is taken when busy), or 0 (any free port); the host
            is always 127.0.0.1.
        skeleton: add the stick geometry (None: only when the model has no visual geometry); meshes are found
            as the robot was loaded (``robot.packages``).
        open_browser: open the page with :mod:`webbrowser`.

    Returns:
        The Viewer (``viewer.url``; ``viewer.close()`` stops it).

    Raises:
        ViewerUnavailable: viser is not installed (``pip install uvms[viz]``).
        ViewerInputError: a port outside 0..65535.
        ConfigurationError: bad q.
    """
    viewer = Viewer(robot, q, port=port, skeleton=skeleton)
    if open_browser:
        import webbrowser

        webbrowser.open(viewer.url)
    return viewer


def play(robot: Robot, t: np.ndarray, q: np.ndarray, *, speed: float = 1.0, fps: float = 30.0,
         viewer: Viewer | None = None, port: int = DEFAULT_PORT, progress: bool | None = None) -> Viewer:
    """Animate configurations q (N, nq) at times t (N,) [s] (e.g. a run's ``trajectory.npz``) in the browser.

    Blocks while playing (``(t[-1] - t[0]) / speed`` seconds), then leaves the viewer running with a
    time slider.

    Args:
        robot: the robot of the run.
        t, q: times [s] and configurations.
        speed: simulated seconds per wall-clock second.
        fps: frames per wall-clock second.
        viewer: an open Viewer of ``robot`` to reuse (default: a new one on ``port``).
        progress: progress bar (None: only on a terminal).

    Returns:
        The Viewer.
    """
    owned = viewer is None
    viewer = viewer or Viewer(robot, port=port)
    try:
        viewer.play(t, q, speed=speed, fps=fps, progress=progress)
    except BaseException:
        if owned:
            viewer.close()
        raise
    return viewer
