"""``ergopose session new DIR --calibration FILE VIDEO...``: a session folder from videos and a
calibration (docs/session-format.md)."""

from __future__ import annotations

import argparse
import datetime as dt
import math
import os
import shutil
from pathlib import Path

from ergopose.atomic import write_text
from ergopose.errors import ConfigError, InputError
from ergopose.geometry.calibration_file import (
    camera_for_video,
    read_any_calibration,
    save_calibration,
    world_frame_warnings,
)
from ergopose.session import CALIBRATION_FILE, FPS_TOLERANCE, SETTINGS_FILE, load_session
from ergopose.settings.generate import TEMPLATE_HOWTO, settings_text
from ergopose.settings.model import FORMAT_VERSION
from ergopose.video import probe_video

HELP = """\
Make a session folder (docs/session-format.md) from one video per camera and a calibration file:
an ergopose calibration (docs/calibration-file.md) or the calibration TOML of Pose2Sim or
anipose (converted as by 'ergopose camera import').

The videos are matched to the calibration's cameras in the order given (the first video is the
first camera of the file, or of --cameras), the cameras keep the calibration's names, and the
folder gets calibration.toml, a commented settings.toml and the videos (copied, or linked with
--link). Every video must be readable and all must have the same frame rate and length.

A video up to 15 pixels narrower or lower than its calibration (an encoder's padding to a
multiple of 16, e.g. 1080 recorded as 1088) is taken as the calibrated image cropped at the
right/bottom: the session's calibration gets the video's size, the pixel coordinates are kept."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "session",
        help="make a session folder from videos and a calibration",
        description="Session folders (docs/session-format.md).",
    )
    actions = parser.add_subparsers(dest="session_action", metavar="ACTION", title="actions")
    new = actions.add_parser(
        "new",
        help="make a session folder from videos and a calibration file",
        description=HELP,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    new.add_argument("dir", metavar="DIR", type=Path, help="the session folder to make (must not exist or be empty)")
    new.add_argument(
        "--calibration",
        required=True,
        type=Path,
        metavar="FILE",
        help="ergopose calibration, or a Pose2Sim/anipose calibration TOML",
    )
    new.add_argument(
        "videos", metavar="VIDEO", type=Path, nargs="+", help="one video per camera, in the calibration's camera order"
    )
    new.add_argument(
        "--cameras",
        metavar="NAME,NAME",
        default=None,
        help="use only these cameras of the calibration, in this order (e.g. cam_01,cam_03)",
    )
    new.add_argument(
        "--units",
        choices=("m", "cm", "mm"),
        default="m",
        help="length unit of a Pose2Sim/anipose calibration's translations (default m)",
    )
    new.add_argument(
        "--recorded-at",
        metavar="ISO",
        default=None,
        help="when the first frame was taken, e.g. 2024-03-04T08:00:00+01:00 (default: the first "
        "video's modification time, said so in settings.toml)",
    )
    new.add_argument("--link", action="store_true", help="link the videos into the folder instead of copying them")
    new.set_defaults(func=run_new)

    def show_help(args: argparse.Namespace) -> int:
        parser.print_help()
        return 2

    parser.set_defaults(func=show_help)
    return parser


def run_new(args: argparse.Namespace) -> int:
    root: Path = args.dir
    if root.exists() and (not root.is_dir() or any(root.iterdir())):
        raise InputError("already exists and is not an empty folder: choose a new session folder", path=root)
    cameras, kind = read_any_calibration(args.calibration, args.units)
    if args.cameras:
        wanted = [n.strip() for n in args.cameras.split(",") if n.strip()]
        names = [c.name for c in cameras]
        unknown = [n for n in wanted if n not in names]
        if unknown or len(set(wanted)) != len(wanted) or not wanted:
            raise ConfigError(
                f"expected distinct camera names of the calibration ({', '.join(names)}), got {args.cameras!r}",
                field="--cameras",
            )
        cameras = tuple(cameras[names.index(n)] for n in wanted)
    if len(args.videos) != len(cameras):
        listing = ", ".join(c.name for c in cameras)
        raise InputError(
            f"{len(cameras)} camera(s) ({listing}) but {len(args.videos)} video(s): give one video per "
            "camera, in the calibration's order (or choose cameras with --cameras)",
            path=args.calibration,
        )
    resolved = [v.resolve() for v in args.videos]
    twice = next((v for k, v in enumerate(args.videos) if resolved[k] in resolved[:k]), None)
    if twice is not None:
        raise InputError("the same video is given for two cameras", path=twice)
    infos = [probe_video(v) for v in args.videos]
    rates = [i.fps for i in infos]
    if any(not (math.isfinite(r) and r > 0) for r in rates):
        bad = args.videos[[not (math.isfinite(r) and r > 0) for r in rates].index(True)]
        raise InputError("the video does not state its frame rate", path=bad)
    if max(rates) - min(rates) > FPS_TOLERANCE * min(rates):
        listing = ", ".join(f"{v.name}: {r:g}" for v, r in zip(args.videos, rates))
        raise InputError(
            f"the videos have different frame rates ({listing} frames per second); the cameras must "
            "record in sync, frame for frame"
        )
    counts = [i.frames for i in infos]
    if len(set(counts)) > 1:
        listing = ", ".join(f"{v.name}: {n}" for v, n in zip(args.videos, counts))
        raise InputError(
            f"the videos have different numbers of frames ({listing}); the cameras must record in "
            "sync, frame for frame (trim them to the same start and length)"
        )
    notes = []
    session_cameras = []
    for cam, video, info in zip(cameras, args.videos, infos):
        fitted = camera_for_video(cam, info.width, info.height)
        if fitted is None:
            raise InputError(
                f"camera {cam.name!r} is calibrated for {cam.width} x {cam.height} pixels but the "
                f"video is {info.width} x {info.height} (a scaled or different video?)",
                path=video,
            )
        if fitted is not cam:
            notes.append(
                f"{cam.name}: video {info.width} x {info.height}, calibrated {cam.width} x {cam.height}: "
                "taken as the calibrated image cropped at the right/bottom (encoder padding)"
            )
        session_cameras.append(fitted)
    if args.recorded_at:
        try:
            recorded_at = dt.datetime.fromisoformat(args.recorded_at)
        except ValueError:
            raise ConfigError(
                f"expected an ISO 8601 date and time, got {args.recorded_at!r}", field="--recorded-at"
            ) from None
        when = "given with --recorded-at"
    else:
        recorded_at = dt.datetime.fromtimestamp(os.stat(args.videos[0]).st_mtime).astimezone().replace(microsecond=0)
        when = f"the modification time of {args.videos[0].name}: CORRECT IT to the first frame's real time"
    root.mkdir(parents=True, exist_ok=True)
    files = []
    for cam, video in zip(session_cameras, args.videos):
        target = root / f"{cam.name}{video.suffix.lower()}"
        if args.link:
            os.symlink(video.resolve(), target)
        else:
            shutil.copyfile(video, target)
        files.append((cam.name, target.name))
    save_calibration(root / CALIBRATION_FILE, session_cameras, description=f"from {args.calibration.name} ({kind})")
    header = _settings_header(args, kind, when, rates[0], counts[0], notes)
    values = {
        "format_version": FORMAT_VERSION,
        "recorded_at": recorded_at,
        "cameras": [{"name": name, "video": video} for name, video in files],
    }
    text = settings_text(values, header=header + TEMPLATE_HOWTO)
    write_text(root / SETTINGS_FILE, text)
    session = load_session(root)  # everything written is read back and checked
    print(
        f"wrote {root}: {len(session.cameras)} camera(s) "
        f"({', '.join(c.camera.name for c in session.cameras)}), {session.frame_count} frames at "
        f"{session.fps:g} fps ({session.frame_count / session.fps:.1f} s)"
    )
    for n in notes:
        print(f"note: {n}")
    for w in world_frame_warnings(session_cameras):
        print(f"warning: {w}")
    print(f"note: recorded_at is {when}; add the task inputs the cameras cannot see in {root / SETTINGS_FILE}")
    return 0


def _settings_header(args: argparse.Namespace, kind: str, when: str, fps: float, frames: int, notes: list[str]) -> str:
    lines = [
        "# ergopose session settings (docs/session-format.md explains the file, docs/settings.md lists every key).",
        f"# Made by 'ergopose session new' from {args.calibration.name} ({kind} calibration) and",
        f"# {len(args.videos)} video(s): {', '.join(v.name for v in args.videos)}; {frames} frames at {fps:g} fps.",
        f"# recorded_at: {when}.",
        "# The cameras below are in the calibration's order, each with its video; do not reorder them",
        "# without reordering the videos.",
    ]
    lines += [f"# {n}" for n in notes]
    return "\n".join(lines) + "\n"
