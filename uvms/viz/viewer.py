"""3-D viewer: a model with its meshes, or a run as an animation, in the browser through Pinocchio's viser viewer.

Optional: ``pip install uvms[viz]`` (viser). The server listens on 127.0.0.1 only; open the printed
URL on the same machine (or through an SSH tunnel, ``ssh -L 8080:127.0.0.1:8080 host``).

The geometry comes from the model's URDF ``<visual>`` elements (mesh URIs resolved as
:func:`uvms.load` does: ``package://`` through ``package_dirs``, ``ROS_PACKAGE_PATH``, ``AMENT_PREFIX_PATH``
and example-robot-data; meshes that cannot be found are left out). A model without visual geometry
(e.g. one composed by :func:`uvms.mount_arm`, which keeps no URDF) is shown as a skeleton: a cylinder per
arm link (parent joint origin -> joint origin), a sphere per joint, and the end effectors in orange.

Without the extra, :mod:`uvms.drawing` draws the same configurations headless (``uvms view --headless OUT``).
"""

from __future__ import annotations

import math
import os
import time
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..model import resources
from .drawing import as_configurations
from ..errors import UVMSError, ViewerUnavailable
from ..robot import Robot
from ..validate import finite_array, time_vector
from ..progress import tqdm


#: The viewer binds to this address only: never to all interfaces.
HOST = "127.0.0.1"
DEFAULT_PORT = 8080
INSTALL_HINT = "the 3-D viewer needs `pip install uvms[viz]` (viser)"
SKELETON_COLOUR = np.array([0.35, 0.35, 0.4, 1.0])
EE_COLOUR = np.array([1.0, 0.5, 0.05, 1.0])


def require_viser():
    """``(viser, ViserVisualizer)``, imported on first use.

    Raises:
        ViewerUnavailable: viser is missing; the message gives the install command.
    """
    try:
        import viser
        from pinocchio.visualize import ViserVisualizer
    except ImportError as exc:
        raise ViewerUnavailable(f"{INSTALL_HINT}: {exc}; or draw headless with uvms.drawing "
                                f"(`uvms view ... --headless OUT.png|OUT.gif`)") from None
    return viser, ViserVisualizer


# ------------------------------------------------------------------ geometry
def resolved_urdf(robot: Robot, package_dirs: Sequence[str | os.PathLike] | None = None) -> tuple[str, list[str]]:
    """The robot's URDF text with every mesh URI made an absolute path; visuals whose mesh is missing removed.

    Returns:
        (URDF text, the mesh URIs that could not be found).
    """
    root = ET.fromstring(robot.urdf)  # a copy of its own: visuals are edited below
    source = Path(robot.source)
    base_dir = source.parent if source.is_file() else None
    roots = resources.package_search_roots(package_dirs)
    missing: list[str] = []
    for link in root.iter("link"):
        for kind in ("visual", "collision"):
            for element in list(link.findall(kind)):
                mesh = element.find("geometry/mesh")
                if mesh is None:
                    continue
                uri = mesh.get("filename", "")
                path = resources.resolve_uri(uri, base_dir, roots)
                if path is None:
                    missing.append(uri)
                    link.remove(element)
                else:
                    mesh.set("filename", str(path.resolve()))
    return ET.tostring(root, encoding="unicode"), sorted(set(missing))


def _align_z(direction: np.ndarray) -> np.ndarray:
    """A rotation whose z axis is the unit vector ``direction``."""
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 0.0, 1.0]), direction).toRotationMatrix()


def skeleton_geometry(robot: Robot, radius: float | None = None) -> pin.GeometryModel:
    """Stick geometry of any model: a cylinder per arm link, a sphere per joint, end effectors in orange.

    Args:
        robot: the robot.
        radius: link radius [m]; default 4 % of the longest link (at least 5 mm).
    """
    import coal  # shipped with the pin wheel

    model = robot.model
    links = [(j, model.jointPlacements[j].translation) for j in range(1, model.njoints) if model.parents[j] > 0]
    ee = [(robot.frame_id(name), name) for name in robot.ee_frames]
    lengths = [np.linalg.norm(d) for _, d in links] + [np.linalg.norm(model.frames[f].placement.translation)
                                                        for f, _ in ee]
    if radius is None:
        radius = max(0.04 * max(lengths, default=0.0), 0.005)
    geometry = pin.GeometryModel()

    def add(name: str, joint: int, placement: pin.SE3, shape, colour: np.ndarray) -> None:
        frame = model.getFrameId(model.names[joint], pin.FrameType.JOINT) if joint > 0 else 0
        item = pin.GeometryObject(name, joint, frame, placement, shape)
        item.meshColor = colour
        geometry.addGeometryObject(item)

    def segment(name: str, joint: int, start: np.ndarray, end: np.ndarray, colour: np.ndarray) -> None:
        offset = end - start
        length = float(np.linalg.norm(offset))
        if length > 1e-6:
            add(name, joint, pin.SE3(_align_z(offset / length), (start + end) / 2),
                coal.Cylinder(radius, length), colour)

    for joint in range(1, model.njoints):
        add(f"skeleton/joint_{model.names[joint]}", joint, pin.SE3.Identity(), coal.Sphere(1.6 * radius),
            SKELETON_COLOUR)
    for joint, offset in links:
        segment(f"skeleton/link_{model.names[joint]}", model.parents[joint], np.zeros(3), offset, SKELETON_COLOUR)
    for frame_id, name in ee:
        frame = model.frames[frame_id]
        placement = frame.placement
        segment(f"skeleton/ee_{name}", frame.parentJoint, np.zeros(3), placement.translation, EE_COLOUR)
        add(f"skeleton/ee_tip_{name}", frame.parentJoint, placement, coal.Sphere(1.8 * radius), EE_COLOUR)
    return geometry


def geometry_models(robot: Robot, package_dirs: Sequence[str | os.PathLike] | None = None,
                    skeleton: bool | None = None) -> tuple[pin.GeometryModel, pin.GeometryModel]:
    """The (visual, collision) geometry models the viewer shows.

    Args:
        robot: the robot.
        package_dirs: extra folders for ``package://`` mesh URIs.
        skeleton: add the stick geometry of :func:`skeleton_geometry`; None: only when the model
            has no visual geometry (no URDF, or a URDF without ``<visual>``).

    Returns:
        The visual model (URDF visuals, plus the skeleton) and the collision model (URDF collisions;
        hidden by the viewer unless asked).

    Warns:
        UserWarning: some meshes cannot be found (they are left out).
    """
    visual, collision = pin.GeometryModel(), pin.GeometryModel()
    if robot.urdf is not None:
        xml, missing = resolved_urdf(robot, package_dirs)
        if missing:
            warnings.warn(f"{robot.source}: {len(missing)} mesh file(s) not found (e.g. {missing[0]!r}); "
                          f"they are not shown", UserWarning, stacklevel=2)
        try:
            visual = pin.buildGeomFromUrdfString(robot.model, xml, pin.GeometryType.VISUAL)
            collision = pin.buildGeomFromUrdfString(robot.model, xml, pin.GeometryType.COLLISION)
        except (RuntimeError, ValueError) as exc:
            warnings.warn(f"{robot.source}: Pinocchio cannot read the geometry ({' '.join(str(exc).split())}); "
                          f"showing the skeleton", UserWarning, stacklevel=2)
            visual, collision = pin.GeometryModel(), pin.GeometryModel()
    if skeleton or (skeleton is None and visual.ngeoms == 0):
        for item in skeleton_geometry(robot).geometryObjects:
            visual.addGeometryObject(item)
    return visual, collision


# ------------------------------------------------------------------ viewer
def check_times(t: np.ndarray, count: int) -> np.ndarray:
    """Times (N,) [s], finite and non-decreasing, one per configuration."""
    return time_vector(finite_array(t, "times (one per configuration)", (count,)), "times", strict=False)


class Viewer:
    """A running viser server on 127.0.0.1 showing one robot through ``pinocchio.visualize.ViserVisualizer``.

    Use as a context manager, or call :meth:`close` to stop the server.

    Attributes:
        robot: the robot shown; visualizer: the ViserVisualizer; server: the ``viser.ViserServer``.
        q: the configuration shown (nq,).
    """

    def __init__(self, robot: Robot, *, port: int = DEFAULT_PORT,
                 package_dirs: Sequence[str | os.PathLike] | None = None, skeleton: bool | None = None) -> None:
        viser, _ = require_viser()
        self.server = viser.ViserServer(host=HOST, port=int(port), verbose=False)  # the next free port if taken
        self._time_slider = None
        self._trajectory: tuple[np.ndarray, np.ndarray] | None = None
        self._playing = False
        try:
            self._show_model(robot, package_dirs, skeleton)
            self.display(robot.neutral())
        except BaseException:
            self.server.stop()
            raise

    def _show_model(self, robot: Robot, package_dirs: Sequence[str | os.PathLike] | None,
                    skeleton: bool | None) -> None:
        _, ViserVisualizer = require_viser()
        visual, collision = geometry_models(robot, package_dirs, skeleton)
        visualizer = ViserVisualizer(robot.model, collision, visual)
        self.server.scene.reset()  # the scene only: the page, its panel and the camera stay
        visualizer.initViewer(viewer=self.server, loadModel=True)
        self.robot, self.visualizer = robot, visualizer

    def reload(self, robot: Robot, q: np.ndarray | None = None, *,
               package_dirs: Sequence[str | os.PathLike] | None = None, skeleton: bool | None = None) -> None:
        """Show another version of the model (e.g. after an edit of its URDF) in place: same page, same camera.

        Args:
            robot: the new robot.
            q: configuration to show (default: the one shown, if it still fits the model, else neutral).
        """
        if q is None:
            q = self.q if len(self.q) == robot.nq else robot.neutral()
        self._trajectory = None  # a run of the old model may no longer fit
        self._show_model(robot, package_dirs, skeleton)
        self.display(q)

    @property
    def url(self) -> str:
        """Address of the viewer page (local machine only)."""
        return f"http://{HOST}:{self.server.get_port()}"

    def display(self, q: np.ndarray) -> None:
        """Show configuration q (nq,)."""
        self.q = self.robot.check_configuration(q)
        self.visualizer.display(self.q)

    def _show_time(self, time_: float) -> int:
        t, qs = self._trajectory
        k = int(min(np.searchsorted(t, time_, side="right") - 1, len(t) - 1))
        self.display(qs[max(k, 0)])
        return max(k, 0)

    def play(self, t: np.ndarray, q: np.ndarray, *, speed: float = 1.0, fps: float = 30.0,
             progress: bool | None = None) -> None:
        """Play configurations q (N, nq) at times t (N,) [s]; returns when the last one is shown.

        A "time [s]" slider in the viewer's panel then scrubs through the run.

        Args:
            t: times (N,) [s], non-decreasing.
            q: configurations (N, nq).
            speed: simulated seconds per wall-clock second.
            fps: frames shown per wall-clock second.
            progress: progress bar (None: only on a terminal).
        """
        qs = as_configurations(self.robot, q)
        times = check_times(t, len(qs))
        if not (speed > 0 and fps > 0 and math.isfinite(speed) and math.isfinite(fps)):
            raise UVMSError(f"speed and fps must be finite and > 0, got speed={speed}, fps={fps}")
        self._trajectory = (times, qs)
        start, end = float(times[0]), float(times[-1])
        step = max((end - start) / 1000, 1e-6)
        if self._time_slider is None:
            self._time_slider = self.server.gui.add_slider("time [s]", min=start, max=max(end, start + step),
                                                           step=step, initial_value=start)

            @self._time_slider.on_update
            def _(_event) -> None:
                if not self._playing and self._trajectory is not None:
                    self._show_time(self._time_slider.value)
        else:
            self._time_slider.min, self._time_slider.max, self._time_slider.step = start, max(end, start + step), step
        frames = max(math.ceil((end - start) / speed * fps), 0) + 1
        self._playing = True
        began = time.perf_counter()
        try:
            for k in tqdm(range(frames), disable=(not progress) if progress is not None else None,
                          desc="playing", leave=False):
                now = min(start + k * speed / fps, end) if k < frames - 1 else end
                self._show_time(now)
                self._time_slider.value = now
                delay = began + (k + 1) / fps - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
        finally:
            self._playing = False

    def close(self) -> None:
        """Stop the server."""
        self.server.stop()

    def __enter__(self) -> Viewer:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Viewer({self.robot.name!r}, {self.url})"


def view(robot: Robot, q: np.ndarray | None = None, *, port: int = DEFAULT_PORT,
         package_dirs: Sequence[str | os.PathLike] | None = None, skeleton: bool | None = None,
         open_browser: bool = False) -> Viewer:
    """Show a robot at configuration q (default neutral) in the browser; the server keeps running.

    Args:
        robot: any Robot (loaded, or composed by :func:`uvms.mount_arm`).
        q: configuration (nq,).
        port: first port tried (the next free one is taken when busy); the host is always 127.0.0.1.
        package_dirs: extra folders for ``package://`` mesh URIs.
        skeleton: add the stick geometry (None: only when the model has no visual geometry).
        open_browser: open the page with :mod:`webbrowser`.

    Returns:
        The Viewer (``viewer.url``; ``viewer.close()`` stops it).

    Raises:
        ViewerUnavailable: viser is not installed (``pip install uvms[viz]``).
        ConfigurationError: bad q.
    """
    viewer = Viewer(robot, port=port, package_dirs=package_dirs, skeleton=skeleton)
    try:
        if q is not None:
            viewer.display(q)
    except BaseException:
        viewer.close()
        raise
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
