"""Reading TRC marker files (the text format of OpenSim, Pose2Sim and motion-capture exports).

Layout (tab-separated)::

    PathFileType  4  (X/Y/Z)  name.trc
    DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  OrigDataStartFrame  OrigNumFrames
    60        60          100        21          m      60            0                   100
    Frame#  Time  RHip        RKnee  ...          (one name per marker, then two empty cells)
                  X1  Y1  Z1  X2  Y2  Z2  ...
    1       0.0167  -0.065  0.90  -1.40  ...      (one row per frame; empty cells = marker missing)

By the TRC convention Y is up (OpenSim's ground frame). Units are given in the header (m, cm or mm)
and converted to metres here. Marker names are kept as written; :mod:`ergopose.evaluation.markers`
maps them onto BlazePose joints.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ergopose.errors import InputError

#: Length units of the header's ``Units`` field, in metres.
TRC_UNITS = {"m": 1.0, "meters": 1.0, "cm": 0.01, "mm": 0.001, "millimeters": 0.001}


@dataclass(frozen=True)
class TrcData:
    """A TRC file read: ``markers`` names in file order, ``points_trc`` (F, M, 3) in metres in the
    file's own axes (Y up by convention; NaN = missing), ``frame_numbers`` (F,) as written,
    ``times_s`` (F,) as written, ``rate_hz`` the header's DataRate."""

    path: Path
    markers: tuple[str, ...]
    points_trc: np.ndarray
    frame_numbers: np.ndarray
    times_s: np.ndarray
    rate_hz: float
    units: str


def read_trc(path: str | os.PathLike) -> TrcData:
    """Read a TRC file; InputError naming the file and the line for anything malformed."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except FileNotFoundError:
        raise InputError("the reference TRC file does not exist", path=path) from None
    except OSError as exc:
        raise InputError(f"cannot read the TRC file ({exc})", path=path) from None
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise InputError("not a TRC file (the first line must start with PathFileType)", path=path)
    keys = lines[1].split("\t")
    values = lines[2].split("\t")
    header = {k.strip(): v.strip() for k, v in zip(keys, values)}
    for key in ("DataRate", "NumMarkers", "Units"):
        if key not in header:
            raise InputError(f"the header (line 2-3) has no {key}", path=path, field=key)
    try:
        rate = float(header["DataRate"])
    except ValueError:
        rate = math.nan
    if not (math.isfinite(rate) and rate > 0):
        raise InputError(f"DataRate must be a positive number, got {header['DataRate']!r}", path=path, field="DataRate")
    units = header["Units"].lower()
    if units not in TRC_UNITS:
        raise InputError(f"unknown Units {header['Units']!r} (known: {', '.join(TRC_UNITS)})", path=path, field="Units")
    names_row = lines[3].split("\t")
    if len(names_row) < 3 or names_row[0].strip() != "Frame#":
        raise InputError("line 4 must start with Frame# and Time, then the marker names", path=path)
    markers = tuple(n.strip() for n in names_row[2:] if n.strip())
    try:
        declared = int(float(header["NumMarkers"]))
    except ValueError:
        declared = -1
    if declared != len(markers):
        raise InputError(
            f"the header declares {header['NumMarkers']} markers but line 4 names {len(markers)}",
            path=path,
            field="NumMarkers",
        )
    if not markers:
        raise InputError("no markers", path=path)
    width = 2 + 3 * len(markers)
    rows = []
    for number, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        cells = line.split("\t")
        cells = cells + [""] * (width - len(cells)) if len(cells) < width else cells[:width]
        try:
            rows.append([float(c) if c.strip() else math.nan for c in cells])
        except ValueError:
            raise InputError(f"line {number}: expected numbers, got {line[:60]!r}", path=path) from None
    if not rows:
        raise InputError("no frames", path=path)
    data = np.array(rows, dtype=np.float64)
    frame_numbers, times = data[:, 0], data[:, 1]
    if not np.isfinite(times).all() or (len(times) > 1 and not np.all(np.diff(times) > 0)):
        raise InputError("the Time column must be finite and strictly increasing", path=path, field="Time")
    points = data[:, 2:].reshape(len(data), len(markers), 3) * TRC_UNITS[units]
    return TrcData(
        path=path,
        markers=markers,
        points_trc=points,
        frame_numbers=frame_numbers,
        times_s=times,
        rate_hz=rate,
        units=units,
    )


__all__ = ["TrcData", "read_trc", "TRC_UNITS"]
