"""The camera calibration file: TOML, versioned, human-readable (docs/calibration-file.md).

    format_version = 1

    [[cameras]]                 # one block per camera, in the order the session uses them
    name = "cam_1"
    width = 2592                # image size, pixels
    height = 1944
    image_circle = [1295.5, 971.5, 960.0]   # optional: lit circle u, v, radius (pixels)

    [cameras.lens]              # kind + that model's parameters (ergopose.geometry.lenses)
    kind = "kannala_brandt"
    fx = 620.0
    ...

    [cameras.pose]              # p_world = rotation_world_from_cam @ p_cam + position_world
    rotation_world_from_cam = [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]   # rows
    position_world = [0.0, 0.0, 3.0]                                                  # metres
    # or instead of the matrix: rodrigues_world_from_cam = [rx, ry, rz] (axis * angle, rad)

    [cameras.calibration]       # optional provenance
    rms_error_px = 0.26
    date = "2024-05-01"

Cameras come back in file order (never sorted by name). Every problem raises one ConfigError
naming the file and the field (``cameras[1].lens.fx``) and saying what is wrong; unknown keys
are errors too, so a typo never silently falls back to a default.

Importers: :func:`camera_from_opencv_fisheye` (K, D and optionally OpenCV's world -> camera
R, t), :func:`read_opencv_fisheye_file` (K and D from a cv2.FileStorage YAML/XML file) and
:func:`read_pose2sim_calibration` (the calibration TOML of Pose2Sim and anipose).
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import math
import os
import tomllib
from pathlib import Path
from typing import Any, Iterable, Sequence

import cv2
import numpy as np
import tomli_w

from ergopose.arrays import FloatArray
from ergopose.atomic import write_text
from ergopose.errors import ConfigError, ErgoposeError
from ergopose.geometry.camera import CalibrationInfo, Camera, check_rotation
from ergopose.geometry.lenses import LensModel, lens_from_dict
from ergopose.geometry.lenses.brown_conrady import BrownConrady
from ergopose.geometry.lenses.kannala_brandt import KannalaBrandt

#: The version this code writes; it reads exactly the versions in SUPPORTED_VERSIONS.
FORMAT_VERSION = 1
SUPPORTED_VERSIONS = (1,)

_TOP_KEYS = {"format_version", "description", "cameras"}
_CAMERA_KEYS = {"name", "width", "height", "lens", "pose", "calibration", "image_circle"}
_POSE_KEYS = {"rotation_world_from_cam", "rodrigues_world_from_cam", "position_world"}
_CALIBRATION_KEYS = {"rms_error_px", "date", "method", "notes"}

_HEADER = """\
# ergopose camera calibration (format: docs/calibration-file.md).
# Units: metres and radians; pixels for image sizes, focal lengths and principal points.
# World frame: floor z = 0, z up. Camera frame: x right, y down, z along the lens axis.
# Pose: p_world = rotation_world_from_cam @ p_cam + position_world (the matrix is listed by rows;
# its columns are the camera's x, y, z axes in world coordinates).
"""


# --- loading ---------------------------------------------------------------------------------------


def load_calibration(path: str | os.PathLike[str]) -> tuple[Camera, ...]:
    """Read and check a calibration file; the cameras in file order.

    Raises ConfigError (naming the file and the field) for a missing or unreadable file, TOML
    syntax errors, missing or unknown keys, wrong types, non-positive sizes, non-rotation
    matrices, unknown lens kinds, invalid lens parameters, duplicate camera names and
    unsupported format versions.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("calibration file not found", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the calibration file ({exc})", path=path) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", path=path) from None
    return cameras_from_dict(data, path=path)


def cameras_from_dict(data: dict[str, Any], path: str | os.PathLike[str] | None = None) -> tuple[Camera, ...]:
    """The checks of :func:`load_calibration` on an already parsed TOML table."""
    _no_unknown_keys(data, _TOP_KEYS, "", path)
    if "format_version" not in data:
        raise ConfigError(
            f"missing; this program writes format_version = {FORMAT_VERSION}", path=path, field="format_version"
        )
    version = data["format_version"]
    if isinstance(version, bool) or not isinstance(version, int):
        raise ConfigError(f"expected a whole number, got {version!r}", path=path, field="format_version")
    if version not in SUPPORTED_VERSIONS:
        raise ConfigError(
            f"version {version} is not supported (this program reads {', '.join(map(str, SUPPORTED_VERSIONS))}); "
            "a newer ergopose may have written it",
            path=path,
            field="format_version",
        )
    if "description" in data and not isinstance(data["description"], str):
        raise ConfigError(f"expected text, got {data['description']!r}", path=path, field="description")
    cameras = data.get("cameras")
    if cameras is None:
        raise ConfigError("missing: add one [[cameras]] block per camera", path=path, field="cameras")
    if not isinstance(cameras, list) or not all(isinstance(c, dict) for c in cameras):
        raise ConfigError("expected [[cameras]] blocks (an array of tables)", path=path, field="cameras")
    if not cameras:
        raise ConfigError("no cameras: add one [[cameras]] block per camera", path=path, field="cameras")
    out: list[Camera] = []
    seen: dict[str, int] = {}
    for index, table in enumerate(cameras):
        camera = _camera_from_table(table, f"cameras[{index}]", path)
        if camera.name in seen:
            raise ConfigError(
                f"duplicate camera name {camera.name!r} (also cameras[{seen[camera.name]}])",
                path=path,
                field=f"cameras[{index}].name",
            )
        seen[camera.name] = index
        out.append(camera)
    return tuple(out)


def _camera_from_table(table: dict[str, Any], where: str, path: Any) -> Camera:
    name = table.get("name")
    label = f" (camera {name!r})" if isinstance(name, str) and name.strip() else ""
    _no_unknown_keys(table, _CAMERA_KEYS, where, path, label)
    for key in ("name", "width", "height", "lens", "pose"):
        if key not in table:
            raise ConfigError(f"missing{label}", path=path, field=f"{where}.{key}")
    if not isinstance(name, str) or not name.strip():  # the same test as the label's
        raise ConfigError(f"expected a non-empty text, got {name!r}", path=path, field=f"{where}.name")
    for key in ("width", "height"):
        value = table[key]
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(
                f"expected a whole number of pixels, got {value!r}{label}", path=path, field=f"{where}.{key}"
            )
        if value <= 0:
            raise ConfigError(f"must be positive, got {value}{label}", path=path, field=f"{where}.{key}")
    lens_table = table["lens"]
    if not isinstance(lens_table, dict):
        raise ConfigError(f"expected a [cameras.lens] table{label}", path=path, field=f"{where}.lens")
    try:
        lens = lens_from_dict(lens_table)
    except ErgoposeError as exc:
        raise _relocated(exc, where, label, path) from None
    rotation, position = _pose_from_table(table["pose"], f"{where}.pose", label, path)
    calibration = _calibration_from_table(table.get("calibration", {}), where, label, path)
    circle = None
    if "image_circle" in table:
        circle = _numbers(table["image_circle"], (3,), f"{where}.image_circle", label, path)
        if not circle[2] > 0:
            raise ConfigError(
                f"the radius (third number) must be positive, got {circle[2]!r}{label}",
                path=path,
                field=f"{where}.image_circle",
            )
    try:
        return Camera(
            name=name,
            lens=lens,
            width=table["width"],
            height=table["height"],
            rotation_world_from_cam=rotation,
            position_world=position,
            calibration=calibration,
            image_circle=None if circle is None else tuple(circle),
        )
    except ErgoposeError as exc:
        raise _relocated(exc, where, label, path) from None


def _pose_from_table(pose: Any, where: str, label: str, path: Any) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(pose, dict):
        raise ConfigError(f"expected a [cameras.pose] table{label}", path=path, field=where)
    _no_unknown_keys(pose, _POSE_KEYS, where, path, label)
    has_matrix = "rotation_world_from_cam" in pose
    has_vector = "rodrigues_world_from_cam" in pose
    if has_matrix == has_vector:
        raise ConfigError(
            "give exactly one of rotation_world_from_cam (3 rows of 3 numbers) or rodrigues_world_from_cam "
            f"(3 numbers){label}",
            path=path,
            field=f"{where}.rotation_world_from_cam",
        )
    if "position_world" not in pose:
        raise ConfigError(f"missing{label}", path=path, field=f"{where}.position_world")
    position = _numbers(pose["position_world"], (3,), f"{where}.position_world", label, path)
    if has_matrix:
        field = f"{where}.rotation_world_from_cam"
        rotation = _numbers(pose["rotation_world_from_cam"], (3, 3), field, label, path)
    else:
        field = f"{where}.rodrigues_world_from_cam"
        rotation = rotation_from_rodrigues(_numbers(pose["rodrigues_world_from_cam"], (3,), field, label, path))
    try:
        check_rotation(rotation, field=field)
    except ConfigError as exc:
        raise ConfigError(f"{_message(exc)}{label}", path=path, field=field) from None
    return rotation, position


def _calibration_from_table(table: Any, where: str, label: str, path: Any) -> CalibrationInfo:
    if not isinstance(table, dict):
        raise ConfigError(f"expected a [cameras.calibration] table{label}", path=path, field=f"{where}.calibration")
    _no_unknown_keys(table, _CALIBRATION_KEYS, f"{where}.calibration", path, label)
    values = dict(table)
    date = values.get("date")
    if isinstance(date, (_dt.date, _dt.datetime, _dt.time)):
        values["date"] = date.isoformat()
    try:
        return CalibrationInfo(**values)
    except ConfigError as exc:
        raise _relocated(exc, where, label, path) from None


def _numbers(value: Any, shape: tuple[int, ...], field: str, label: str, path: Any) -> np.ndarray:
    def bad() -> ConfigError:
        what = "3 numbers" if shape == (3,) else "3 rows of 3 numbers"
        return ConfigError(f"expected {what}, got {value!r}{label}", path=path, field=field)

    if not isinstance(value, list):
        raise bad()
    rows = value if len(shape) == 2 else [value]
    if len(shape) == 2 and len(rows) != shape[0]:
        raise bad()
    for row in rows:
        if not isinstance(row, list) or len(row) != shape[-1]:
            raise bad()
        for x in row:
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise bad()
    return np.array(value, dtype=np.float64)


def _no_unknown_keys(table: dict[str, Any], allowed: set[str], where: str, path: Any, label: str = "") -> None:
    unknown = [k for k in table if k not in allowed]
    if unknown:
        prefix = f"{where}." if where else ""
        raise ConfigError(
            f"unknown key {unknown[0]!r}{label} (allowed here: {', '.join(sorted(allowed))})",
            path=path,
            field=f"{prefix}{unknown[0]}",
        )


def _message(exc: ErgoposeError) -> str:
    """The error's own sentence, without the 'path: field: ' prefix."""
    text = str(exc)
    prefix = ""
    if exc.path:
        prefix += f"{exc.path}: "
    if exc.field:
        prefix += f"{exc.field}: "
    return text[len(prefix) :] if text.startswith(prefix) else text


def _relocated(exc: ErgoposeError, where: str, label: str, path: Any) -> ConfigError:
    """A lens/camera error re-issued with the file and the camera's place in it."""
    field = f"{where}.{exc.field}" if exc.field else where
    return ConfigError(f"{_message(exc)}{label}", path=path, field=field)


# --- saving ----------------------------------------------------------------------------------------


def save_calibration(path: str | os.PathLike[str], cameras: Sequence[Camera], description: str | None = None) -> Path:
    """Write ``cameras`` (in the given order) atomically; returns the path.

    Floats are written with full precision, so load_calibration(save_calibration(p, cams))
    gives back equal cameras.
    """
    text = calibration_to_toml(cameras, description)
    # Never write what we could not read back.
    cameras_from_dict(tomllib.loads(text), path=path)
    return write_text(path, text)


def calibration_to_toml(cameras: Sequence[Camera], description: str | None = None) -> str:
    """The file text for ``cameras`` (see :func:`save_calibration`)."""
    cameras = list(cameras)
    if not cameras:
        raise ConfigError("nothing to save: no cameras", field="cameras")
    names = [c.name for c in cameras]
    if len(set(names)) != len(names):
        raise ConfigError(f"camera names must be unique, got {names}", field="cameras")
    lines = [_HEADER.rstrip("\n"), f"format_version = {FORMAT_VERSION}"]
    if description is not None:
        lines.append(f"description = {_value(description)}")
    for camera in cameras:
        lines += [
            "",
            "[[cameras]]",
            f"name = {_value(camera.name)}",
            f"width = {camera.width}",
            f"height = {camera.height}",
        ]
        if camera.image_circle is not None:
            lines.append(f"image_circle = {_array(camera.image_circle)}   # u, v, radius (pixels)")
        lines += ["", "[cameras.lens]"]
        lens = camera.lens.to_dict()
        lines.append(f"kind = {_value(lens.pop('kind'))}")
        lines += [f"{key} = {_value(float(v))}" for key, v in lens.items()]
        rotation = camera.rotation_world_from_cam
        lines += ["", "[cameras.pose]", "rotation_world_from_cam = ["]
        lines += [f"    {_array(row)}," for row in rotation]
        lines += ["]", f"position_world = {_array(camera.position_world)}"]
        info = camera.calibration
        if not info.is_empty():
            lines += ["", "[cameras.calibration]"]
            for key in ("rms_error_px", "date", "method", "notes"):
                value = getattr(info, key)
                if value is not None:
                    lines.append(f"{key} = {_value(value)}")
    return "\n".join(lines) + "\n"


def _value(value: Any) -> str:
    """One TOML value, formatted (and string-escaped) by tomli_w."""
    return tomli_w.dumps({"v": value})[len("v = ") :].rstrip("\n")


def _array(values: Iterable[float]) -> str:
    return "[" + ", ".join(_value(float(v)) for v in values) + "]"


# --- OpenCV importers ------------------------------------------------------------------------------


def rotation_from_rodrigues(rvec: Any) -> FloatArray:
    """Rotation matrix of an axis-angle vector (direction = axis, length = angle in radians)."""
    r = np.asarray(rvec, dtype=np.float64).reshape(3)
    angle = float(np.linalg.norm(r))
    if angle < 1e-300:
        return np.eye(3)
    k = r / angle
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    rotation: FloatArray = np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * (kx @ kx)
    return rotation


def camera_from_opencv_fisheye(
    name: str,
    K: Any,
    D: Any,
    width: int,
    height: int,
    R: Any = None,
    t: Any = None,
    calibration: CalibrationInfo = CalibrationInfo(),
) -> Camera:
    """A Kannala-Brandt camera from cv2.fisheye's K (3x3) and D (k1..k4).

    ``R`` (3x3 matrix or Rodrigues 3-vector) and ``t`` are OpenCV's extrinsics, world -> camera
    (x_cam = R x_world + t, as from cv2.fisheye.calibrate or solvePnP); the camera's pose is then
    rotation_world_from_cam = R^T and position_world = -R^T t. Without them the camera frame is
    the world frame (identity pose): set the real pose before using the camera in a session.
    """
    lens = KannalaBrandt.from_opencv(K, D)
    if (R is None) != (t is None):
        raise ConfigError("give both R and t (world -> camera) or neither", field="R" if R is None else "t")
    rotation: FloatArray
    position: FloatArray
    if R is None:
        rotation, position = np.eye(3), np.zeros(3)
    else:
        r = np.asarray(R, dtype=np.float64)
        r_cam_from_world = rotation_from_rodrigues(r) if r.size == 3 else r.reshape(3, 3)
        check_rotation(r_cam_from_world, field="R")
        t = np.asarray(t, dtype=np.float64).reshape(3)
        rotation = r_cam_from_world.T
        position = -rotation @ t
    return Camera(
        name=name,
        lens=lens,
        width=width,
        height=height,
        rotation_world_from_cam=rotation,
        position_world=position,
        calibration=calibration,
    )


#: Node names tried, in order, for the camera matrix and the distortion coefficients.
OPENCV_K_NAMES = ("K", "camera_matrix", "cameraMatrix", "intrinsics")
OPENCV_D_NAMES = ("D", "distortion_coefficients", "dist_coeffs", "distCoeffs", "distortion")


def read_opencv_fisheye_file(path: str | os.PathLike[str]) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """(K 3x3, D (4,), extras) from an OpenCV FileStorage file (.yml, .yaml, .xml, .json).

    K is read from the first node of :data:`OPENCV_K_NAMES` present, D from
    :data:`OPENCV_D_NAMES`. ``extras`` holds ``image_width`` / ``image_height`` (from nodes of
    those names or an ``image_size`` pair) and ``rms_error_px`` (node ``rms`` or
    ``avg_reprojection_error``) where the file has them.
    """
    path = Path(path)
    if not path.is_file():
        raise ConfigError("OpenCV calibration file not found", path=path)
    try:
        storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    except (cv2.error, SystemError):  # cv2 raises SystemError for syntax errors
        storage = None
    if storage is None or not storage.isOpened():
        raise ConfigError(
            "not a readable OpenCV FileStorage file (YAML, XML or JSON as written by "
            "cv2.FileStorage, with nodes K and D)",
            path=path,
        )
    try:

        def matrix(names: Sequence[str]) -> tuple[str, np.ndarray] | None:
            for node_name in names:
                node = storage.getNode(node_name)
                if not node.empty():
                    value = node.mat()
                    if value is None and node.isSeq():
                        value = np.array([node.at(i).real() for i in range(node.size())])
                    if value is not None:
                        return node_name, np.asarray(value, dtype=np.float64)
            return None

        found_k = matrix(OPENCV_K_NAMES)
        found_d = matrix(OPENCV_D_NAMES)
        if found_k is None:
            raise ConfigError(f"no camera matrix (looked for nodes {', '.join(OPENCV_K_NAMES)})", path=path, field="K")
        if found_d is None:
            raise ConfigError(
                f"no distortion coefficients (looked for nodes {', '.join(OPENCV_D_NAMES)})", path=path, field="D"
            )
        extras: dict[str, Any] = {}
        for key in ("image_width", "image_height"):
            node = storage.getNode(key)
            if not node.empty() and node.isInt():
                extras[key] = int(node.real())
        node = storage.getNode("image_size")
        if not node.empty():
            size = node.mat()
            if size is None and node.isSeq() and node.size() == 2:
                size = [node.at(0).real(), node.at(1).real()]
            if size is not None and np.asarray(size).size == 2:
                w, h = np.asarray(size, dtype=np.float64).ravel()
                extras.setdefault("image_width", int(w))
                extras.setdefault("image_height", int(h))
        for key in ("rms", "avg_reprojection_error"):
            node = storage.getNode(key)
            if not node.empty() and node.isReal():
                extras["rms_error_px"] = float(node.real())
                break
    finally:
        storage.release()
    k_name, K = found_k
    d_name, D = found_d
    if K.shape != (3, 3):
        raise ConfigError(f"expected a 3x3 matrix, got shape {K.shape}", path=path, field=k_name)
    if D.size != 4:
        raise ConfigError(
            f"expected the 4 fisheye coefficients k1..k4, got {D.size} values (a non-fisheye OpenCV model?)",
            path=path,
            field=d_name,
        )
    return K, D.reshape(4), extras


# --- Pose2Sim / anipose calibration TOML -----------------------------------------------------------

#: Length units a Pose2Sim/anipose translation may be in, and their size in metres.
LENGTH_UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}
_TOML_CAMERA_KEYS = {"name", "size", "matrix", "distortions", "rotation", "translation", "fisheye"}


def read_pose2sim_calibration(path: str | os.PathLike[str], units: str = "m") -> tuple[Camera, ...]:
    """The cameras of a calibration TOML written by Pose2Sim or anipose (aniposelib), in file order.

    Layout: one table per camera (``[cam_01]``, ``[cam_0]``, ...) with ``name``, ``size`` = [width,
    height] in pixels, ``matrix`` (3x3 K), ``distortions`` (OpenCV's k1, k2, p1, p2[, k3], or the
    four cv2.fisheye k1..k4 when ``fisheye = true``), ``rotation`` (Rodrigues vector) and
    ``translation``: the extrinsics map world to camera, x_cam = R x_world + t, as OpenCV's rvec and
    tvec (checked on the Pose2Sim demo: its own 3D output reprojects onto its 2D keypoints with a
    median of 10.7 px this way and over 2,000 px the other way). Other tables (``[metadata]``) are
    ignored. ``units``: the length unit of ``translation`` (Pose2Sim writes metres; anipose writes the
    unit of the board's square size, often millimetres).

    The world frame is kept as the file has it: ergopose needs floor z = 0 and z up; Pose2Sim's
    Qualisys or board-defined worlds usually are, anipose's (the first camera's frame) are not --
    see :func:`world_frame_warnings`.
    """
    path = Path(path)
    if units not in LENGTH_UNITS:
        raise ConfigError(f"unknown length unit {units!r} (known: {', '.join(LENGTH_UNITS)})", field="units")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("calibration file not found", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the calibration file ({exc})", path=path) from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", path=path) from None
    if "format_version" in data and "cameras" in data:
        raise ConfigError("this is already an ergopose calibration file: use it as it is", path=path)
    tables = [(k, v) for k, v in data.items() if isinstance(v, dict) and k != "metadata"]
    if not tables:
        raise ConfigError(
            "no camera tables: expected [cam_01] (Pose2Sim) or [cam_0] (anipose) tables with "
            "name, size, matrix, distortions, rotation and translation",
            path=path,
        )
    scale = LENGTH_UNITS[units]
    cameras: list[Camera] = []
    seen: dict[str, str] = {}
    for key, table in tables:
        where = key
        unknown = [k for k in table if k not in _TOML_CAMERA_KEYS]
        if unknown:
            raise ConfigError(
                f"unknown key {unknown[0]!r} (a Pose2Sim/anipose camera table has "
                f"{', '.join(sorted(_TOML_CAMERA_KEYS))})",
                path=path,
                field=f"{where}.{unknown[0]}",
            )
        for field in ("size", "matrix", "distortions", "rotation", "translation"):
            if field not in table:
                raise ConfigError("missing", path=path, field=f"{where}.{field}")
        name = table.get("name", key)
        if not isinstance(name, str) or not name.strip():
            raise ConfigError(f"expected a non-empty text, got {name!r}", path=path, field=f"{where}.name")
        if name in seen:
            raise ConfigError(f"duplicate camera name {name!r} (also [{seen[name]}])", path=path, field=f"{where}.name")
        seen[name] = key
        size = _toml_numbers(table["size"], (2,), f"{where}.size", path)
        if not all(v > 0 and float(v).is_integer() for v in size):
            raise ConfigError(
                f"expected [width, height] in whole pixels, got {table['size']!r}", path=path, field=f"{where}.size"
            )
        K = _toml_numbers(table["matrix"], (3, 3), f"{where}.matrix", path)
        dist = np.asarray(table["distortions"], dtype=object)
        dist = _toml_numbers(table["distortions"], (dist.size,), f"{where}.distortions", path)
        rvec = _toml_numbers(table["rotation"], (3,), f"{where}.rotation", path)
        tvec = _toml_numbers(table["translation"], (3,), f"{where}.translation", path) * scale
        fisheye = table.get("fisheye", False)
        if not isinstance(fisheye, bool):
            raise ConfigError(f"expected true or false, got {fisheye!r}", path=path, field=f"{where}.fisheye")
        info = CalibrationInfo(
            method=f"imported from {path.name} ({'fisheye' if fisheye else 'pinhole'} model, Pose2Sim/anipose layout)"
        )
        lens: LensModel
        try:
            if fisheye:
                if dist.size != 4:
                    raise ConfigError(
                        f"a fisheye camera has 4 coefficients k1..k4, got {dist.size}", field="distortions"
                    )
                lens = KannalaBrandt.from_opencv(K, dist)
            else:
                lens = BrownConrady.from_opencv(K, dist)
            r_cam_from_world = rotation_from_rodrigues(rvec)
            rotation = r_cam_from_world.T
            cameras.append(
                Camera(
                    name=name,
                    lens=lens,
                    width=int(size[0]),
                    height=int(size[1]),
                    rotation_world_from_cam=rotation,
                    position_world=-rotation @ tvec,
                    calibration=info,
                )
            )
        except ErgoposeError as exc:
            sub = f"{where}.{exc.field}" if exc.field and not exc.field.startswith("lens.") else where
            raise ConfigError(_message(exc), path=path, field=sub) from None
    return tuple(cameras)


def _toml_numbers(value: Any, shape: tuple[int, ...], field: str, path: Any) -> np.ndarray:
    try:
        arr = np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != shape or not np.isfinite(arr).all() or _has_bool(value):
        what = {(2,): "[width, height]", (3,): "3 numbers", (3, 3): "3 rows of 3 numbers"}.get(shape, "numbers")
        raise ConfigError(f"expected {what}, got {value!r}", path=path, field=field)
    return arr


def _has_bool(value: Any) -> bool:
    if isinstance(value, list):
        return any(_has_bool(v) for v in value)
    return isinstance(value, bool)


#: Largest crop (pixels per dimension) taken as an encoder's padding rather than a wrong video:
#: encoders pad frames to blocks of 16 pixels, so a calibration of 1088 x 1920 px can belong to a
#: video of 1080 x 1920 (the calibrated image cropped at the right/bottom).
MAX_PADDING_PX = 15


def read_any_calibration(path: str | os.PathLike[str], units: str = "m") -> tuple[tuple[Camera, ...], str]:
    """The cameras of an ergopose calibration file or of a Pose2Sim/anipose calibration TOML, and
    which of the two it was ("ergopose" or "Pose2Sim/anipose"). ``units``: the length unit of a
    Pose2Sim/anipose file's translations."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError("calibration file not found", path=p) from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read the calibration file ({exc})", path=p) from None
    if "format_version" in data or "cameras" in data:
        return load_calibration(p), "ergopose"
    return read_pose2sim_calibration(p, units=units), "Pose2Sim/anipose"


def camera_for_video(camera: Camera, width: int, height: int) -> Camera | None:
    """``camera`` for a video of width x height pixels: itself when the sizes agree; with the
    video's size when the video is the calibrated image cropped by an encoder's padding (0 to
    MAX_PADDING_PX pixels at the right/bottom; the pixel coordinates are kept); None when the video
    cannot be this camera's image (a scaled or different video)."""
    if (width, height) == (camera.width, camera.height):
        return camera
    dw, dh = camera.width - width, camera.height - height
    if 0 <= dw <= MAX_PADDING_PX and 0 <= dh <= MAX_PADDING_PX:
        return dataclasses.replace(camera, width=int(width), height=int(height))
    return None


def world_frame_warnings(cameras: Sequence[Camera]) -> list[str]:
    """Sentences for a user whose imported world frame does not look like floor z = 0, z up:
    a camera below the floor or looking more than 30 degrees upwards (with z up, cameras in a work
    area hang above the floor and look down or level), or most cameras' distances from the world
    origin above 100 (a translation in millimetres read as metres)."""
    out = []
    low = [c.name for c in cameras if c.position_world[2] <= 0.0]
    up = [c.name for c in cameras if c.axis_world[2] > 0.5]
    if low or up:
        out.append(
            "the world frame does not look like floor z = 0, z up ("
            + "; ".join(
                x
                for x in (
                    f"camera(s) at or below z = 0: {', '.join(low)}" if low else "",
                    f"camera(s) looking upwards: {', '.join(up)}" if up else "",
                )
                if x
            )
            + "); anipose's world is its first camera's frame: set the poses against the floor "
            "before assessing"
        )
    far = float(np.median([np.linalg.norm(c.position_world) for c in cameras]))
    if far > 100.0:
        out.append(
            f"the cameras are a median {far:.0f} m from the world origin: are the translations in "
            "millimetres (give the unit)?"
        )
    return out


__all__ = [
    "FORMAT_VERSION",
    "SUPPORTED_VERSIONS",
    "load_calibration",
    "save_calibration",
    "cameras_from_dict",
    "calibration_to_toml",
    "camera_from_opencv_fisheye",
    "read_opencv_fisheye_file",
    "rotation_from_rodrigues",
    "read_pose2sim_calibration",
    "read_any_calibration",
    "camera_for_video",
    "MAX_PADDING_PX",
    "world_frame_warnings",
    "LENGTH_UNITS",
]
