"""``ergopose pose VIDEO_OR_FOLDER --out DIR``: the 2D stage alone on one camera's footage; keypoints as CSV,
Parquet and COCO-style JSON, and an overlay to check them by eye."""

from __future__ import annotations

import argparse
import math
import re
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ergopose import __version__
from ergopose.atomic import atomic_dir, clean_up_beside
from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError, InputError
from ergopose.geometry.calibration_file import camera_for_video, read_any_calibration
from ergopose.geometry.camera import Camera
from ergopose.geometry.image_circle import nominal_fisheye_camera, nominal_pinhole_camera
from ergopose.pipeline.pose_outputs import (
    CocoImage,
    CocoSource,
    OverlayImages,
    OverlayVideo,
    coco_document,
    write_pose_coco,
    write_pose_parquet,
)
from ergopose.pipeline.pose_video import (
    FrameSink,
    PoseVideoResult,
    circle_from_images,
    circle_from_video,
    pose_frames,
    write_pose_csv,
)
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
from ergopose.pose.settings import PoseSettings
from ergopose.pose.models import LANDMARK_MODELS, POSE_COMMAND_MODEL, ConfidenceGates
from ergopose.progress import warn
from ergopose.progress import ProgressCallback
from ergopose.recon.settings import ReconSettings
from ergopose.video import image_size, list_images, probe_video, read_frames_checked, read_images_checked

#: Pose models --model accepts (the BlazePose landmark model cards of docs/models.md).
MODELS: tuple[str, ...] = tuple(LANDMARK_MODELS)
#: Accepted --fov-deg per lens (degrees): the whole field of view across the image circle
#: (fisheye) or across the image's width (pinhole).
FOV_RANGE_DEG = {"fisheye": (100.0, 280.0), "pinhole": (10.0, 150.0)}
DEFAULT_FOV_DEG = {"fisheye": 180.0, "pinhole": 60.0}
#: The stage alone remembers each person's left/right labelling this long (seconds; weight halving
#: time, ``PoseSettings.left_right_memory``): with one camera nothing downstream settles a run of
#: frames the network labels the other way round. Measured on the Pose2Sim recording (cam_02: 34 of
#: 100 frames crossed -> 0; re-rendered into virtual fisheye: 38 -> 22 %); `assess` does without,
#: its reconstruction settles sides across cameras (docs/pose-in-fisheye.md).
LEFT_RIGHT_MEMORY_S = 2.0
#: Views turned from upright by more than this (degrees) are run again upright to check the
#: person's sides (a second network run for such views).
UPRIGHT_CHECK_DEG = 10.0


def stage_settings(gates: ConfidenceGates | None, fps: float, max_people: int) -> PoseSettings:
    """The 2D stage as this command runs it: the model card's gates, the left/right memory
    (``LEFT_RIGHT_MEMORY_S``), and a person whose sides the left/right check doubts passed on with
    the confidence of every left/right keypoint lowered to the card's ``min_keypoint_confidence``
    (below its triangulation gate: not a confident pose; the CSV's ``left_right_uncertain`` says
    why). Measured on the Pose2Sim recording re-rendered into virtual fisheye cameras
    (docs/pose-command.md, "Doubted sides"): cam_02's confident frames with left and right
    crossed 21.9 -> 13.2 %, the three other cameras unchanged (no frame doubted). A view turned
    more than ``UPRIGHT_CHECK_DEG`` from upright is run again upright, and the frame's sides are
    doubted when the two views label them the other way round
    (``PoseSettings.left_right_upright_check``; docs/pose-in-fisheye.md, "A second, upright
    view"). gates: None (a card without its own) keeps the stage's default gates."""
    settings = PoseSettings(
        max_people=max_people,
        left_right_memory=LEFT_RIGHT_MEMORY_S * fps,
        left_right_upright_check=math.radians(UPRIGHT_CHECK_DEG),
    ).with_gates(gates)
    return replace(settings, uncertain_confidence=settings.min_keypoint_confidence)


HELP = """\
Find the people in one video, or in a folder of images, and write their 2D keypoints (33 body
points per person, in the camera's own pixels, with a confidence): the first stage of 'ergopose
assess' run alone, for one camera, without a session. Use it to check what the cameras see before
a whole assessment, or to get keypoints from footage that has no calibration yet.

The source: a video file, or a folder of images (.png, .jpg, ...) taken as the frames of one
camera in name order (frame_2 before frame_10), at --fps frames per second (default 1).

The camera: with --calibration FILE, the lens from a calibration file (an ergopose calibration,
or a Pose2Sim/anipose calibration TOML); --camera NAME picks the camera when the file holds
several, else the camera named like the video (or folder) is taken. ('--camera FILE' without
--calibration, the earlier spelling, names the file; --camera-name then names the camera.)
Without a calibration an approximate camera is made from the footage itself: for a fisheye lens
(the default), the bright image circle is found in the frames and the lens is taken to spread
--fov-deg degrees (default 180) evenly across it, looking straight down from the ceiling; for
--lens pinhole, --fov-deg is the field of view across the image's width (default 60), looking
level. Keypoints from an approximate camera are as good as that guess; calibrate the cameras for
an assessment (docs/calibration.md).

The output: --out DIR writes the folder DIR with keypoints.csv, keypoints.parquet (the same
table) and keypoints.coco.json (COCO's person-keypoint layout: one annotation per person and
frame), and with --overlay the frames with the skeletons drawn (overlay.mp4 for a video, overlay/
for a folder of images): video frames, so faces, in a file you asked for. --out FILE.csv writes
the CSV file alone.

The table has one row per frame, person and keypoint: frame, time_s, person (numbered within the
frame), joint (name), x_px, y_px, confidence (0-1), left_right_uncertain (1 on a keypoint whose
side, left or right, is in doubt in that frame; its confidence is then lowered). A keypoint that
falls outside the lens has empty x_px and y_px. Frames where nobody was found have no rows. See
docs/pose-command.md."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "pose",
        help="find the people in one video or folder of images and write their 2D keypoints (CSV, Parquet, COCO JSON, an overlay; no session needed)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "video", metavar="VIDEO_OR_FOLDER", type=Path, help="the video file of one camera, or a folder of its images"
    )
    p.add_argument(
        "--out",
        required=True,
        type=Path,
        metavar="DIR",
        help="the folder to write (keypoints as CSV, Parquet and COCO JSON; the overlay), or FILE.csv for the "
        "CSV file alone",
    )
    p.add_argument(
        "--calibration",
        type=Path,
        metavar="FILE.toml",
        default=None,
        help="calibration file of the camera (ergopose, or Pose2Sim/anipose TOML); "
        "without it an approximate camera is made from the footage",
    )
    p.add_argument(
        "--camera",
        metavar="NAME",
        default=None,
        help="with --calibration: the camera of the file that filmed the footage (default: the file's only "
        "camera, or the one named like the video or folder); without --calibration: the calibration file "
        "(the earlier spelling)",
    )
    p.add_argument("--camera-name", metavar="NAME", default=None, help="the camera's name (the earlier spelling)")
    p.add_argument(
        "--overlay",
        action="store_true",
        help="also write the frames with the skeletons drawn, for checking by eye (needs --out DIR)",
    )
    p.add_argument(
        "--fps",
        type=float,
        default=None,
        metavar="F",
        help="a folder of images: their frames per second (default 1); a video states its own",
    )
    p.add_argument(
        "--lens",
        choices=tuple(FOV_RANGE_DEG),
        default=None,
        help="without --camera: the kind of lens (default fisheye)",
    )
    p.add_argument(
        "--fov-deg",
        type=float,
        metavar="D",
        default=None,
        help="without --camera: the lens's field of view in degrees, across the image circle for a fisheye "
        f"({FOV_RANGE_DEG['fisheye'][0]:g}-{FOV_RANGE_DEG['fisheye'][1]:g}, default "
        f"{DEFAULT_FOV_DEG['fisheye']:g}) or across the image's width for a pinhole "
        f"({FOV_RANGE_DEG['pinhole'][0]:g}-{FOV_RANGE_DEG['pinhole'][1]:g}, default "
        f"{DEFAULT_FOV_DEG['pinhole']:g})",
    )
    p.add_argument(
        "--model",
        choices=MODELS,
        default=POSE_COMMAND_MODEL,
        help=f"the pose model (default {POSE_COMMAND_MODEL}, which keeps people's left and right best; 'assess' "
        "uses full for speed; 'ergopose models list', docs/models.md)",
    )
    p.add_argument(
        "--model-dir",
        default=None,
        metavar="DIR",
        help="pose model cache (default: $ERGOPOSE_MODEL_DIR or the user cache)",
    )
    p.add_argument(
        "--max-people",
        type=int,
        default=PoseSettings().max_people,
        metavar="N",
        help=f"most people followed at once (default {PoseSettings().max_people}); "
        "a warning says when a frame reaches it",
    )
    p.add_argument("--start", type=float, default=0.0, metavar="S", help="first second of the video to use (default 0)")
    p.add_argument(
        "--end", type=float, default=None, metavar="S", help="last second of the video to use (default: the end)"
    )
    p.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    p.set_defaults(func=run)
    return p


#: The files of an output folder (--out DIR).
CSV_NAME = "keypoints.csv"
PARQUET_NAME = "keypoints.parquet"
COCO_NAME = "keypoints.coco.json"
OVERLAY_VIDEO_NAME = "overlay.mp4"
OVERLAY_IMAGES_NAME = "overlay"
OUTPUT_NAMES = (CSV_NAME, PARQUET_NAME, COCO_NAME, OVERLAY_VIDEO_NAME, OVERLAY_IMAGES_NAME)
#: Frames per second of a folder of images unless --fps says otherwise.
IMAGES_FPS = 1.0


@dataclass(frozen=True)
class Footage:
    """The frames of one camera: a video, or a folder's images (``images``, in name order)."""

    path: Path
    frames: int
    fps: float
    width: int
    height: int
    images: tuple[Path, ...] = ()

    @property
    def is_folder(self) -> bool:
        return bool(self.images)

    def frame_name(self, index: int) -> str:
        return self.images[index].name if self.images else f"{self.path.name}#{index}"


def run(args: argparse.Namespace) -> int:
    calibration, camera_name = _camera_arguments(args)
    _check_arguments(args, calibration, camera_name)
    footage = _footage(args)
    start, stop = _frame_range(args, footage.frames, footage.fps)
    progress = ProgressBars()
    if calibration is not None:
        camera = _camera_from_file(calibration, camera_name, footage.path, footage.width, footage.height, progress)
    else:
        camera = _camera_from_footage(args, footage, start, stop)
    print(f"camera {_describe(camera)}", flush=True)
    landmarker = BlazePoseLandmarker(model=args.model, model_dir=args.model_dir, progress=progress)
    detector = BlazePoseDetector(model_dir=args.model_dir, progress=progress)
    settings = stage_settings(landmarker.card.gates, footage.fps, args.max_people)
    gate = (
        landmarker.card.gates.min_triangulation_confidence if landmarker.card.gates else ReconSettings().min_confidence
    )

    def stage(on_frame: FrameSink | None) -> PoseVideoResult:
        if footage.is_folder:
            frames = read_images_checked(list(footage.images), start, stop, (footage.width, footage.height))
        else:
            frames = read_frames_checked(footage.path, start, stop)
        return pose_frames(
            frames, footage.path, camera, footage.fps, start, stop, landmarker, detector, settings, progress, on_frame
        )

    clean_up_beside(args.out)  # what a killed run of this command left beside --out
    if _csv_only(args.out):
        result = stage(None)
        write_pose_csv(args.out, result.table)
        written = [args.out]
    else:
        with atomic_dir(args.out) as folder:
            overlay: OverlayVideo | OverlayImages | None = None
            if args.overlay and footage.is_folder:
                overlay = OverlayImages(folder / OVERLAY_IMAGES_NAME, [p.name for p in footage.images], gate)
            elif args.overlay:
                overlay = OverlayVideo(folder / OVERLAY_VIDEO_NAME, footage.fps, footage.width, footage.height, gate)
            try:
                result = stage(overlay.add if overlay is not None else None)
            finally:
                if overlay is not None:
                    overlay.close()
            write_pose_csv(folder / CSV_NAME, result.table)
            write_pose_parquet(folder / PARQUET_NAME, result.table)
            write_pose_coco(folder / COCO_NAME, _coco(result, footage, camera, args.model, gate))
        written = [args.out / name for name in OUTPUT_NAMES if (args.out / name).exists()]
    _summary(args, footage, result)
    for path in written:
        print(f"wrote {path}")
    return 0


def _coco(result: PoseVideoResult, footage: Footage, camera: Camera, model: str, gate: float) -> dict[str, Any]:
    images = [
        CocoImage(int(f), f / footage.fps, footage.frame_name(int(f)), footage.width, footage.height)
        for k, f in enumerate(range(result.start, result.stop))
        if result.people[k] >= 0
    ]
    source = CocoSource(
        description=f"ergopose pose {__version__}: keypoints of {footage.path.name}, camera {camera.name}",
        model=f"BlazePose {model} (docs/models.md)",
        min_confidence=gate,
        extra={"source": str(footage.path), "camera": camera.name, "fps": footage.fps},
    )
    return coco_document(result.table, images, source)


def _summary(args: argparse.Namespace, footage: Footage, result: PoseVideoResult) -> None:
    read = result.frames_read
    print(
        f"{footage.path}: people found in {result.frames_with_people} of {read} frames "
        f"({100.0 * result.frames_with_people / max(read, 1):.1f} %), at most {int(result.people.max())} at once; "
        f"{len(result.table)} keypoint rows"
    )
    doubted = result.uncertain_person_frames
    if doubted:
        print(
            f"  left and right doubted in {doubted} person-frames: their left/right keypoints carry lowered "
            "confidence (column left_right_uncertain)"
        )
    if result.upright_checks:
        print(
            f"  {result.upright_checks} person views turned from upright checked in an upright view; "
            f"{result.upright_disputed} of them gave the sides the other way round (those sides doubted)"
        )
    if result.capped_frames:
        print(f"  max_people = {args.max_people} reached in {result.capped_frames} frames")


def _csv_only(out: Path) -> bool:
    return out.suffix.lower() == ".csv"


def _camera_arguments(args: argparse.Namespace) -> tuple[Path | None, str | None]:
    """(calibration file, camera name) from --calibration FILE --camera NAME, or from the earlier
    spelling --camera FILE --camera-name NAME."""
    if args.calibration is not None:
        if args.camera is not None and args.camera_name is not None:
            raise ConfigError("names the camera a second time: give --camera NAME alone", field="--camera-name")
        return args.calibration, args.camera if args.camera is not None else args.camera_name
    return (Path(args.camera) if args.camera is not None else None), args.camera_name


def _check_arguments(args: argparse.Namespace, calibration: Path | None, camera_name: str | None) -> None:
    if calibration is not None:
        for name in ("lens", "fov_deg"):
            if getattr(args, name) is not None:
                flag = "--" + name.replace("_", "-")
                raise ConfigError(
                    "describes a camera without calibration; with --calibration the file gives the lens", field=flag
                )
    else:
        if camera_name is not None:
            raise ConfigError(
                "needs --calibration FILE (the calibration file that holds the camera)", field="--camera-name"
            )
        lens = args.lens or "fisheye"
        low, high = FOV_RANGE_DEG[lens]
        fov = DEFAULT_FOV_DEG[lens] if args.fov_deg is None else args.fov_deg
        if not (math.isfinite(fov) and low <= fov <= high):
            raise ConfigError(
                f"a {lens} lens's field of view must be between {low:g} and {high:g} degrees, got {fov:g}",
                field="--fov-deg",
            )
    if args.max_people < 1:
        raise ConfigError(f"expected at least 1 person, got {args.max_people}", field="--max-people")
    if not (math.isfinite(args.start) and args.start >= 0):
        raise ConfigError(f"expected seconds >= 0, got {args.start:g}", field="--start")
    if args.end is not None and not (math.isfinite(args.end) and args.end > args.start):
        raise ConfigError(f"expected seconds after --start ({args.start:g}), got {args.end:g}", field="--end")
    if args.fps is not None and not (math.isfinite(args.fps) and args.fps > 0):
        raise ConfigError(f"expected frames per second > 0, got {args.fps:g}", field="--fps")
    out = args.out
    if _csv_only(out):
        if args.overlay:
            raise ConfigError(
                "needs --out DIR (a folder): the overlay is written beside the keypoints", field="--overlay"
            )
        if out.is_dir():
            raise ConfigError("is a folder: --out FILE.csv names the CSV file to write", path=out)
        if out.exists() and not args.force:
            raise ConfigError("already exists: choose another --out or add --force", path=out)
        return
    if out.exists() and not out.is_dir():
        raise ConfigError("is a file: --out names the folder to write (or a FILE.csv)", path=out)
    if out.is_dir() and any(out.iterdir()):
        others = sorted(p.name for p in out.iterdir() if p.name not in OUTPUT_NAMES)
        if others:
            raise ConfigError(
                f"is a folder that holds other files than 'ergopose pose' writes ({', '.join(others[:3])}"
                f"{', ...' if len(others) > 3 else ''}): choose a new --out",
                path=out,
            )
        if not args.force:
            raise ConfigError("already holds keypoints: choose another --out or add --force", path=out)


def _footage(args: argparse.Namespace) -> Footage:
    path: Path = args.video
    if path.is_dir():
        images = list_images(path)
        width, height = image_size(images[0])
        fps = IMAGES_FPS if args.fps is None else float(args.fps)
        return Footage(path, len(images), fps, width, height, tuple(images))
    if args.fps is not None:
        raise ConfigError("a video states its own frame rate: --fps is for a folder of images", field="--fps")
    info = probe_video(path)
    return Footage(path, info.frames, info.fps, info.width, info.height)


def _frame_range(args: argparse.Namespace, frames: int, fps: float) -> tuple[int, int]:
    start = int(round(args.start * fps))
    stop = frames if args.end is None else min(frames, int(round(args.end * fps)))
    if start >= frames:
        raise ConfigError(f"the video is only {frames / fps:.2f} s long, got {args.start:g}", field="--start")
    return start, max(stop, start + 1)


def _camera_from_footage(args: argparse.Namespace, footage: Footage, start: int, stop: int) -> Camera:
    lens = args.lens or "fisheye"
    fov = math.radians(DEFAULT_FOV_DEG[lens] if args.fov_deg is None else args.fov_deg)
    name = footage.path.stem
    width, height = footage.width, footage.height
    if lens == "pinhole":
        return nominal_pinhole_camera(name, width, height, fov)
    if footage.is_folder:
        search = circle_from_images(list(footage.images), start, stop, (width, height))
    else:
        search = circle_from_video(footage.path, start, stop)
    if search.circle is None:
        raise InputError(
            f"no image circle found in {footage.path} ({search.reason}): give --calibration FILE "
            "(a calibration), or --lens pinhole for a camera without a fisheye lens"
        )
    return nominal_fisheye_camera(name, width, height, search.circle, fov)


def _key(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.lower())


def _camera_from_file(
    path: Path, name: str | None, video: Path, width: int, height: int, progress: ProgressCallback | None
) -> Camera:
    cameras, _ = read_any_calibration(path)
    names = [c.name for c in cameras]
    if name is not None:
        if name not in names:
            raise ConfigError(f"no camera {name!r} in {path} (it has: {', '.join(names)})", field="--camera-name")
        camera = cameras[names.index(name)]
    elif len(cameras) == 1:
        camera = cameras[0]
    else:
        like = [c for c in cameras if _key(c.name) == _key(video.stem)]
        if len(like) != 1:
            raise ConfigError(
                f"{path} holds {len(cameras)} cameras ({', '.join(names)}): say which one filmed {video.name}",
                field="--camera-name",
            )
        camera = like[0]
    fitted = camera_for_video(camera, width, height)
    if fitted is not None:
        if fitted is not camera:
            warn(
                progress,
                f"camera {camera.name} is calibrated for {camera.width}x{camera.height} px, the video is "
                f"{width}x{height} px; taken as the calibrated image cropped at the right/bottom "
                "(encoder padding)",
            )
        return fitted
    raise InputError(
        f"the video is {width}x{height} px but camera {camera.name} of {path} is calibrated for "
        f"{camera.width}x{camera.height} px: wrong camera or wrong video?",
        path=video,
    )


def _describe(camera: Camera) -> str:
    hfov, vfov = camera.field_of_view()
    text = (
        f"{camera.name}: {camera.lens.kind} lens, {camera.width}x{camera.height} px, "
        f"field of view {math.degrees(hfov):.0f} x {math.degrees(vfov):.0f} deg"
    )
    if camera.image_circle is not None:
        u, v, r = camera.image_circle
        text += f", image circle at ({u:.1f}, {v:.1f}) r = {r:.1f} px"
    return text
