"""The simulated evaluation area: two ceiling fisheye cameras over a 6 x 6 m workplace.

The layout follows the paper's evaluation (Heindl et al. 2018, section "Evaluation and results"):
a 6 x 6 m working area, two 180-degree fisheye cameras on the ceiling 3 m above the floor with a
baseline of about 1.5 m, 12 frames per second, shelves that often hide parts of the workers.
Everything here is geometry in the world frame (metres, floor z = 0, z up); the area spans
x, y in [-3, 3] with the cameras near the middle.

- Furniture is a set of axis-aligned boxes (:class:`Box`): shelves (solid, 1.6-1.9 m high),
  work tables (a top and four legs, so legs under a table stay visible), pallets with cartons.
- Reference bars (:class:`ReferenceBar`): straight 1.5 m bars with red end caps, placed where the
  two cameras see them in different regions of the lens (central, outer, edge), for the
  calibration check and the evaluation (the paper measured a 1.5 m object the same way).
- Stations (:class:`Station`): where a worker stands for a task, facing the furniture.

The lens: Kannala-Brandt with the distortion coefficients of a real wide fisheye (the TUM VI
dataset's cam0, a 195-degree lens: k1..k4 = 0.00348, 0.000715, -0.00205, 0.000203, Schubert et
al. 2018), scaled so that 95 degrees off-axis lies just inside the short side of the image: the
whole image circle is in the picture, the corners are black.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ergopose.geometry.camera import Camera, ceiling_rotation
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt
from ergopose.geometry.regions import DEFAULT_LIMITS_DEG, region_index, region_table

#: Half the side of the square work area (metres): the area is [-3, 3] x [-3, 3].
AREA_HALF = 3.0
#: The paper's frame rate.
DEFAULT_FPS = 12.0
#: The paper's camera resolution (Axis M3007-PV).
PAPER_SIZE = (2592, 1944)
#: The default simulated resolution: the paper's aspect ratio at 40 % of its width; people stay
#: large enough for the pose network in 256 x 256 views (docs/simulator.md has the measurement).
DEFAULT_SIZE = (1024, 768)
#: Distortion of a real 195-degree fisheye lens (TUM VI cam0, Kannala-Brandt k1..k4).
LENS_COEFFICIENTS = (0.0034823894, 0.0007150348, -0.0020532361, 0.0002029367)
#: The angle off the lens axis that lands on the short side of the image (radians).
IMAGE_CIRCLE_THETA = math.radians(95.0)

#: Lens regions for per-region statistics (angle from the lens axis, degrees): central below 30,
#: outer 30-55, edge above 55. ergopose's choice: the paper splits the field of view into three
#: rings without giving their limits; floor points of the 6 x 6 m area lie within about 58 degrees.
LENS_REGIONS_DEG = region_table(DEFAULT_LIMITS_DEG)


def lens_region(theta: np.ndarray) -> np.ndarray:
    """Angle from the lens axis (radians, any shape) -> region index into LENS_REGIONS_DEG (-1 for NaN)."""
    return region_index(np.degrees(np.asarray(theta, dtype=np.float64)), DEFAULT_LIMITS_DEG)


@dataclass(frozen=True)
class Box:
    """An axis-aligned box of furniture: lo and hi corners (metres, world), kind and colour.

    kind: "shelf", "table_top", "table_leg", "pallet", "carton", "post" (the renderer picks the
    surface pattern from it). colour: base colour, BGR 0-255.
    """

    name: str
    kind: str
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    colour: tuple[int, int, int]

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "kind": self.kind,
            "lo": list(self.lo),
            "hi": list(self.hi),
            "colour_bgr": list(self.colour),
        }


@dataclass(frozen=True)
class ReferenceBar:
    """A straight bar of known length between two world points (its end-cap centres).

    intended_region: the lens region the placement was chosen for (see LENS_REGIONS_DEG); the
    actual angles per camera are in the scene description of a simulated session.
    radius: half the bar's thickness (metres).
    """

    name: str
    end_a: tuple[float, float, float]
    end_b: tuple[float, float, float]
    intended_region: str
    radius: float = 0.02

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.subtract(self.end_b, self.end_a)))

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "end_a": list(self.end_a),
            "end_b": list(self.end_b),
            "length_m": round(self.length, 9),
            "radius_m": self.radius,
            "intended_region": self.intended_region,
        }


@dataclass(frozen=True)
class Station:
    """A place where a worker stands for a task.

    position: (x, y) of the worker's mid-hip point over the floor; heading: the direction the
    worker faces (radians, counter-clockwise from world +x). tasks: the tasks done here.
    work_height: height (metres) of the surface worked on (shelf board, table top, pallet load).
    """

    name: str
    position: tuple[float, float]
    heading: float
    tasks: tuple[str, ...]
    work_height: float

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "position": list(self.position),
            "heading_deg": round(math.degrees(self.heading), 6),
            "tasks": list(self.tasks),
            "work_height_m": self.work_height,
        }


@dataclass(frozen=True)
class Scene:
    """Furniture, reference bars and stations of the work area (world frame, metres)."""

    boxes: tuple[Box, ...]
    bars: tuple[ReferenceBar, ...]
    stations: tuple[Station, ...]
    area: tuple[float, float, float, float] = (-AREA_HALF, AREA_HALF, -AREA_HALF, AREA_HALF)
    #: Boxes lower than this do not block walking (bars and mats).
    walk_over_height: float = field(default=0.05)

    def obstacles_xy(self) -> np.ndarray:
        """(n, 4) footprints (xmin, ymin, xmax, ymax) of the boxes a worker cannot walk through."""
        rows = [(b.lo[0], b.lo[1], b.hi[0], b.hi[1]) for b in self.boxes if b.hi[2] > self.walk_over_height]
        return np.array(rows, dtype=np.float64).reshape(-1, 4)

    def station(self, name: str) -> Station:
        for s in self.stations:
            if s.name == name:
                return s
        raise KeyError(f"no station {name!r}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "area_m": list(self.area),
            "boxes": [b.to_dict() for b in self.boxes],
            "reference_bars": [b.to_dict() for b in self.bars],
            "stations": [s.to_dict() for s in self.stations],
        }


def _table(name: str, x0: float, y0: float, x1: float, y1: float, height: float = 0.9) -> list[Box]:
    top = 0.04
    leg = 0.05
    wood = (92, 128, 168)
    metal = (70, 70, 76)
    boxes = [Box(f"{name}_top", "table_top", (x0, y0, height - top), (x1, y1, height), wood)]
    for k, (lx, ly) in enumerate(((x0, y0), (x1 - leg, y0), (x0, y1 - leg), (x1 - leg, y1 - leg))):
        boxes.append(Box(f"{name}_leg{k + 1}", "table_leg", (lx, ly, 0.0), (lx + leg, ly + leg, height - top), metal))
    return boxes


def default_scene() -> Scene:
    """The evaluation area used by ``ergopose simulate`` (fixed layout; workers vary with the seed).

    Cameras sit at about (-0.75, 0) and (0.75, 0). Shelves stand along the north and east walls
    and as a free-standing double-sided unit in the west half (it hides workers from one camera
    or the other), tables in the south and next to camera 2, a pallet with cartons in the
    south-east corner.
    """
    shelf_blue = (150, 96, 40)
    shelf_grey = (120, 124, 128)
    boxes: list[Box] = [
        Box("shelf_north", "shelf", (-2.4, 2.45, 0.0), (-0.4, 2.95, 1.9), shelf_blue),
        Box("shelf_east", "shelf", (2.45, -0.9, 0.0), (2.95, 1.3, 1.8), shelf_grey),
        Box("shelf_island", "shelf", (-2.15, -1.3, 0.0), (-1.65, 0.7, 1.6), shelf_blue),
        *_table("table_south", -0.6, -2.85, 1.1, -2.15),
        *_table("table_centre", 0.35, 0.95, 1.45, 1.65),
        Box("pallet", "pallet", (1.95, -2.85, 0.0), (2.85, -1.85, 0.14), (70, 130, 170)),
        Box("carton_1", "carton", (2.0, -2.8, 0.14), (2.4, -2.35, 0.44), (60, 120, 170)),
        Box("carton_2", "carton", (2.45, -2.8, 0.14), (2.8, -2.4, 0.39), (75, 140, 190)),
        Box("carton_3", "carton", (2.1, -2.3, 0.14), (2.5, -1.9, 0.42), (55, 110, 160)),
    ]
    # Reference bars: central (on the floor between the cameras), outer (on the floor further out),
    # edge (on a wall bracket at 1.7 m near the west wall, far off both lens axes).
    bars = (
        ReferenceBar("bar_central", (-0.75, -0.3, 0.02), (0.75, -0.3, 0.02), "central"),
        ReferenceBar("bar_outer", (0.6, 2.4, 0.02), (2.1, 2.4, 0.02), "outer"),
        ReferenceBar("bar_edge", (-2.9, -2.95, 1.7), (-1.4, -2.95, 1.7), "edge"),
    )
    boxes += [
        Box("bar_edge_bracket_1", "post", (-2.9, -3.0, 0.0), (-2.84, -2.94, 1.68), (60, 60, 60)),
        Box("bar_edge_bracket_2", "post", (-1.46, -3.0, 0.0), (-1.4, -2.94, 1.68), (60, 60, 60)),
    ]
    north, east, south, west = math.pi / 2, 0.0, -math.pi / 2, math.pi
    shelf_tasks = ("place_shelf", "reach_overhead", "pick_twist")
    stations = (
        Station("shelf_north_a", (-1.9, 1.95), north, shelf_tasks, 1.45),
        Station("shelf_north_b", (-0.9, 1.95), north, shelf_tasks, 1.25),
        Station("shelf_east_a", (1.95, -0.35), east, shelf_tasks, 1.35),
        Station("shelf_east_b", (1.95, 0.75), east, shelf_tasks, 1.5),
        Station("shelf_island_w", (-2.6, -0.3), east, shelf_tasks, 1.2),
        Station("shelf_island_e", (-1.2, 0.05), west, shelf_tasks, 1.3),
        Station("table_south_a", (-0.2, -1.72), south, ("assembly",), 0.9),
        Station("table_south_b", (0.7, -1.72), south, ("assembly",), 0.9),
        Station("table_centre", (0.9, 0.52), north, ("assembly",), 0.9),
        Station("pallet_w", (1.52, -2.35), east, ("lift_stoop", "lift_squat"), 0.44),
        Station("pallet_n", (2.4, -1.42), south, ("lift_stoop", "lift_squat"), 0.42),
        Station("rest_sw", (-2.4, -2.2), north, ("rest",), 0.0),
        Station("rest_mid", (-0.3, -0.75), east, ("rest",), 0.0),
    )
    return Scene(boxes=tuple(boxes), bars=bars, stations=stations)


# --- the rig ---------------------------------------------------------------------------------------

#: Camera centres (world, metres): about 1.5 m apart, 3 m above the floor, slightly off-level as
#: real ceiling mounts are.
RIG_POSITIONS = ((-0.76, 0.04, 3.0), (0.74, -0.03, 2.98))
#: (yaw, tilt about camera x, tilt about camera y) in degrees per camera.
RIG_ORIENTATIONS_DEG = ((3.0, 1.2, -0.8), (181.5, -0.9, 1.4))
CAMERA_NAMES = ("cam_1", "cam_2")


#: Per camera: focal length scale, fy / fx, principal point offset from the image centre (pixels at
#: 768 rows): two real cameras of the same type never have identical intrinsics.
RIG_INTRINSIC_SPREAD = ((1.0, 1.0004, 1.7, -1.1), (0.997, 1.0007, -2.3, 1.6))


def rig_lens(width: int, height: int, index: int = 0) -> KannalaBrandt:
    """The simulated fisheye lens of camera ``index`` (0 or 1) for an image of width x height pixels.

    The focal length puts IMAGE_CIRCLE_THETA (95 degrees) just inside the short side of the
    image; the principal point sits slightly off the image centre, as in a real camera.
    """
    k1, k2, k3, k4 = LENS_COEFFICIENTS
    t = IMAGE_CIRCLE_THETA
    rd = t * (1 + k1 * t**2 + k2 * t**4 + k3 * t**6 + k4 * t**8)
    f_scale, aspect, dx, dy = RIG_INTRINSIC_SPREAD[index]
    scale = min(width, height) / 768.0
    f = (min(width, height) / 2.0 - 2.0 - 2.0 * scale) / rd * f_scale
    return KannalaBrandt(
        fx=f,
        fy=f * aspect,
        cx=(width - 1) / 2.0 + dx * scale,
        cy=(height - 1) / 2.0 + dy * scale,
        k1=k1,
        k2=k2,
        k3=k3,
        k4=k4,
    )


def _rig_rotation(yaw_deg: float, tilt_x_deg: float, tilt_y_deg: float) -> np.ndarray:
    ax, ay = math.radians(tilt_x_deg), math.radians(tilt_y_deg)
    rx = np.array([[1, 0, 0], [0, math.cos(ax), -math.sin(ax)], [0, math.sin(ax), math.cos(ax)]])
    ry = np.array([[math.cos(ay), 0, math.sin(ay)], [0, 1, 0], [-math.sin(ay), 0, math.cos(ay)]])
    rot = ceiling_rotation(math.radians(yaw_deg)) @ rx @ ry
    u, _, vt = np.linalg.svd(rot)  # exactly orthonormal
    return u @ vt


def rig_cameras(width: int = DEFAULT_SIZE[0], height: int = DEFAULT_SIZE[1]) -> tuple[Camera, Camera]:
    """The two ceiling cameras (cam_1, cam_2) at the given image size, each with its image circle
    (where IMAGE_CIRCLE_THETA lands; the simulator leaves the pixels beyond it dark)."""
    first, second = (
        Camera(
            name=name,
            lens=lens,
            width=width,
            height=height,
            rotation_world_from_cam=_rig_rotation(*orient),
            position_world=np.array(pos),
            image_circle=_image_circle(lens),
        )
        for k, (name, pos, orient) in enumerate(zip(CAMERA_NAMES, RIG_POSITIONS, RIG_ORIENTATIONS_DEG))
        for lens in (rig_lens(width, height, k),)
    )
    return first, second


def _image_circle(lens: KannalaBrandt) -> tuple[float, float, float]:
    """(u, v, radius) of the circle where IMAGE_CIRCLE_THETA lands (the larger of fx, fy: the lit
    region is the ellipse inside it when fx != fy; the circle errs on the side of keeping pixels)."""
    k1, k2, k3, k4 = lens.coefficients
    t = IMAGE_CIRCLE_THETA
    rd = t * (1 + k1 * t**2 + k2 * t**4 + k3 * t**6 + k4 * t**8)
    return (lens.cx, lens.cy, rd * max(lens.fx, lens.fy))
