"""Scene furniture of the browser viewer: the robot's bounding box, the camera framed on it, the seabed grid
under it and the end-effector triads.

Everything here is computed from the model through Pinocchio (geometry placements, frame placements); the
viser calls take a ``viser.ViserServer``, imported by :mod:`uvms.viz.viewer` on first use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ...robot.robot import Robot

#: Camera direction (world, from the look-at point towards the camera): front-right, above.
VIEW_DIRECTION = np.array([1.0, -1.1, 0.65])
#: A planar vehicle moves in the x-y plane: look from higher up.
PLANAR_VIEW_DIRECTION = np.array([0.6, -0.9, 1.3])
#: Vertical field of view of the camera [rad] (viser's default, three.js's 75 deg).
FOV = math.radians(75.0)
#: Narrowest canvas the framing allows for (width / height): the panel docked at the right takes space.
MIN_ASPECT = 1.0
#: The robot's box spans at most this share of the half field of view.
FILL = 0.8
#: At most this many configurations of a run are sampled for its bounding box.
BOX_SAMPLES = 60
SEABED_COLOUR = (214, 200, 160)  # sand
WATER_COLOUR = (200, 225, 245)  # the hemisphere light's sky
GRID_CELL_COLOUR = (170, 160, 130)
GRID_SECTION_COLOUR = (120, 110, 85)
TRIAD_ORIGIN_COLOUR = (255, 128, 13)  # the orange of the skeleton's end effectors


def nice_step(length: float) -> float:
    """The 1-2-5 x 10^k number closest to (not above) ``length`` [m]."""
    exponent = math.floor(math.log10(length))
    for mantissa in (5.0, 2.0, 1.0):
        if mantissa * 10.0 ** exponent <= length:
            return mantissa * 10.0 ** exponent
    return 10.0 ** exponent


def box_corners(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """The 8 corners (8, 3) of the axis-aligned box lower (3,) .. upper (3,)."""
    bits = (np.arange(8)[:, None] >> np.arange(3)) & 1  # (8, 3): corner k takes upper on axis a when bit a is set
    return np.where(bits == 1, np.asarray(upper, float), np.asarray(lower, float))


def _local_boxes(visual: pin.GeometryModel) -> list[np.ndarray | None]:
    """The 8 corners (8, 3) [m] of each geometry's axis-aligned box in its own frame (None: no box known)."""
    corners = []
    for item in visual.geometryObjects:
        try:
            item.geometry.computeLocalAABB()
            box = item.geometry.aabb_local
            lower, upper = np.array(box.min_), np.array(box.max_)
        except (AttributeError, RuntimeError):
            corners.append(None)
            continue
        if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper)) and np.all(upper >= lower)):
            corners.append(None)
            continue
        corners.append(box_corners(lower, upper))
    return corners


def bounding_box(robot: Robot, visual: pin.GeometryModel, configurations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World axis-aligned box around the robot over configurations (N, nq).

    The box holds every corner of every visual geometry's own box (shapes and meshes), every joint origin
    and every end-effector origin. A run of many configurations is sampled (at most :data:`BOX_SAMPLES`,
    the first and last included).

    Returns:
        (lower (3,), upper (3,)) [m], world frame.
    """
    configurations = np.atleast_2d(configurations)
    if len(configurations) > BOX_SAMPLES:
        configurations = configurations[np.unique(np.linspace(0, len(configurations) - 1, BOX_SAMPLES).astype(int))]
    model, data = robot.model, robot.model.createData()
    geometry_data = visual.createData()
    local = _local_boxes(visual)
    ee = [robot.frame_id(name) for name in robot.ee_frames]
    points = []
    for q in configurations:
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        pin.updateGeometryPlacements(model, data, visual, geometry_data)
        points.extend(data.oMi[j].translation.copy() for j in range(1, model.njoints))
        points.extend(data.oMf[f].translation.copy() for f in ee)
        for corners, pose in zip(local, geometry_data.oMg):
            if corners is None:
                points.append(pose.translation.copy())
            else:
                points.extend(corners @ pose.rotation.T + pose.translation)
    if not points:
        return np.zeros(3), np.zeros(3)
    points = np.array(points)  # (P, 3)
    return points.min(axis=0), points.max(axis=0)


@dataclass(frozen=True)
class Framing:
    """Where the camera looks from and at, and where the seabed lies, for a bounding box.

    Attributes:
        look_at: camera target (3,) [m] (the box centre); position: camera position (3,) [m].
        size: characteristic length of the robot [m] (the box diagonal, at least 0.1 m).
        seabed_z: height of the grid [m] (a little below the box); seabed_centre: grid centre (2,) [m].
        seabed_width: side of the square grid [m]; cell: grid cell [m]; section: heavier lines every [m].
    """

    look_at: np.ndarray
    position: np.ndarray
    size: float
    seabed_z: float
    seabed_centre: np.ndarray
    seabed_width: float
    cell: float
    section: float


def framing(lower: np.ndarray, upper: np.ndarray, *, planar: bool = False, fov: float = FOV,
            aspect: float = MIN_ASPECT, fill: float = FILL) -> Framing:
    """Camera and seabed for a world box (lower (3,), upper (3,)) [m].

    The camera (up = world z) looks at the box centre from :data:`VIEW_DIRECTION` (:data:`PLANAR_VIEW_DIRECTION`
    when ``planar``), at the distance where every corner of the box lies within ``fill`` of the half field of
    view: vertically ``fov`` [rad], horizontally that of a canvas of width/height ``aspect``.
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    centre = (lower + upper) / 2
    size = max(float(np.linalg.norm(upper - lower)), 0.1)
    direction = PLANAR_VIEW_DIRECTION if planar else VIEW_DIRECTION
    direction = direction / np.linalg.norm(direction)  # from the target towards the camera
    right = np.cross(-direction, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, -direction)
    corners = box_corners(lower, upper) - centre  # (8, 3)
    tan_v = fill * math.tan(fov / 2)
    tan_h = fill * aspect * math.tan(fov / 2)
    # a corner at offset p is seen at depth D - p.d: it fits when |p.right| <= tan_h (D - p.d), same for up
    distance = float(np.max(np.maximum(np.abs(corners @ right) / tan_h, np.abs(corners @ up) / tan_v)
                            + corners @ direction))
    distance = max(distance, 0.3 * size)
    position = centre + distance * direction
    cell = nice_step(size / 8)
    section = 5 * cell
    extent = float(max(upper[0] - lower[0], upper[1] - lower[1]))
    width = section * math.ceil(max(4 * size, extent + 2 * size) / section)
    centre_xy = section * np.round(centre[:2] / section)
    return Framing(look_at=centre, position=position, size=size, seabed_z=float(lower[2] - 0.03 * size),
                   seabed_centre=centre_xy, seabed_width=width, cell=cell, section=section)


def apply_camera(server, frame: Framing, clients: bool = False) -> None:
    """Set the initial camera of ``server`` (new pages, "Reset View") to ``frame``; also move the cameras
    of the pages already open when ``clients``."""
    server.initial_camera.fov = FOV
    server.initial_camera.near = max(frame.size * 1e-3, 1e-3)
    server.initial_camera.far = max(frame.size * 200, 100.0)
    server.initial_camera.look_at = tuple(frame.look_at)
    server.initial_camera.position = tuple(frame.position)
    if clients:
        for client in server.get_clients().values():
            client.camera.look_at = tuple(frame.look_at)
            client.camera.position = tuple(frame.position)


def add_lighting(server) -> None:
    """Light of open water: a hemisphere light (pale blue above, sand below) instead of viser's city
    environment map (whose reflections mean nothing under water, and which software WebGL takes seconds
    to prepare); viser's default directional lights and their shadows stay."""
    server.scene.configure_environment_map(None)
    server.scene.add_light_hemisphere("/lights/water", sky_color=WATER_COLOUR, ground_color=SEABED_COLOUR,
                                      intensity=1.6)


def add_seabed(server, frame: Framing, name: str = "/seabed"):
    """A sand-coloured grid in the world x-y plane under the robot; returns the viser grid handle."""
    return server.scene.add_grid(
        name, width=frame.seabed_width, height=frame.seabed_width, plane="xy", cell_size=frame.cell,
        section_size=frame.section, cell_color=GRID_CELL_COLOUR, section_color=GRID_SECTION_COLOUR,
        cell_thickness=1.0, section_thickness=1.5, plane_color=SEABED_COLOUR, plane_opacity=0.45,
        shadow_opacity=0.2, fade_distance=3 * frame.seabed_width, fade_from="camera",
        position=(float(frame.seabed_centre[0]), float(frame.seabed_centre[1]), frame.seabed_z))


class EndEffectorTriads:
    """An x-y-z triad (red, green, blue) with its name on every end-effector frame, moved by :meth:`show`.

    Args:
        server: the viser server; robot: the robot; size: robot size [m] (triads are 15 % of it).
    """

    ROOT = "/end_effectors"

    def __init__(self, server, robot: Robot, size: float) -> None:
        self.robot = robot
        self.frame_ids = [robot.frame_id(name) for name in robot.ee_frames]
        length = 0.15 * size
        self.handles = {
            name: server.scene.add_frame(f"{self.ROOT}/{name}", axes_length=length, axes_radius=length / 25,
                                         origin_radius=length / 12, origin_color=TRIAD_ORIGIN_COLOUR)
            for name in robot.ee_frames
        }
        self.labels = {name: server.scene.add_label(f"{self.ROOT}/{name}/label", name, position=(0.0, 0.0, length))
                       for name in robot.ee_frames}

    def show(self, data: pin.Data) -> None:
        """Move the triads to the frame placements of ``data`` (after ``pin.updateFramePlacements``)."""
        for name, frame_id in zip(self.handles, self.frame_ids):
            pose = data.oMf[frame_id]
            handle = self.handles[name]
            handle.position = pose.translation
            handle.wxyz = pin.Quaternion(pose.rotation).coeffs()[[3, 0, 1, 2]]  # Pinocchio stores xyzw
