"""``ergopose pose VIDEO --out FILE``: the 2D stage alone on one video, keypoints into a CSV file."""

from __future__ import annotations

import argparse
import math
import re
from dataclasses import replace
from pathlib import Path

from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError, InputError
from ergopose.geometry.calibration_file import camera_for_video, read_any_calibration
from ergopose.geometry.camera import Camera
from ergopose.geometry.image_circle import nominal_fisheye_camera, nominal_pinhole_camera
from ergopose.pipeline.pose_video import circle_from_video, pose_video, write_pose_csv
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
from ergopose.pose.settings import PoseSettings
from ergopose.pose.models import LANDMARK_MODELS, POSE_COMMAND_MODEL, ConfidenceGates
from ergopose.progress import warn
from ergopose.progress import ProgressCallback
from ergopose.video import probe_video

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
Find the people in one video and write their 2D keypoints (33 body points per person, in the
video's own pixels, with a confidence) to a CSV file: the first stage of 'ergopose assess' run
alone, for one camera, without a session. Use it to check what the cameras see before a whole
assessment, or to get keypoints from footage that has no calibration yet.

The camera: with --camera FILE, the lens from a calibration file (an ergopose calibration, or a
Pose2Sim/anipose calibration TOML; --camera-name picks the camera when the file holds several,
else the camera named like the video file is taken). Without it, an approximate camera is made
from the video itself: for a fisheye lens (the default), the bright image circle is found in the
frames and the lens is taken to spread --fov-deg degrees (default 180) evenly across it, looking
straight down from the ceiling; for --lens pinhole, --fov-deg is the field of view across the
image's width (default 60), looking level. Keypoints from an approximate camera are as good as
that guess; calibrate the cameras for an assessment (docs/calibration.md).

The CSV has one row per frame, person and keypoint: frame, time_s, person (numbered within the
frame), joint (name), x_px, y_px, confidence (0-1), left_right_uncertain (1 on a keypoint whose
side, left or right, is in doubt in that frame; its confidence is then lowered). A keypoint that
falls outside the lens has empty x_px and y_px. Frames where nobody was found have no rows. See
docs/pose-command.md."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "pose",
        help="find the people in one video and write their 2D keypoints to a CSV file (no session needed)",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("video", metavar="VIDEO", type=Path, help="the video file of one camera")
    p.add_argument("--out", required=True, type=Path, metavar="FILE", help="the CSV file to write")
    p.add_argument(
        "--camera",
        type=Path,
        metavar="FILE.toml",
        default=None,
        help="calibration file of the camera (ergopose, or Pose2Sim/anipose TOML); "
        "without it an approximate camera is made from the video",
    )
    p.add_argument(
        "--camera-name",
        metavar="NAME",
        default=None,
        help="with --camera: the camera of the file that filmed VIDEO (default: the file's only camera, "
        "or the one named like the video file)",
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


def run(args: argparse.Namespace) -> int:
    _check_arguments(args)
    info = probe_video(args.video)
    start, stop = _frame_range(args, info.frames, info.fps)
    progress = ProgressBars()
    if args.camera is not None:
        camera = _camera_from_file(args.camera, args.camera_name, args.video, info.width, info.height, progress)
    else:
        camera = _camera_from_video(args, info.width, info.height, start, stop)
    print(f"camera {_describe(camera)}", flush=True)
    landmarker = BlazePoseLandmarker(model=args.model, model_dir=args.model_dir, progress=progress)
    detector = BlazePoseDetector(model_dir=args.model_dir, progress=progress)
    settings = stage_settings(landmarker.card.gates, info.fps, args.max_people)
    result = pose_video(args.video, camera, info.fps, start, stop, landmarker, detector, settings, progress)
    write_pose_csv(args.out, result.table)
    read = result.frames_read
    print(
        f"{args.video}: people found in {result.frames_with_people} of {read} frames "
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
    print(f"wrote {args.out}")
    return 0


def _check_arguments(args: argparse.Namespace) -> None:
    if args.camera is not None:
        for name in ("lens", "fov_deg"):
            if getattr(args, name) is not None:
                flag = "--" + name.replace("_", "-")
                raise ConfigError(
                    "describes a camera without calibration; with --camera the file gives the lens", field=flag
                )
    else:
        if args.camera_name is not None:
            raise ConfigError("needs --camera FILE (the calibration file that holds the camera)", field="--camera-name")
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
    if args.out.is_dir():
        raise ConfigError("is a folder: --out names the CSV file to write", path=args.out)
    if args.out.exists() and not args.force:
        raise ConfigError("already exists: choose another --out or add --force", path=args.out)


def _frame_range(args: argparse.Namespace, frames: int, fps: float) -> tuple[int, int]:
    start = int(round(args.start * fps))
    stop = frames if args.end is None else min(frames, int(round(args.end * fps)))
    if start >= frames:
        raise ConfigError(f"the video is only {frames / fps:.2f} s long, got {args.start:g}", field="--start")
    return start, max(stop, start + 1)


def _camera_from_video(args: argparse.Namespace, width: int, height: int, start: int, stop: int) -> Camera:
    lens = args.lens or "fisheye"
    fov = math.radians(DEFAULT_FOV_DEG[lens] if args.fov_deg is None else args.fov_deg)
    name = args.video.stem
    if lens == "pinhole":
        return nominal_pinhole_camera(name, width, height, fov)
    search = circle_from_video(args.video, start, stop)
    if search.circle is None:
        raise InputError(
            f"no image circle found in {args.video} ({search.reason}): give --camera FILE "
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
