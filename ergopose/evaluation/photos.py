"""Real photographs of people warped into a ceiling fisheye camera (evaluation only).

Issue 14's photo test: a photograph that ships inside an installed package is taken as the image
of a pinhole camera and re-rendered, by a pure rotation about that camera's centre, into a
virtual **equidistant fisheye** camera looking straight down from the ceiling. The rendered
fisheye image holds exactly the photo's rays, so a stage whose person view were the photo's own
camera would see the photo again; what the 2D stage adds to the network on the photo is what
this measures.

The scene (camera frame of the fisheye: x right, y down in the image, z the lens axis, pointing
at the floor; world z up):

* the photo's pinhole has its principal point at the centre of the body the network finds in
  the photo (the middle of the box around its confident keypoints) and a focal length that puts
  the body ``distance`` metres from the camera: the photo's shoulder width (from the network on
  the photo) is taken as ``shoulder_width`` metres (0.40 m, an adult's), so
  ``focal = shoulders_px * distance / shoulder_width``;
* the body centre lies ``off_axis`` radians from the fisheye's axis, in the image direction
  ``direction`` (radians from image +x towards image +y);
* the photo's "up" at the body centre turns to the world's up there, so the person stands upright
  in the world: under a ceiling fisheye their head points away from the image centre, as a
  standing person's does.

The image is ``width`` x ``height`` pixels at ``px_per_rad`` (r = f theta), centred on the lens
axis, with a 180-degree image circle; pixels the photo does not cover are black.

Reference: the same network on the photo itself, placed as MediaPipe places it (the detector on
the photo padded to a square, the landmark network on its crop, then on the crop of its own
alignment points: :func:`ergopose.evaluation.refisheye.reference_pose`). Scored keypoints: those
of the 33 the reference gives with confidence >= 0.5 inside the photo (a half-body photo scores
the keypoints it shows). Torso length: shoulder centre to hip centre in the photo when both hips
are scored, else the shoulder width (half-body photos), in photo pixels.

Per case: the stage runs on ``frames`` identical frames (the first frame searches, the next ones
follow) and the last frame is scored. Found: a detection whose scored keypoints, mapped back to
photo pixels through the known warp, have their centre within 0.5 torso lengths of the
reference's; error: the median over the scored keypoints of the distance to the reference, in
torso lengths (the closest such detection). Two more references tell apart what is the
network's own: the network on the photo shrunk to the fisheye's pixel density at the body
(:func:`reference_at_density`; the stage's views can be no sharper) and with upright crops
(:func:`upright_reference`; the stage's views are rolled at most ``max_body_roll`` from upright).

Run: ``python -m ergopose.evaluation.photos --out table.md``. This module imports the product;
the product never imports it.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Sequence

import cv2
import numpy as np

from ergopose import atomic
from ergopose.evaluation.refisheye import reference_pose
from ergopose.geometry.camera import Camera, ceiling_rotation
from ergopose.geometry.image_circle import LEVEL_ROTATION
from ergopose.geometry.lenses.equidistant import Equidistant
from ergopose.geometry.lenses.rectilinear import Rectilinear
from ergopose.geometry.views import build_map
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.models import DEFAULT_LANDMARK_MODEL
from ergopose.pose.settings import PoseSettings


@dataclass(frozen=True)
class PackagedPhoto:
    """A photograph of a person that ships inside a Python package.

    name: short label; package: the distribution (PyPI name); module: its import name;
    path: the file inside the module's folder; licence: the licence of the picture and where the
    package says so; body: what the photo shows of the body.
    """

    name: str
    package: str
    module: str
    path: str
    licence: str
    body: str


PHOTOS: tuple[PackagedPhoto, ...] = (
    PackagedPhoto(
        "astronaut",
        "scikit-image",
        "skimage",
        "data/astronaut.png",
        "public domain (NASA photograph of Eileen Collins; skimage.data.astronaut's docstring: "
        "'No known copyright restrictions, released into the public domain')",
        "head to chest, arms to the elbows",
    ),
    PackagedPhoto(
        "camera",
        "scikit-image",
        "skimage",
        "data/camera.png",
        "CC0 (skimage.data.camera's docstring: 'No copyright restrictions. CC0 by the photographer (Lav Varshney)')",
        "a man bent over a camera on a tripod, head to thighs, seen from the side",
    ),
)


def photo_file(photo: PackagedPhoto) -> Path | None:
    """The photo's file in the installed package, or None when the package is not installed.
    The package is located without being imported (only its data file is read)."""
    spec = importlib.util.find_spec(photo.module)
    if spec is None:
        return None
    places = list(spec.submodule_search_locations or [])
    if spec.origin and spec.origin not in ("namespace", "built-in"):
        places.insert(0, str(Path(spec.origin).parent))
    for place in places:
        path = Path(place) / photo.path
        if path.is_file():
            return path
    return None


def read_photo(path: Path) -> np.ndarray:
    """The photo as a BGR uint8 image (grey photos get three equal channels)."""
    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise ValueError(f"cannot read {path}")
    return image


# --------------------------------------------------------------------------------------------
# The reference: the network on the photo

SHOULDERS = np.array([JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]])
HIPS = np.array([JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]])
MIN_CONFIDENCE = 0.5


@dataclass(frozen=True)
class PhotoReference:
    """The network on the photo: pixels (33, 2), confidence (33,), scored (33,) bool (confidence
    >= 0.5 and inside the photo), centre (2,) of the box around the scored keypoints, torso_px
    and torso_kind ("torso": shoulder centre to hip centre; "shoulders": shoulder width, when the
    hips are not scored), shoulders_px (shoulder width)."""

    pixels: np.ndarray
    confidence: np.ndarray
    scored: np.ndarray
    centre: np.ndarray
    torso_px: float
    torso_kind: str
    shoulders_px: float


def photo_reference(image: np.ndarray, detector, landmarker) -> PhotoReference | None:
    """The network on the photo (None when it finds nobody or not both shoulders)."""
    found = reference_pose(image, detector, landmarker)
    if found is None:
        return None
    pixels, confidence = found
    h, w = image.shape[:2]
    inside = (
        np.isfinite(pixels).all(axis=1)
        & (pixels[:, 0] >= 0)
        & (pixels[:, 0] <= w - 1)
        & (pixels[:, 1] >= 0)
        & (pixels[:, 1] <= h - 1)
    )
    scored = inside & (confidence >= MIN_CONFIDENCE)
    if not scored[SHOULDERS].all():
        return None
    shoulders = float(np.linalg.norm(pixels[SHOULDERS[0]] - pixels[SHOULDERS[1]]))
    if scored[HIPS].all():
        torso = float(np.linalg.norm(pixels[SHOULDERS].mean(0) - pixels[HIPS].mean(0)))
        kind = "torso"
    else:
        torso, kind = shoulders, "shoulders"
    pts = pixels[scored]
    centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    return PhotoReference(pixels, confidence, scored, centre, torso, kind, shoulders)


# --------------------------------------------------------------------------------------------
# The warp


@dataclass(frozen=True)
class PhotoFisheye:
    """A photo rendered into a virtual ceiling fisheye.

    camera: the fisheye camera (equidistant lens, looking straight down from ``camera_height``);
    image: the rendered frame (BGR); photo_lens: the photo's pinhole; rotation_photo_from_cam:
    rays_photo = R @ rays_cam.
    """

    camera: Camera
    image: np.ndarray
    photo_lens: Rectilinear
    rotation_photo_from_cam: np.ndarray

    def photo_pixels(self, rays_cam: np.ndarray) -> np.ndarray:
        """(..., 3) rays in the fisheye's frame -> (..., 2) photo pixels (NaN behind the photo)."""
        return self.photo_lens.project(np.asarray(rays_cam, dtype=np.float64) @ self.rotation_photo_from_cam.T)

    def fisheye_pixels(self, photo_px: np.ndarray) -> np.ndarray:
        """(..., 2) photo pixels -> (..., 2) fisheye pixels."""
        rays = self.photo_lens.unproject(np.asarray(photo_px, dtype=np.float64)) @ self.rotation_photo_from_cam
        return self.camera.lens.project(rays)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def warp_photo(
    photo: np.ndarray,
    centre_px: np.ndarray,
    focal_px: float,
    off_axis: float,
    direction: float,
    px_per_rad: float,
    size: tuple[int, int],
    camera_height: float = 3.0,
    whole_image: bool = False,
) -> PhotoFisheye:
    """Render ``photo`` into a ceiling fisheye (module docstring): the photo pixel ``centre_px``
    lands ``off_axis`` radians from the lens axis in image direction ``direction`` (radians from
    image +x towards +y), the photo's up there along the world's up.

    The map is built over the box of fisheye pixels the photo can light (:func:`_footprint`; a
    quarter of the time of a 2048 x 2048 case went to the whole image's map), the rest stays
    black; ``whole_image`` builds it over every pixel. Both give the same image to the bit: the
    box's lens is the fisheye's with its principal point moved by whole pixels (tested)."""
    width, height = int(size[0]), int(size[1])
    cx, cy = (width - 1) / 2.0, (height - 1) / 2.0
    lens = Equidistant(px_per_rad, px_per_rad, cx, cy)
    rotation = ceiling_rotation(0.0)
    camera = Camera(
        "photo_fisheye",
        lens,
        width,
        height,
        rotation,
        np.array([0.0, 0.0, camera_height]),
        image_circle=(cx, cy, px_per_rad * math.pi / 2.0),
    )
    body = np.array(
        [math.sin(off_axis) * math.cos(direction), math.sin(off_axis) * math.sin(direction), math.cos(off_axis)]
    )
    up_cam = rotation.T @ np.array([0.0, 0.0, 1.0])
    up_here = _unit(up_cam - body * (up_cam @ body))
    # The photo's frame in the fisheye's: its axis through the body centre, its image down
    # against the world's up there, x = y cross z.
    y = -up_here
    x = np.cross(y, body)
    cam_from_photo = np.stack([x, y, body], axis=1)
    photo_lens = Rectilinear(float(focal_px), float(focal_px), float(centre_px[0]), float(centre_px[1]))
    box = (0, 0, width, height) if whole_image else _footprint(photo.shape, photo_lens, cam_from_photo, camera)
    x0, y0, x1, y1 = box
    image = np.zeros((height, width) + photo.shape[2:], photo.dtype)
    if x1 > x0 and y1 > y0:
        box_lens = Equidistant(px_per_rad, px_per_rad, cx - x0, cy - y0)
        view_map = build_map(box_lens, (x1 - x0, y1 - y0), photo_lens, cam_from_photo.T)
        image[y0:y1, x0:x1] = view_map.apply(photo, exact=True)
    return PhotoFisheye(camera, image, photo_lens, cam_from_photo.T)


def _footprint(
    shape: tuple[int, ...], photo_lens: Rectilinear, cam_from_photo: np.ndarray, camera: Camera, margin: int = 2
) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1): the fisheye pixels [x0, x1) x [y0, y1) that bilinear sampling of a photo
    of this shape can light: the box around the image of the photo's border, widened by a photo
    pixel (the sampling blends the edge with the black beyond) and ``margin`` fisheye pixels (the
    border is sampled at 257 points a side). The whole image where a border point has no
    fisheye pixel."""
    h, w = int(shape[0]), int(shape[1])
    t = np.linspace(0.0, 1.0, 257)
    left, right, top, bottom = -1.5, w + 0.5, -1.5, h + 0.5
    xs, ys = left + (right - left) * t, top + (bottom - top) * t
    border_photo = np.concatenate(
        [
            np.stack([xs, np.full_like(xs, top)], axis=1),
            np.stack([xs, np.full_like(xs, bottom)], axis=1),
            np.stack([np.full_like(ys, left), ys], axis=1),
            np.stack([np.full_like(ys, right), ys], axis=1),
        ]
    )
    border_fisheye = camera.lens.project(photo_lens.unproject(border_photo) @ cam_from_photo.T)
    if not np.isfinite(border_fisheye).all():
        return 0, 0, camera.width, camera.height
    lo = np.floor(border_fisheye.min(axis=0)).astype(int) - margin
    hi = np.ceil(border_fisheye.max(axis=0)).astype(int) + margin + 1
    x0, y0 = max(0, int(lo[0])), max(0, int(lo[1]))
    x1, y1 = min(camera.width, int(hi[0])), min(camera.height, int(hi[1]))
    return x0, y0, max(x0, x1), max(y0, y1)


# --------------------------------------------------------------------------------------------
# One case


@dataclass(frozen=True)
class Case:
    photo: str
    off_axis_deg: float
    direction_deg: float
    px_per_rad: float
    width: int
    height: int


#: The pixel densities and image sizes measured: the rig's (2048 x 2048, about 620 px/rad) and a
#: 1024 x 768 camera's (250 px/rad).
DENSITIES: tuple[tuple[float, int, int], ...] = ((620.0, 2048, 2048), (250.0, 1024, 768))
ANGLES_DEG = (20.0, 50.0, 80.0)
DIRECTIONS_DEG = tuple(float(d) for d in range(0, 360, 45))


def cases(photos: Sequence[str], angles=ANGLES_DEG, directions=DIRECTIONS_DEG, densities=DENSITIES) -> list[Case]:
    return [Case(p, a, d, rho, w, h) for p in photos for rho, w, h in densities for a in angles for d in directions]


def score(reference: PhotoReference, warped: PhotoFisheye, detections, same_density: np.ndarray | None = None) -> dict:
    """found, error (median, torso lengths; NaN when not found), errors per scored keypoint,
    people (the stage's count); with ``same_density`` ((33, 2) photo pixels: the network on the
    photo at the fisheye's pixel density), error_same_density: the same median against it."""
    out = {
        "found": False,
        "error": float("nan"),
        "errors": [],
        "people": int(detections.count),
        "error_same_density": float("nan"),
    }
    if detections.count == 0:
        return out
    scored = np.nonzero(reference.scored)[0]
    px = warped.photo_pixels(detections.rays_cam[:, scored])  # (N, K, 2)
    ref = reference.pixels[scored]
    centre = np.nanmean(px, axis=1)
    offset = np.linalg.norm(centre - ref.mean(axis=0), axis=1) / reference.torso_px
    offset = np.where(np.isfinite(offset), offset, np.inf)
    i = int(np.argmin(offset))
    if not offset[i] <= 0.5:
        return out
    err = np.linalg.norm(px[i] - ref, axis=1) / reference.torso_px
    err = np.where(np.isfinite(err), err, np.inf)
    out.update(found=True, error=float(np.median(err)), errors=[float(e) for e in err])
    if same_density is not None:
        e2 = np.linalg.norm(px[i] - same_density[scored], axis=1) / reference.torso_px
        out["error_same_density"] = float(np.median(np.where(np.isfinite(e2), e2, np.inf)))
    return out


def focal_px(reference: PhotoReference, distance: float = 3.0, shoulder_width: float = 0.40) -> float:
    """The photo's focal length (pixels) that puts the body ``distance`` metres away."""
    return reference.shoulders_px * distance / shoulder_width


def reference_at_density(photo: np.ndarray, detector, landmarker, scale: float) -> np.ndarray | None:
    """The network on the photo shrunk by ``scale`` (< 1: the pixel density the fisheye gives
    the body, px_per_rad / focal), its keypoints in the full photo's pixels ((33, 2); None when
    it finds nobody). Tells the loss of resolution apart from what the stage adds."""
    if scale >= 1.0:
        found = reference_pose(photo, detector, landmarker)
        return None if found is None else found[0]
    h, w = photo.shape[:2]
    small = cv2.resize(photo, (max(1, round(w * scale)), max(1, round(h * scale))), interpolation=cv2.INTER_AREA)
    found = reference_pose(small, detector, landmarker)
    if found is None:
        return None
    sx, sy = w / small.shape[1], h / small.shape[0]
    return (found[0] + 0.5) * np.array([sx, sy]) - 0.5


def upright_reference(photo: np.ndarray, detector, landmarker) -> np.ndarray | None:
    """The network on the photo with every crop upright (the photo's own up) instead of turned
    to the body axis: (33, 2) pixels, or None. Against the main reference it shows how much the
    network's keypoints move with the crop's orientation alone."""
    h, w = photo.shape[:2]
    level = Camera(
        "photo",
        Rectilinear(float(max(w, h)), float(max(w, h)), (w - 1) / 2.0, (h - 1) / 2.0),
        w,
        h,
        LEVEL_ROTATION,
        np.array([0.0, 0.0, 1.5]),
    )
    found = reference_pose(photo, detector, landmarker, level)
    return None if found is None else found[0]


def median_error(reference: PhotoReference, pixels: np.ndarray | None) -> float:
    """Median distance (torso lengths) of ``pixels`` to the reference over its scored keypoints."""
    if pixels is None:
        return float("nan")
    e = np.linalg.norm(pixels[reference.scored] - reference.pixels[reference.scored], axis=1) / reference.torso_px
    return float(np.median(np.where(np.isfinite(e), e, np.inf)))


def run_case(
    case: Case,
    photo: np.ndarray,
    reference: PhotoReference,
    landmarker,
    detector,
    frames: int = 5,
    distance: float = 3.0,
    shoulder_width: float = 0.40,
    settings: PoseSettings | None = None,
    same_density: np.ndarray | None = None,
) -> dict:
    """The stage on ``frames`` identical warped frames; the last one scored (see :func:`score`;
    same_density: :func:`reference_at_density` at this case's density)."""
    focal = focal_px(reference, distance, shoulder_width)
    warped = warp_photo(
        photo,
        reference.centre,
        focal,
        math.radians(case.off_axis_deg),
        math.radians(case.direction_deg),
        case.px_per_rad,
        (case.width, case.height),
    )
    if settings is None:
        settings = PoseSettings().with_gates(landmarker.card.gates)
    stage = FisheyePoseEstimator(warped.camera, 0, landmarker, detector, settings)
    t0 = time.perf_counter()
    found = None
    for f in range(frames):
        found = stage.process(warped.image, f)
    seconds = time.perf_counter() - t0
    out = score(reference, warped, found, same_density)
    out.update(
        photo=case.photo,
        off_axis_deg=case.off_axis_deg,
        direction_deg=case.direction_deg,
        px_per_rad=case.px_per_rad,
        width=case.width,
        height=case.height,
        seconds=seconds,
        torso_kind=reference.torso_kind,
        keypoints=int(reference.scored.sum()),
        body_px=float(np.ptp(warped.fisheye_pixels(reference.pixels[reference.scored]), axis=0).max()),
        in_frame=int(warped.camera.in_image(warped.fisheye_pixels(reference.pixels[reference.scored])).sum()),
    )
    return out


def render(rows: list[dict]) -> str:
    """The case table (markdown) and a summary line per photo and density."""
    lines = [
        "| photo | px/rad (image) | off axis | direction | found | median error (torso lengths) | "
        "against the photo at the fisheye's density | body size (px) | scored keypoints in the frame |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['photo']} | {r['px_per_rad']:g} ({r['width']}x{r['height']}) | {r['off_axis_deg']:g} deg | "
            f"{r['direction_deg']:g} deg | {'yes' if r['found'] else 'NO'} | "
            f"{r['error']:.3f} | {r.get('error_same_density', float('nan')):.3f} | {r['body_px']:.0f} | "
            f"{r.get('in_frame', r['keypoints'])} of {r['keypoints']} |"
        )
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m ergopose.evaluation.photos", description=__doc__.split("\n")[0])
    p.add_argument("--photos", default=",".join(x.name for x in PHOTOS))
    p.add_argument("--angles", default=",".join(f"{a:g}" for a in ANGLES_DEG), help="degrees off the lens axis")
    p.add_argument("--directions", default=",".join(f"{a:g}" for a in DIRECTIONS_DEG), help="image directions, degrees")
    p.add_argument("--frames", type=int, default=5)
    p.add_argument("--distance", type=float, default=3.0, help="metres from the camera to the body")
    p.add_argument("--model", default=DEFAULT_LANDMARK_MODEL)
    p.add_argument("--model-dir", default=None)
    p.add_argument(
        "--setting",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a PoseSettings field changed (a number, radians for angles, or true/false), "
        "e.g. body_margin=1.6 or merge_prefers_upright=false",
    )
    p.add_argument("--out", type=Path, required=True, help="markdown table; the rows go to OUT.json")
    a = p.parse_args(argv)
    changes: dict[str, Any] = {}
    for item in a.setting:
        key, _, value = item.partition("=")
        if key not in PoseSettings.__dataclass_fields__:
            print(f"--setting: no PoseSettings field {key!r}", file=sys.stderr)
            return 2
        default = getattr(PoseSettings(), key)
        if isinstance(default, bool):
            changes[key] = value.strip().lower() in ("1", "true", "yes")
        elif isinstance(default, int):
            changes[key] = int(value)
        else:
            changes[key] = float(value)
    cv2.setNumThreads(1)
    det = BlazePoseDetector(model_dir=a.model_dir, num_threads=1)
    lm = BlazePoseLandmarker(model=a.model, model_dir=a.model_dir, num_threads=1)
    settings = replace(PoseSettings().with_gates(lm.card.gates), **changes)
    by_name = {x.name: x for x in PHOTOS}
    rows: list[dict] = []
    notes: list[str] = []
    t0 = time.time()
    for name in a.photos.split(","):
        path = photo_file(by_name[name])
        if path is None:
            print(f"{name}: package {by_name[name].package} is not installed", file=sys.stderr)
            return 2
        image = read_photo(path)
        ref = photo_reference(image, det, lm)
        if ref is None:
            print(f"{name}: the network finds nobody with both shoulders in the photo", file=sys.stderr)
            return 2
        same = {rho: reference_at_density(image, det, lm, rho / focal_px(ref, a.distance)) for rho, _, _ in DENSITIES}
        notes.append(
            f"{name}: {image.shape[1]}x{image.shape[0]} px, {ref.scored.sum()} keypoints scored, torso length "
            f"({ref.torso_kind}) {ref.torso_px:.0f} px, focal {focal_px(ref, a.distance):.0f} px; the network "
            f"on the photo with upright crops: {median_error(ref, upright_reference(image, det, lm)):.3f}; "
            "on the photo shrunk to each density: "
            + ", ".join(f"{rho:g} px/rad {median_error(ref, same[rho]):.3f}" for rho in same)
        )
        print(notes[-1], file=sys.stderr)
        for case in cases([name], [float(x) for x in a.angles.split(",")], [float(x) for x in a.directions.split(",")]):
            r = run_case(
                case, image, ref, lm, det, a.frames, a.distance, settings=settings, same_density=same[case.px_per_rad]
            )
            rows.append(r)
            print(
                f"[{time.time() - t0:.0f} s] {name} {case.px_per_rad:g} px/rad {case.off_axis_deg:g} deg "
                f"dir {case.direction_deg:g}: found {r['found']} error {r['error']:.3f} "
                f"({r['people']} people, {r['seconds']:.1f} s)",
                file=sys.stderr,
                flush=True,
            )
    text = render(rows) + "\n" + "\n".join(f"- {n}" for n in notes) + "\n"
    atomic.write_text(a.out, text)
    atomic.write_text(a.out.with_suffix(".json"), json.dumps(rows, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
