"""``ergopose camera show | import | import-opencv | guess``: look at and create calibration files."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import cv2
import numpy as np

from ergopose.errors import ConfigError, InputError
from ergopose.geometry.calibration_file import (
    camera_from_opencv_fisheye,
    LENGTH_UNITS,
    load_calibration,
    read_opencv_fisheye_file,
    read_pose2sim_calibration,
    save_calibration,
    world_frame_warnings,
)
from ergopose.geometry.camera import CalibrationInfo, Camera, ceiling_rotation
from ergopose.geometry.image_circle import (
    NOMINAL_FISHEYE_LENSES,
    NOMINAL_FOV_RANGE,
    CircleSearch,
    find_image_circle,
    max_image,
    nominal_fisheye_camera,
    nominal_max_fov,
)
from ergopose.pipeline.pose_video import circle_from_video
from ergopose.video import probe_video

#: Files ``camera guess`` reads as one still image (anything else is opened as a video).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
DEFAULT_GUESS_HEIGHT_M = 3.0

HELP = """\
Camera calibration files (TOML, docs/calibration-file.md) hold, per camera, the lens model,
the image size and the pose in the work area (metres, floor z = 0, z up)."""

IMPORT_HELP = """\
Add a camera calibrated with OpenCV's fisheye model (cv2.fisheye: camera matrix K and four
coefficients D) to a calibration file. The K/D file is an OpenCV FileStorage file (.yml, .yaml,
.xml or .json) with nodes K and D (or camera_matrix and distortion_coefficients).

Without --position the camera gets the identity pose (camera frame = world frame); give
--position X,Y,Z (metres) for a camera on the ceiling looking straight down, with --yaw the
direction of the image's x axis in the floor plane (degrees from world +x towards +y).
If --out exists, the camera is appended (cameras keep their order); an existing camera of
the same name is an error unless --replace."""

IMPORT_TOML_HELP = """\
Convert the calibration TOML written by Pose2Sim or anipose (one [cam_xx] table per camera with
name, size, matrix, distortions, rotation, translation and fisheye) into an ergopose calibration
file. Pinhole cameras get the brown_conrady lens (OpenCV k1, k2, p1, p2, k3), fisheye = true ones
the kannala_brandt lens (cv2.fisheye). The file's rotation and translation map world to camera
(OpenCV rvec/tvec); they are inverted into ergopose's camera-to-world pose. Cameras keep the
file's order and names.

The world frame is kept as it is: ergopose needs the floor at z = 0 and z up (Pose2Sim with a
Qualisys or floor-board calibration usually is; anipose's world is its first camera's frame and
is not). The command warns when the cameras' poses do not look like that."""


GUESS_HELP = """\
Write a calibration file for one fisheye camera that has never been calibrated: the image
circle (the disc of light the lens throws on the sensor) is found in the footage, the lens
model's focal length is set so that the circle's edge lies at half the nominal field of view
(--fov, from the lens's data sheet), and the camera looks straight down from --height metres
above the world origin, image x along world +x.

The result is good enough for the 2D stage ('ergopose pose --camera FILE') and for a first look;
it is not a calibration: the real lens differs from its nominal model and the camera is rarely
exactly level. Calibrate with a board for an assessment (docs/calibration.md). The footage must
show the dark border around the image circle: a video lit to its corners (a pinhole camera, or a
fisheye cropped inside its circle) is refused."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "camera",
        help="show calibration files, import Pose2Sim/anipose and OpenCV calibrations",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = parser.add_subparsers(dest="camera_action", metavar="ACTION", title="actions")

    show = actions.add_parser(
        "show",
        help="one line per camera: lens model, size, field of view, position, viewing direction",
        description="Check a calibration file and print one line per camera, in file order.",
    )
    show.add_argument("file", metavar="FILE", help="calibration file (.toml)")
    show.set_defaults(func=run_show)

    toml = actions.add_parser(
        "import",
        help="convert a Pose2Sim or anipose calibration TOML into a calibration file",
        description=IMPORT_TOML_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    toml.add_argument("file", metavar="FILE", help="Pose2Sim/anipose calibration (.toml)")
    toml.add_argument("--out", metavar="FILE", required=True, help="ergopose calibration file to write (.toml)")
    toml.add_argument(
        "--units",
        choices=tuple(LENGTH_UNITS),
        default="m",
        help="length unit of the file's translations (default m, as Pose2Sim; anipose uses the board's unit, often mm)",
    )
    toml.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    toml.set_defaults(func=run_import_toml)

    imp = actions.add_parser(
        "import-opencv",
        help="add an OpenCV fisheye K/D calibration to a calibration file",
        description=IMPORT_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    imp.add_argument(
        "--K-D",
        dest="kd_file",
        metavar="FILE",
        required=True,
        help="OpenCV FileStorage file (.yml/.xml/.json) with the fisheye K and D",
    )
    imp.add_argument("--name", required=True, help="camera name, e.g. cam_1 (unique in the file)")
    imp.add_argument(
        "--size",
        metavar="WxH",
        type=_size,
        help="image size in pixels, e.g. 2592x1944 (default: image_width/image_height from the K/D file)",
    )
    imp.add_argument("--out", metavar="FILE", required=True, help="calibration file to write or extend (.toml)")
    imp.add_argument(
        "--position",
        metavar="X,Y,Z",
        type=_position,
        help="camera position in metres for a ceiling camera looking straight down "
        "(write --position=-1.5,0,3 when X is negative)",
    )
    imp.add_argument(
        "--yaw",
        metavar="DEG",
        type=float,
        default=0.0,
        help="with --position: image x axis direction in the floor plane, degrees (default 0: world +x)",
    )
    imp.add_argument("--replace", action="store_true", help="replace a camera of the same name in --out")
    imp.set_defaults(func=run_import_opencv)

    guess = actions.add_parser(
        "guess",
        help="an approximate calibration for uncalibrated ceiling fisheye footage",
        description=GUESS_HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    guess.add_argument(
        "footage", metavar="VIDEO_OR_IMAGE", type=Path, help="a video of the camera, or one image (.png, .jpg, ...)"
    )
    low, high = (math.degrees(x) for x in NOMINAL_FOV_RANGE)
    guess.add_argument(
        "--fov",
        metavar="DEG",
        type=float,
        required=True,
        help=f"the lens's nominal field of view across its image circle, degrees ({low:g}-{high:g}; "
        "from the lens's data sheet, e.g. 180)",
    )
    guess.add_argument(
        "--lens",
        choices=tuple(NOMINAL_FISHEYE_LENSES),
        default="equidistant",
        help="the lens's projection (default equidistant, r = f theta)",
    )
    guess.add_argument(
        "--height",
        metavar="M",
        type=float,
        default=DEFAULT_GUESS_HEIGHT_M,
        help=f"the camera's height above the floor in metres (default {DEFAULT_GUESS_HEIGHT_M:g})",
    )
    guess.add_argument("--name", default=None, help="camera name (default: the file name without its extension)")
    guess.add_argument("--out", metavar="FILE", type=Path, required=True, help="calibration file to write (.toml)")
    guess.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    guess.set_defaults(func=run_guess)

    parser.set_defaults(func=lambda args: _usage(parser))
    return parser


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help()
    return 2


def _size(text: str) -> tuple[int, int]:
    parts = text.lower().split("x")
    try:
        width, height = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected WIDTHxHEIGHT in pixels, e.g. 2592x1944, got {text!r}") from None
    if width <= 0 or height <= 0:
        raise argparse.ArgumentTypeError(f"width and height must be positive, got {text!r}")
    return width, height


def _position(text: str) -> np.ndarray:
    try:
        values = [float(p) for p in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected X,Y,Z in metres, e.g. 0,0,3, got {text!r}")
    return np.array(values)


def describe(camera: Camera) -> str:
    """One line: name, lens model, size, field of view, position, viewing direction."""
    hfov, vfov = camera.field_of_view()
    axis = np.round(camera.axis_world, 3) + 0.0  # no "-0.000"
    from_down = math.degrees(math.acos(max(-1.0, min(1.0, -axis[2]))))
    x, y, z = camera.position_world
    if camera.image_circle is not None:
        fov_from = f"image circle r = {camera.image_circle[2]:.1f} px"
    elif camera.max_theta_in_image() > math.pi / 2:
        fov_from = "lens model; no image_circle given"
    else:
        fov_from = "image"
    line = (
        f"{camera.name}: {camera.lens.kind}, {camera.width}x{camera.height} px, "
        f"field of view {math.degrees(hfov):.1f} x {math.degrees(vfov):.1f} deg "
        f"(up to {math.degrees(camera.max_theta_in_image()):.1f} deg off-axis; {fov_from}), "
        f"at ({x:.3f}, {y:.3f}, {z:.3f}) m, looking ({axis[0]:+.3f}, {axis[1]:+.3f}, {axis[2]:+.3f}), "
        f"{from_down:.1f} deg from straight down"
    )
    if camera.calibration.rms_error_px is not None:
        line += f", calibration rms {camera.calibration.rms_error_px:.3f} px"
    return line


def run_show(args: argparse.Namespace) -> int:
    for camera in load_calibration(args.file):
        print(describe(camera))
    return 0


def run_import_toml(args: argparse.Namespace) -> int:
    cameras = read_pose2sim_calibration(args.file, units=args.units)
    out = Path(args.out)
    if out.exists() and not args.force:
        raise ConfigError("already exists: choose another --out or add --force", path=out)
    save_calibration(out, cameras, description=f"imported from {Path(args.file).name}")
    for camera in cameras:
        print(describe(camera))
    for warning in world_frame_warnings(cameras):
        print(f"warning: {warning}")
    print(
        f"wrote {out} ({len(cameras)} camera{'s' if len(cameras) != 1 else ''}; world frame as in "
        f"{Path(args.file).name})"
    )
    return 0


def run_import_opencv(args: argparse.Namespace) -> int:
    K, D, extras = read_opencv_fisheye_file(args.kd_file)
    if args.size is not None:
        width, height = args.size
    elif "image_width" in extras and "image_height" in extras:
        width, height = extras["image_width"], extras["image_height"]
    else:
        raise ConfigError(
            "the file has no image_width/image_height: give --size WxH", path=args.kd_file, field="--size"
        )
    info = CalibrationInfo(
        rms_error_px=extras.get("rms_error_px"), method=f"cv2.fisheye K and D imported from {Path(args.kd_file).name}"
    )
    camera = camera_from_opencv_fisheye(args.name, K, D, width, height, calibration=info)
    if args.position is not None:
        camera = Camera(
            name=camera.name,
            lens=camera.lens,
            width=width,
            height=height,
            rotation_world_from_cam=ceiling_rotation(math.radians(args.yaw)),
            position_world=args.position,
            calibration=info,
        )
    out = Path(args.out)
    cameras = list(load_calibration(out)) if out.exists() else []
    names = [c.name for c in cameras]
    if camera.name in names:
        if not args.replace:
            raise ConfigError(
                f"{out} already has a camera {camera.name!r}: choose another --name or add --replace", field="--name"
            )
        cameras[names.index(camera.name)] = camera
    else:
        cameras.append(camera)
    save_calibration(out, cameras)
    print(describe(camera))
    if args.position is None:
        print(
            f"note: {camera.name} has the identity pose (camera frame = world frame); "
            "set its real pose before using the file in a session"
        )
    print(f"wrote {out} ({len(cameras)} camera{'s' if len(cameras) != 1 else ''})")
    return 0


def _circle_of_footage(path: Path) -> tuple[CircleSearch, int, int]:
    """The image circle of an image or a video (frames spread over it), and the image size."""
    if not path.is_file():
        raise InputError("no such file", path=path)
    if path.suffix.lower() in IMAGE_SUFFIXES:
        image = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if image is None:
            raise InputError("cannot be read as an image", path=path)
        return find_image_circle(max_image([image])), int(image.shape[1]), int(image.shape[0])

    info = probe_video(path)
    return circle_from_video(path, 0, info.frames), info.width, info.height


def run_guess(args: argparse.Namespace) -> int:
    low, high = NOMINAL_FOV_RANGE
    fov = math.radians(args.fov) if math.isfinite(args.fov) else math.nan
    if not low <= fov <= high:
        raise ConfigError(
            f"a fisheye's field of view must be between {math.degrees(low):g} and "
            f"{math.degrees(high):g} degrees, got {args.fov:g}",
            field="--fov",
        )
    reach = nominal_max_fov(args.lens)
    if fov > reach + 1e-12:
        raise ConfigError(
            f"a {args.lens} lens spans at most {math.degrees(reach):g} degrees, got {args.fov:g}", field="--fov"
        )
    if not (math.isfinite(args.height) and args.height > 0):
        raise ConfigError(f"expected a height above the floor in metres, got {args.height:g}", field="--height")
    out = Path(args.out)
    if out.is_dir():
        raise ConfigError("is a folder: --out names the calibration file to write", path=out)
    if out.exists() and not args.force:
        raise ConfigError("already exists: choose another --out or add --force", path=out)
    search, width, height = _circle_of_footage(args.footage)
    if search.circle is None:
        raise InputError(
            f"no fisheye image circle found ({search.reason}); 'camera guess' needs footage of a "
            "fisheye lens whose dark border shows",
            path=args.footage,
        )
    name = args.name or args.footage.stem
    camera = nominal_fisheye_camera(name, width, height, search.circle, fov, args.height, args.lens)
    camera = Camera(
        camera.name,
        camera.lens,
        width,
        height,
        camera.rotation_world_from_cam,
        camera.position_world,
        calibration=CalibrationInfo(
            method=f"{camera.calibration.method} (ergopose camera guess on "
            f"{args.footage.name}, circle fit {search.fit_rms_px:.2f} px RMS)"
        ),
        image_circle=camera.image_circle,
    )
    save_calibration(
        out,
        [camera],
        description=f"guessed from {args.footage.name}: nominal {args.lens} lens, "
        f"{args.fov:g} deg, {args.height:g} m, straight down",
    )
    print(describe(camera))
    u, v, r = search.circle
    print(f"image circle at ({u:.1f}, {v:.1f}), r = {r:.1f} px (fit {search.fit_rms_px:.2f} px RMS)")
    print(f"wrote {out} (approximate: calibrate with a board for an assessment)")
    return 0
