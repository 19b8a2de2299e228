"""``ergopose calibrate``: intrinsics from board images, extrinsics on the floor, accuracy check."""

from __future__ import annotations

import argparse
import csv
import datetime as dt
import sys
from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.atomic import write_text
from ergopose.calibration import check
from ergopose.calibration import extrinsics as ext
from ergopose.calibration import intrinsics as intr
from ergopose.calibration.boards import detect_board, parse_board
from ergopose.calibration.intrinsics import read_gray
from ergopose.cli_progress import ProgressBars
from ergopose.errors import ConfigError, InputError
from ergopose.geometry.calibration_file import load_calibration, save_calibration
from ergopose.geometry.camera import CalibrationInfo, Camera
from ergopose.session import load_session

HELP = "calibrate the fisheye cameras (intrinsics, extrinsics, accuracy check)"

BOARD_HELP = (
    "checkerboard:COLSxROWS:SQUARE (inner corners, metres, e.g. checkerboard:9x6:0.025), "
    "charuco:COLSxROWS:SQUARE:MARKER:DICT (squares, e.g. charuco:7x5:0.04:0.03:DICT_5X5_100) "
    "or a board TOML file"
)

DESCRIPTION = """\
Calibrate the ceiling fisheye cameras, in three steps (docs/calibration.md):

  1. ergopose calibrate intrinsics --images DIR --board SPEC --camera NAME --out calibration.toml
     (once per camera: 10-30 photos of a board held at many places, including the image edges)
  2. ergopose calibrate extrinsics --calibration calibration.toml --board SPEC --board-image NAME=IMAGE ...
     or  ... --points-world floor_points.csv --points-pixels floor_pixels.csv
     (where each camera hangs and looks; world frame = floor, z up, metres)
  3. ergopose calibrate check --calibration calibration.toml --observations bar.csv --length 1.5
     (measures a bar of known length per lens region, like the source paper's Table 1)

Board SPEC: checkerboard:COLSxROWS:SQUARE (INNER corners, square side in metres, e.g.
checkerboard:9x6:0.025), charuco:COLSxROWS:SQUARE:MARKER:DICT (squares, e.g.
charuco:7x5:0.04:0.03:DICT_5X5_100), or a board TOML file."""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "calibrate", help=HELP, description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = parser.add_subparsers(dest="calibrate_command", metavar="STEP", title="steps")

    p = sub.add_parser(
        "intrinsics",
        help="fit the lens model of one camera from board images",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Detect the board in every image of DIR, fit a Kannala-Brandt lens (cv2.fisheye.calibrate;\n"
        "views OpenCV refuses, typically boards far off-axis, are taken back through the full\n"
        "model), optionally refine a Double Sphere model, print the RMS reprojection error and\n"
        "the images left out (and why), and write the camera to the calibration file (other\n"
        "cameras in the file are kept; this camera's pose is reset until extrinsics are run).",
        epilog="Example: ergopose calibrate intrinsics --images photos/cam_1 --board checkerboard:9x6:0.025 "
        "--camera cam_1 --out calibration.toml",
    )
    p.add_argument("--images", required=True, metavar="DIR", help="folder of board images from this camera")
    p.add_argument("--board", required=True, metavar="SPEC", help=BOARD_HELP)
    p.add_argument("--camera", default="cam_1", metavar="NAME", help="camera name in the file (default cam_1)")
    p.add_argument("--out", required=True, metavar="FILE", help="calibration TOML to write or update")
    p.add_argument(
        "--model",
        choices=("kannala_brandt", "double_sphere"),
        default="kannala_brandt",
        help="lens model (double_sphere for lenses wider than 180 degrees; default kannala_brandt)",
    )
    p.add_argument("--min-images", type=int, default=None, metavar="N", help="fewest usable board images (default 8)")
    p.add_argument(
        "--min-coverage",
        type=float,
        default=None,
        metavar="F",
        help="share of the 4x4 image cells the corners must reach (default 0.5)",
    )
    p.set_defaults(func=run_intrinsics)

    p = sub.add_parser(
        "extrinsics",
        help="solve where each camera hangs and looks (world = floor, z up)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Solve each camera's pose through its full lens model (Levenberg-Marquardt) from\n"
        "(a) an image of a board lying face up on the floor (--board-image NAME=IMAGE), or\n"
        "(b) measured floor points: --points-world CSV (columns point,x,y,z in metres) and\n"
        "    --points-pixels CSV (columns camera,point,u,v in pixels).\n"
        "With a board, corner 0 is the world origin unless --board-origin/--board-yaw say otherwise;\n"
        "world x runs down the board's columns of corners and y along its rows (docs/calibration.md).\n"
        "Prints per-point residuals in pixels and millimetres and updates the calibration file.",
        epilog="Example: ergopose calibrate extrinsics --calibration calibration.toml --board "
        "checkerboard:9x6:0.25 --board-image cam_1=floor1.png --board-image cam_2=floor2.png",
    )
    p.add_argument("--calibration", required=True, metavar="FILE", help="calibration TOML with the cameras' intrinsics")
    p.add_argument("--out", metavar="FILE", help="where to write the result (default: update --calibration)")
    p.add_argument("--board", metavar="SPEC", help=BOARD_HELP + " (with --board-image)")
    p.add_argument(
        "--board-image",
        action="append",
        default=[],
        metavar="NAME=IMAGE",
        help="image of the floor board taken by camera NAME (repeat per camera)",
    )
    p.add_argument(
        "--board-origin", default="0,0", metavar="X,Y", help="world position of board corner 0 in metres (default 0,0)"
    )
    p.add_argument(
        "--board-yaw",
        type=float,
        default=0.0,
        metavar="DEG",
        help="board turn about the vertical, degrees counter-clockwise seen from above (default 0)",
    )
    p.add_argument("--points-world", metavar="CSV", help="measured points: point,x,y,z (metres)")
    p.add_argument("--points-pixels", metavar="CSV", help="their pixels: camera,point,u,v")
    p.set_defaults(func=run_extrinsics)

    p = sub.add_parser(
        "check",
        help="measure a bar of known length per lens region (central / outer / edge)",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Triangulate both ends of a bar of known length from its pixels in two or more cameras\n"
        "and print target and measured length per lens region (by the largest angle from a lens\n"
        "axis among the measurement's rays: central < 30 deg, outer 30-60 deg, edge > 60 deg).\n"
        "Observation CSV columns: measurement,camera,end,u,v (end is a or b; one row per camera\n"
        "and end; measurement labels one placement of the bar).\n\n"
        "With --session, the calibration, the observations and the length come from the session's\n"
        "settings.toml ([calibration_check] observations, length_m; docs/session-format.md).",
        epilog="Examples:\n  ergopose calibrate check --session day1/\n"
        "  ergopose calibrate check --calibration calibration.toml --observations bar.csv --length 1.5",
    )
    p.add_argument("--session", metavar="DIR", help="a session folder whose settings name the bar observations")
    p.add_argument("--calibration", metavar="FILE", help="calibration TOML (intrinsics and poses)")
    p.add_argument("--observations", metavar="CSV", help="bar-end pixels (see above)")
    p.add_argument("--length", type=float, metavar="M", help="true bar length, metres")
    p.add_argument(
        "--rings",
        default="30,60",
        metavar="DEG,DEG",
        help="ring bounds in degrees from the lens axis (default 30,60: ergopose's lens regions)",
    )
    p.add_argument("--out", metavar="CSV", help="also write every measurement (length, region, angle) here")
    p.set_defaults(func=run_check)

    parser.set_defaults(func=lambda args: _no_step(parser))
    return parser


def _no_step(parser: argparse.ArgumentParser) -> int:
    parser.print_help()
    return 2


def _progress() -> ProgressBars:
    return ProgressBars()


def _two_floats(text: str, field: str) -> tuple[float, float]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 2 or not all(np.isfinite(values)):
        raise ConfigError(f"expected 2 comma-separated numbers, got {text!r}", field=field)
    return values[0], values[1]


# ------------------------------------------------------------------------- intrinsics
def run_intrinsics(args: argparse.Namespace) -> int:
    board = parse_board(args.board)
    out = Path(args.out)
    existing = load_calibration(out) if out.exists() else ()
    paths = intr.list_images(args.images)
    kwargs = {}
    if args.min_images is not None:
        if args.min_images < 3:
            raise ConfigError(f"must be at least 3, got {args.min_images}", field="--min-images")
        kwargs["min_images"] = args.min_images
    if args.min_coverage is not None:
        if not 0 <= args.min_coverage <= 1:
            raise ConfigError(f"must be between 0 and 1, got {args.min_coverage}", field="--min-coverage")
        kwargs["min_coverage"] = args.min_coverage
    res = intr.calibrate_images(paths, board, model=args.model, progress=_progress(), **kwargs)

    print(
        f"camera {args.camera}: {len(res.used)} of {len(paths)} images used, board {board.spec()}, "
        f"image {res.image_size[0]}x{res.image_size[1]}"
    )
    for source, rms in zip(res.used, res.per_view_rms):
        note = "  (recovered: OpenCV refused it, the full model fits it)" if source in res.recovered else ""
        print(f"  used     {source}: RMS {rms:.3f} px{note}")
    for d in res.dropped:
        print(f"  left out {d.source}: {d.reason}")
    print(
        f"coverage {res.coverage:.0%} of the image, corners up to {np.degrees(res.max_theta_observed):.1f} deg "
        f"from the lens axis"
    )
    if res.model == "double_sphere":
        print(f"Kannala-Brandt RMS {res.kb_rms:.4f} px; Double Sphere RMS {res.rms:.4f} px")
    print(f"RMS reprojection error: {res.rms:.4f} px")
    print(
        "lens: " + ", ".join(f"{k} = {v:.6g}" for k, v in res.lens.to_dict().items() if k != "kind") + f" ({res.model})"
    )

    method = (
        f"{'cv2.fisheye.calibrate (Kannala-Brandt)' if res.model == 'kannala_brandt' else 'Double Sphere least squares from a cv2.fisheye Kannala-Brandt start'}"
        f", {len(res.used)} views of {board.spec()}"
    )
    notes = f"images from {Path(args.images).resolve()}; used {len(res.used)}"
    if res.recovered:
        notes += f"; recovered through the full model: {', '.join(res.recovered)}"
    if res.dropped:
        notes += "; left out: " + "; ".join(f"{d.source} ({d.reason})" for d in res.dropped)
    camera = Camera(
        args.camera,
        res.lens,
        res.image_size[0],
        res.image_size[1],
        np.eye(3),
        np.zeros(3),
        CalibrationInfo(rms_error_px=res.rms, date=dt.date.today().isoformat(), method=method, notes=notes),
    )
    cameras = list(existing)
    names = [c.name for c in cameras]
    if args.camera in names:
        old = cameras[names.index(args.camera)]
        cameras[names.index(args.camera)] = camera
        if not (np.allclose(old.rotation_world_from_cam, np.eye(3)) and np.allclose(old.position_world, 0)):
            print(f"note: the pose of {args.camera} was reset; run 'ergopose calibrate extrinsics' again")
    else:
        cameras.append(camera)
    save_calibration(out, cameras)
    print(f"wrote {out} (camera {args.camera}; pose identity until 'ergopose calibrate extrinsics')")
    return 0


# ------------------------------------------------------------------------- extrinsics
def _read_csv(path: Path, columns: tuple[str, ...]) -> list[tuple[int, dict[str, str]]]:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError("file not found", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read: {exc}", path=path) from None
    reader = csv.DictReader(text.splitlines())
    header = [h.strip() for h in (reader.fieldnames or [])]
    missing = [c for c in columns if c not in header]
    if missing:
        raise InputError(f"missing column(s) {', '.join(missing)}; expected a header {','.join(columns)}", path=path)
    rows = []
    for line, row in enumerate(reader, start=2):
        row = {(k or "").strip(): (v or "").strip() for k, v in row.items()}
        if any(row.values()):
            rows.append((line, row))
    if not rows:
        raise InputError("no rows", path=path)
    return rows


def _number(row: dict[str, str], key: str, line: int, path: Path) -> float:
    try:
        value = float(row[key])
    except ValueError:
        value = float("nan")
    if not np.isfinite(value):
        raise InputError(f"line {line}: {key} must be a number, got {row[key]!r}", path=path)
    return value


def read_point_csvs(
    world_csv: str | Path, pixels_csv: str | Path
) -> dict[str, tuple[list[str], np.ndarray, np.ndarray]]:
    """Per camera: (point names, points_world (N, 3), pixels (N, 2)) from the two CSV files."""
    world_csv, pixels_csv = Path(world_csv), Path(pixels_csv)
    world: dict[str, FloatArray] = {}
    for line, row in _read_csv(world_csv, ("point", "x", "y", "z")):
        name = row["point"]
        if name in world:
            raise InputError(f"line {line}: point {name!r} appears twice", path=world_csv)
        world[name] = np.array([_number(row, k, line, world_csv) for k in ("x", "y", "z")])
    per_camera: dict[str, tuple[list[str], list[FloatArray], list[list[float]]]] = {}
    for line, row in _read_csv(pixels_csv, ("camera", "point", "u", "v")):
        name = row["point"]
        if name not in world:
            raise InputError(f"line {line}: point {name!r} is not in {world_csv.name}", path=pixels_csv)
        names, pts, px = per_camera.setdefault(row["camera"], ([], [], []))
        if name in names:
            raise InputError(f"line {line}: camera {row['camera']!r} lists point {name!r} twice", path=pixels_csv)
        names.append(name)
        pts.append(world[name])
        px.append([_number(row, "u", line, pixels_csv), _number(row, "v", line, pixels_csv)])
    return {cam: (names, np.array(pts), np.array(px)) for cam, (names, pts, px) in per_camera.items()}


def _print_pose(camera: Camera, result: ext.PoseResult) -> None:
    axis = result.rotation_world_from_cam[:, 2]
    tilt = np.degrees(np.arccos(np.clip(-axis[2], -1.0, 1.0)))
    p = result.position_world
    print(
        f"camera {camera.name}: position ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) m, lens axis {tilt:.2f} deg "
        f"from straight down, {len(result.names)} points"
    )
    print(f"  {'point':<14} {'x (m)':>8} {'y (m)':>8} {'z (m)':>8} {'residual px':>12} {'residual mm':>12}")
    for name, pt, rpx, rmm in zip(result.names, result.points_world, result.residuals_px, result.residuals_mm):
        print(f"  {name:<14} {pt[0]:>8.3f} {pt[1]:>8.3f} {pt[2]:>8.3f} {rpx:>12.3f} {rmm:>12.2f}")
    print(
        f"  RMS {result.rms_px:.3f} px, {np.sqrt(np.mean(result.residuals_mm**2)):.2f} mm; "
        f"max {result.residuals_px.max():.3f} px, {result.residuals_mm.max():.2f} mm"
    )


def run_extrinsics(args: argparse.Namespace) -> int:
    cameras = list(load_calibration(args.calibration))
    by_name = {c.name: i for i, c in enumerate(cameras)}
    use_board = bool(args.board_image)
    use_points = bool(args.points_world or args.points_pixels)
    if use_board == use_points:
        raise ConfigError(
            "give either --board-image NAME=IMAGE (with --board) or --points-world and --points-pixels",
            field="extrinsics",
        )
    solved = {}
    if use_board:
        if not args.board:
            raise ConfigError("--board-image needs --board SPEC", field="--board")
        board = parse_board(args.board)
        origin = _two_floats(args.board_origin, "--board-origin")
        yaw = np.radians(args.board_yaw)
        for item in args.board_image:
            name, sep, image_path = item.partition("=")
            if not sep or not name or not image_path:
                raise ConfigError(f"expected NAME=IMAGE, got {item!r}", field="--board-image")
            if name not in by_name:
                raise ConfigError(
                    f"unknown camera {name!r}; the file has {', '.join(by_name)}",
                    path=args.calibration,
                    field="--board-image",
                )
            camera = cameras[by_name[name]]
            image = read_gray(image_path)
            if (image.shape[1], image.shape[0]) != (camera.width, camera.height):
                raise InputError(
                    f"image is {image.shape[1]}x{image.shape[0]} but camera {name} is {camera.width}x{camera.height}",
                    path=image_path,
                )
            det = detect_board(image, board, source=Path(image_path).name)
            if det is None:
                raise InputError(
                    f"the board ({board.spec()}) was not found; check the spec (checkerboard: "
                    f"INNER corners) and that the whole board is visible",
                    path=image_path,
                )
            solved[name] = ext.solve_pose_from_board(camera.lens, det, board, origin, yaw)
    else:
        if not (args.points_world and args.points_pixels):
            raise ConfigError("--points-world and --points-pixels go together", field="extrinsics")
        data = read_point_csvs(args.points_world, args.points_pixels)
        unknown = [c for c in data if c not in by_name]
        if unknown:
            raise InputError(
                f"unknown camera(s) {', '.join(unknown)}; the calibration has {', '.join(by_name)}",
                path=args.points_pixels,
            )
        for name, (names, pts, px) in data.items():
            try:
                solved[name] = ext.solve_pose(cameras[by_name[name]].lens, pts, px, names=names)
            except InputError as exc:
                raise InputError(f"camera {name}: {exc}", path=args.points_pixels) from None
    for name, result in solved.items():
        i = by_name[name]
        cameras[i] = replace(
            cameras[i], rotation_world_from_cam=result.rotation_world_from_cam, position_world=result.position_world
        )
        _print_pose(cameras[i], result)
    out = Path(args.out or args.calibration)
    save_calibration(out, cameras)
    missing = [c.name for c in cameras if c.name not in solved]
    print(f"wrote {out} (poses of {', '.join(solved)})" + (f"; not solved: {', '.join(missing)}" if missing else ""))
    return 0


# ------------------------------------------------------------------------------ check
def run_check(args: argparse.Namespace) -> int:
    if args.session is not None:
        if any(v is not None for v in (args.calibration, args.observations, args.length)):
            raise ConfigError(
                "give either --session or --calibration, --observations and --length, not both", field="--session"
            )

        session = load_session(args.session, check_videos=False)
        if session.calibration_check is None:
            raise ConfigError(
                "the settings name no reference bar: add a [calibration_check] table with "
                "observations (a CSV of bar-end pixels) and length_m",
                path=session.settings_path,
            )
        cameras: Sequence[Camera] = list(session.calibrated_cameras)
        observations, length = session.calibration_check.observations_path, session.calibration_check.length_m
    else:
        missing = [
            o
            for o, v in (
                ("--calibration", args.calibration),
                ("--observations", args.observations),
                ("--length", args.length),
            )
            if v is None
        ]
        if missing:
            raise ConfigError(f"missing {', '.join(missing)} (or give --session DIR)", field=missing[0])
        cameras = load_calibration(args.calibration)
        observations, length = args.observations, args.length
    if len(cameras) < 2:
        raise ConfigError(f"the check needs at least two cameras, the file has {len(cameras)}", path=args.calibration)
    rings = _two_floats(args.rings, "--rings")
    names = [c.name for c in cameras]
    labels, pixels = check.read_bar_observations(observations, names)
    report = check.measure_bar(cameras, pixels, length, ring_bounds_deg=rings, labels=labels)
    m = report.measurements
    print(
        f"Bar length check: target {report.target_length:.3f} m, cameras {', '.join(names)}, "
        f"{len(m.labels)} measurements"
    )
    print(check.format_table(report))
    failed = int(np.sum(~np.isfinite(m.lengths)))
    if failed:
        print(f"{failed} measurement(s) could not be triangulated (rays nearly parallel)", file=sys.stderr)
    if args.out:
        lines = ["measurement,length_m,error_mm,region,max_angle_deg,ray_miss_a_mm,ray_miss_b_mm"]
        for i, label in enumerate(m.labels):
            lines.append(
                f"{label},{m.lengths[i]:.5f},{1000 * (m.lengths[i] - report.target_length):.2f},"
                f"{m.regions[i]},{np.degrees(m.max_angle[i]):.2f},{1000 * m.ray_miss_m[i, 0]:.2f},"
                f"{1000 * m.ray_miss_m[i, 1]:.2f}"
            )
        write_text(args.out, "\n".join(lines) + "\n")
        print(f"wrote {args.out}")
    return 0
