"""Calibration boards: description, corner detection and a printable texture.

Two kinds of board:

- ``checkerboard``: ``cols x rows`` INNER corners (OpenCV's pattern size), squares of ``square``
  metres. Object points: corner (c, r) at (c * square, r * square, 0) in the board frame, in
  OpenCV's row-major order (index = r * cols + c). The board frame has x along the rows of
  corners, y down the columns, z into the board (right-handed, as OpenCV's object points).
  The board has ``cols + 1`` by ``rows + 1`` squares; the square diagonally outside corner 0
  is black (this is the convention :func:`board_texture` prints and
  :func:`detect_board` uses to fix the 180-degree ambiguity on boards that have one).
- ``charuco``: ``squares_x x squares_y`` SQUARES with ArUco markers of ``marker`` metres from the
  dictionary ``dictionary`` (e.g. DICT_5X5_100). Object points are OpenCV's
  ``CharucoBoard.getChessboardCorners()``; every detected corner carries its id, so partial
  views are fine and there is no orientation ambiguity.

Board specs on the command line:
``checkerboard:9x6:0.025`` (inner corners, square in metres) and
``charuco:7x5:0.04:0.03:DICT_5X5_100`` (squares, square and marker in metres, dictionary),
or the path of a TOML board file (see docs/calibration.md).
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import ConfigError

KINDS = ("checkerboard", "charuco")


@dataclass(frozen=True)
class Board:
    """A planar calibration target.

    kind: "checkerboard" or "charuco".
    cols, rows: inner corners (checkerboard) or squares (charuco) along x and y.
    square: side of one square, metres.
    marker: side of one ArUco marker, metres (charuco only, else 0).
    dictionary: OpenCV ArUco dictionary name (charuco only, else "").
    """

    kind: str
    cols: int
    rows: int
    square: float
    marker: float = 0.0
    dictionary: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ConfigError(f"unknown board kind {self.kind!r}; expected one of {', '.join(KINDS)}", field="board")
        if self.cols < 2 or self.rows < 2:
            raise ConfigError(
                f"a board needs at least 2 x 2 corners/squares, got {self.cols}x{self.rows}", field="board"
            )
        if not (self.square > 0 and np.isfinite(self.square)):
            raise ConfigError(f"square size must be a positive number of metres, got {self.square}", field="board")
        if self.kind == "charuco":
            if not (0 < self.marker < self.square):
                raise ConfigError(
                    f"charuco marker size must be between 0 and the square size ({self.square} m), got {self.marker}",
                    field="board",
                )
            if not self.dictionary.startswith("DICT_") or not hasattr(cv2.aruco, self.dictionary):
                raise ConfigError(f"unknown ArUco dictionary {self.dictionary!r} (e.g. DICT_5X5_100)", field="board")
            if self.cols < 3 or self.rows < 3:
                raise ConfigError("a charuco board needs at least 3 x 3 squares", field="board")

    # ------------------------------------------------------------------ geometry
    @property
    def pattern_size(self) -> tuple[int, int]:
        """OpenCV's pattern size (inner corners along x, along y)."""
        if self.kind == "checkerboard":
            return (self.cols, self.rows)
        return (self.cols - 1, self.rows - 1)

    @property
    def n_corners(self) -> int:
        c, r = self.pattern_size
        return c * r

    @property
    def squares(self) -> tuple[int, int]:
        """Number of squares along x and y."""
        if self.kind == "checkerboard":
            return (self.cols + 1, self.rows + 1)
        return (self.cols, self.rows)

    @property
    def origin_offset(self) -> float:
        """Distance (metres, along x and y) from the outer corner of the square grid to object point 0's frame origin.

        Checkerboard object points start at the first inner corner, so the grid's outer corner is at
        (-square, -square); ChArUco object points are measured from the grid's outer corner (0).
        """
        return self.square if self.kind == "checkerboard" else 0.0

    def object_points(self) -> np.ndarray:
        """(n_corners, 3) float64 corner positions in the board frame, metres (z = 0)."""
        if self.kind == "charuco":
            pts = np.asarray(self._charuco().getChessboardCorners(), dtype=np.float64).reshape(-1, 3)
            return pts
        c, r = np.meshgrid(np.arange(self.cols), np.arange(self.rows))
        pts = np.stack([c.ravel() * self.square, r.ravel() * self.square, np.zeros(c.size)], axis=-1)
        return pts.astype(np.float64)

    def extent(self) -> tuple[float, float, float, float]:
        """(x_min, y_min, x_max, y_max) of the square grid in the board frame, metres."""
        sx, sy = self.squares
        o = self.origin_offset
        return (-o, -o, sx * self.square - o, sy * self.square - o)

    def spec(self) -> str:
        """The command-line spec that parses back to this board."""
        if self.kind == "checkerboard":
            return f"checkerboard:{self.cols}x{self.rows}:{self.square:g}"
        return f"charuco:{self.cols}x{self.rows}:{self.square:g}:{self.marker:g}:{self.dictionary}"

    def _charuco(self) -> cv2.aruco.CharucoBoard:
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.cols, self.rows), self.square, self.marker, dictionary)


# ---------------------------------------------------------------------- parsing
def _parse_size(text: str, what: str) -> tuple[int, int]:
    parts = text.lower().split("x")
    if len(parts) != 2 or not all(p.strip().isdigit() for p in parts):
        raise ConfigError(f"expected {what} as COLSxROWS (e.g. 9x6), got {text!r}", field="board")
    return int(parts[0]), int(parts[1])


def _parse_float(text: str, what: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise ConfigError(f"expected {what} in metres (e.g. 0.025), got {text!r}", field="board") from None


def parse_board(spec: str) -> Board:
    """A board from a command-line spec or the path of a TOML board file.

    ``checkerboard:COLSxROWS:SQUARE`` (inner corners), ``charuco:COLSxROWS:SQUARE:MARKER:DICT``
    (squares). Raises ConfigError naming what is wrong.
    """
    text = spec.strip()
    kind = text.split(":", 1)[0].lower()
    if kind in KINDS:
        parts = text.split(":")
        if kind == "checkerboard":
            if len(parts) != 3:
                raise ConfigError(
                    f"expected checkerboard:COLSxROWS:SQUARE (inner corners, metres), got {spec!r}", field="board"
                )
            cols, rows = _parse_size(parts[1], "inner corners")
            return Board("checkerboard", cols, rows, _parse_float(parts[2], "square size"))
        if len(parts) != 5:
            raise ConfigError(
                f"expected charuco:COLSxROWS:SQUARE:MARKER:DICT (squares, metres, "
                f"e.g. charuco:7x5:0.04:0.03:DICT_5X5_100), got {spec!r}",
                field="board",
            )
        cols, rows = _parse_size(parts[1], "squares")
        return Board(
            "charuco",
            cols,
            rows,
            _parse_float(parts[2], "square size"),
            _parse_float(parts[3], "marker size"),
            parts[4].strip().upper(),
        )
    path = Path(text)
    if path.suffix.lower() == ".toml" or path.exists():
        return load_board_file(path)
    raise ConfigError(
        f"{spec!r} is neither a board spec (checkerboard:9x6:0.025, "
        f"charuco:7x5:0.04:0.03:DICT_5X5_100) nor an existing board file",
        field="board",
    )


def load_board_file(path: str | Path) -> Board:
    """Read a TOML board file with a [board] table (kind, cols, rows, square[, marker, dictionary])."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError("board file not found", path=path) from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"cannot read board file: {exc}", path=path) from None
    table = data.get("board")
    if not isinstance(table, dict):
        raise ConfigError("missing [board] table", path=path)
    try:
        kind = str(table["kind"])
        cols, rows = int(table["cols"]), int(table["rows"])
        square = float(table["square"])
        marker = float(table.get("marker", 0.0))
        dictionary = str(table.get("dictionary", ""))
    except KeyError as exc:
        raise ConfigError(f"missing field {exc.args[0]!r} in [board]", path=path) from None
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"invalid value in [board]: {exc}", path=path) from None
    try:
        return Board(kind, cols, rows, square, marker, dictionary)
    except ConfigError as exc:
        raise ConfigError(str(exc), path=path) from None


# -------------------------------------------------------------------- detection
@dataclass(frozen=True)
class Detection:
    """Board corners found in one image.

    pixels: (N, 2) float64 corner positions in the image, pixels.
    ids: (N,) int indices into ``Board.object_points()``.
    image_size: (width, height) of the image.
    source: file name (or label) of the image.
    """

    pixels: np.ndarray
    ids: np.ndarray
    image_size: tuple[int, int]
    source: str = ""


def _gray(image: np.ndarray) -> np.ndarray:
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    return image


def detect_board(image: np.ndarray, board: Board, source: str = "") -> Detection | None:
    """Find the board's corners in one image; None when the board is not found.

    Checkerboard: cv2.findChessboardCorners, or if that fails cv2.findChessboardCornersSB
    (exhaustive; slower, more tolerant of blur and strong distortion); then cornerSubPix with a
    window scaled to the square size. On boards whose square count makes a 180-degree
    turn look different (odd number of squares in one direction and even in the other), the
    corner order is fixed so that the square diagonally outside corner 0 is black.
    ChArUco: cv2.aruco.CharucoDetector; at least 6 corners are required.
    """
    gray = _gray(np.asarray(image))
    if gray.dtype != np.uint8:
        # cv2's stubs lack dst=None (OpenCV allocates the output)
        gray = cv2.normalize(gray, None, 0, 255, cv2.NORM_MINMAX).astype(np.uint8)  # type: ignore[call-overload]
    height, width = gray.shape[:2]
    if board.kind == "charuco":
        detector = cv2.aruco.CharucoDetector(board._charuco())
        corners, ids, _, _ = detector.detectBoard(gray)
        if corners is None or ids is None or len(ids) < 6:
            return None
        return Detection(
            np.asarray(corners, np.float64).reshape(-1, 2), np.asarray(ids, int).ravel(), (width, height), source
        )
    pattern = board.pattern_size
    flags = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_FAST_CHECK
    ok, corners = cv2.findChessboardCorners(gray, pattern, flags=flags)
    if not ok:
        ok, corners = cv2.findChessboardCornersSB(gray, pattern, flags=cv2.CALIB_CB_EXHAUSTIVE)
        if not ok:
            return None
    grid = corners.reshape(pattern[1], pattern[0], 2)
    spacing = min(
        np.linalg.norm(np.diff(grid, axis=0), axis=-1).min(), np.linalg.norm(np.diff(grid, axis=1), axis=-1).min()
    )
    half = int(np.clip(0.4 * spacing, 2, 11))  # search window stays inside the neighbouring squares
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 50, 1e-3)
    corners = cv2.cornerSubPix(gray, np.ascontiguousarray(corners, np.float32), (half, half), (-1, -1), criteria)
    pixels = np.asarray(corners, np.float64).reshape(-1, 2)
    pixels = _orient_checkerboard(gray, pixels, board)
    return Detection(pixels, np.arange(board.n_corners), (width, height), source)


def _orient_checkerboard(gray: np.ndarray, pixels: np.ndarray, board: Board) -> np.ndarray:
    """Reverse the corner order if the square outside corner 0 is white (see module doc)."""
    sx, sy = board.squares
    if (sx + sy) % 2 == 0:
        return pixels  # a 180-degree turn looks the same: the order cannot be fixed from the image
    cols, rows = board.pattern_size
    grid = pixels.reshape(rows, cols, 2)

    def outside_value(g: np.ndarray) -> float:
        # centre of the square beyond corner 0, extrapolated along the grid's diagonal
        p = g[0, 0] + 0.5 * (g[0, 0] - g[1, 1])
        x, y = int(round(p[0])), int(round(p[1]))
        h, w = gray.shape
        if not (0 <= x < w and 0 <= y < h):
            return np.nan
        return float(gray[y, x])

    def neighbour_value(g: np.ndarray) -> float:
        # centre of the square beside it (outside the row of corners 0 and 1): the opposite colour
        p = 0.5 * (g[0, 0] + g[0, 1]) + 0.5 * (g[0, 0] - g[1, 0])
        x, y = int(round(p[0])), int(round(p[1]))
        h, w = gray.shape
        if not (0 <= x < w and 0 <= y < h):
            return np.nan
        return float(gray[y, x])

    out = outside_value(grid)
    ref = neighbour_value(grid)
    if np.isnan(out) or np.isnan(ref):
        return pixels
    if out > ref:  # the outside square is the lighter one: corner 0 is at the other end
        return pixels[::-1].copy()
    return pixels


# ---------------------------------------------------------------------- texture
@dataclass(frozen=True)
class BoardTexture:
    """A printable image of a board.

    image: (H, W) uint8, white margin around the square grid.
    scale: texture pixels per metre.
    margin_px: width of the white margin, texture pixels.
    """

    image: np.ndarray
    scale: float
    margin_px: int

    def coordinates(self, board: "Board", points_board: np.ndarray) -> FloatArray:
        """(..., 2+) board-plane points (metres) -> (..., 2) texture pixel coordinates (pixel centres at integers)."""
        x0, y0, _, _ = board.extent()
        pixels: FloatArray = (
            (np.asarray(points_board)[..., :2] - np.array([x0, y0])) * self.scale + self.margin_px - 0.5
        )
        return pixels


def board_texture(board: Board, px_per_square: int = 48, margin_squares: float = 1.0) -> BoardTexture:
    """Draw the board: checkerboard squares by the module convention (square outside corner 0
    black), ChArUco boards by OpenCV's CharucoBoard.generateImage."""
    sx, sy = board.squares
    m = int(round(margin_squares * px_per_square))
    if board.kind == "charuco":
        inner = board._charuco().generateImage((sx * px_per_square, sy * px_per_square), marginSize=0, borderBits=1)
    else:
        v, u = np.mgrid[0 : sy * px_per_square, 0 : sx * px_per_square]
        black = ((u // px_per_square) + (v // px_per_square)) % 2 == 0
        inner = np.where(black, 0, 255).astype(np.uint8)
    tex = np.full((inner.shape[0] + 2 * m, inner.shape[1] + 2 * m), 255, np.uint8)
    tex[m : m + inner.shape[0], m : m + inner.shape[1]] = inner
    return BoardTexture(tex, px_per_square / board.square, m)
