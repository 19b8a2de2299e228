"""Walking paths around the furniture: an occupancy grid with a clearance around every box, A* on
it, the path shortened by line of sight (:func:`plan_path`) and its corners rounded.
"""

from __future__ import annotations

import heapq
import math
from typing import Sequence

import numpy as np

from ergopose.sim.scene import Scene

#: Clearance kept around furniture by walking paths (metres, from the mid-hip point).
PATH_CLEARANCE = 0.3
GRID_STEP = 0.1


# --- path planning ---------------------------------------------------------------------------------


class WalkGrid:
    """Occupancy grid of the area for walking (furniture inflated by PATH_CLEARANCE)."""

    def __init__(self, scene: Scene):
        x0, x1, y0, y1 = scene.area
        self.x0, self.y0 = x0, y0
        self.nx = int(round((x1 - x0) / GRID_STEP))
        self.ny = int(round((y1 - y0) / GRID_STEP))
        xs = x0 + (np.arange(self.nx) + 0.5) * GRID_STEP
        ys = y0 + (np.arange(self.ny) + 0.5) * GRID_STEP
        self.cx, self.cy = np.meshgrid(xs, ys, indexing="ij")
        blocked = (self.cx < x0 + 0.25) | (self.cx > x1 - 0.25) | (self.cy < y0 + 0.25) | (self.cy > y1 - 0.25)
        for bx0, by0, bx1, by1 in scene.obstacles_xy():
            blocked |= _box_distance(self.cx, self.cy, bx0, by0, bx1, by1) < PATH_CLEARANCE
        self.static = blocked
        self.obstacles = scene.obstacles_xy()

    def free_point(self, p: np.ndarray, circles: list[tuple[float, float, float]]) -> bool:
        x, y = float(p[0]), float(p[1])
        for bx0, by0, bx1, by1 in self.obstacles:
            if _box_distance(x, y, bx0, by0, bx1, by1) < PATH_CLEARANCE - 1e-9:
                return False
        return all(math.hypot(x - cx, y - cy) >= r for cx, cy, r in circles)

    def cell(self, p: np.ndarray) -> tuple[int, int]:
        i = int(np.clip((p[0] - self.x0) / GRID_STEP, 0, self.nx - 1))
        j = int(np.clip((p[1] - self.y0) / GRID_STEP, 0, self.ny - 1))
        return i, j

    def centre(self, c: tuple[int, int]) -> np.ndarray:
        return np.array([self.x0 + (c[0] + 0.5) * GRID_STEP, self.y0 + (c[1] + 0.5) * GRID_STEP])


def _box_distance(x, y, bx0, by0, bx1, by1):
    dx = np.maximum(np.maximum(bx0 - x, x - bx1), 0.0)
    dy = np.maximum(np.maximum(by0 - y, y - by1), 0.0)
    return np.hypot(dx, dy)


def plan_path(
    grid: WalkGrid, start: np.ndarray, goal: np.ndarray, circles: Sequence[tuple[float, float, float]] = ()
) -> np.ndarray:
    """Waypoints (n, 2) from start to goal around the furniture (and the given circles (x, y, r)).

    A* over the 8-connected grid, then shortened: from each waypoint, jump to the farthest later
    one in line of sight. Start and goal themselves may lie in blocked cells (stations are close
    to furniture); the path leaves and enters them in a straight line.
    """
    circles = list(circles)
    blocked = grid.static.copy()
    for cx, cy, r in circles:
        blocked |= np.hypot(grid.cx - cx, grid.cy - cy) < r
    s, g = grid.cell(start), grid.cell(goal)
    blocked[s] = False
    blocked[g] = False
    steps = [
        (1, 0, 1.0),
        (-1, 0, 1.0),
        (0, 1, 1.0),
        (0, -1, 1.0),
        (1, 1, math.sqrt(2)),
        (1, -1, math.sqrt(2)),
        (-1, 1, math.sqrt(2)),
        (-1, -1, math.sqrt(2)),
    ]
    came: dict[tuple[int, int], tuple[int, int]] = {}
    cost = {s: 0.0}
    heap = [(0.0, 0, s)]
    counter = 0
    found = False
    while heap:
        _, _, c = heapq.heappop(heap)
        if c == g:
            found = True
            break
        for di, dj, w in steps:
            n = (c[0] + di, c[1] + dj)
            if not (0 <= n[0] < grid.nx and 0 <= n[1] < grid.ny) or blocked[n]:
                continue
            if di and dj and (blocked[c[0] + di, c[1]] or blocked[c[0], c[1] + dj]):
                continue  # no corner cutting
            nc = cost[c] + w
            if nc < cost.get(n, math.inf):
                cost[n] = nc
                came[n] = c
                counter += 1
                heapq.heappush(heap, (nc + math.hypot(g[0] - n[0], g[1] - n[1]), counter, n))
    if not found:
        if circles:
            return plan_path(grid, start, goal, ())
        return np.array([start, goal], dtype=np.float64)
    cells = [g]
    while cells[-1] != s:
        cells.append(came[cells[-1]])
    cells.reverse()
    points = [np.asarray(start, float)] + [grid.centre(c) for c in cells[1:-1]] + [np.asarray(goal, float)]

    def visible(a: np.ndarray, b: np.ndarray) -> bool:
        n = max(2, int(math.ceil(np.linalg.norm(b - a) / 0.04)) + 1)
        for t in np.linspace(0.0, 1.0, n)[1:-1]:
            p = a + (b - a) * t
            i, j = grid.cell(p)
            if blocked[i, j] and (i, j) not in (s, g):
                return False
        return True

    out = [points[0]]
    k = 0
    while k < len(points) - 1:
        nxt = k + 1
        for m in range(len(points) - 1, k, -1):
            if visible(points[k], points[m]):
                nxt = m
                break
        out.append(points[nxt])
        k = nxt
    return np.array(out)


def rounded_curve(points: np.ndarray, radius: float = 0.6, spacing: float = 0.02) -> np.ndarray:
    """A polyline with its corners rounded (quadratic Bezier from ``radius`` before to ``radius``
    after each corner, at most half of each segment), sampled every ``spacing`` metres."""
    if len(points) == 2:
        n = max(2, int(math.ceil(np.linalg.norm(points[1] - points[0]) / spacing)) + 1)
        return points[0] + (points[1] - points[0]) * np.linspace(0.0, 1.0, n)[:, None]
    pieces = [points[0][None, :]]
    start = points[0]
    for i in range(1, len(points) - 1):
        a, c, b = points[i - 1], points[i], points[i + 1]
        ra = min(radius, 0.5 * np.linalg.norm(c - a))
        rb = min(radius, 0.5 * np.linalg.norm(b - c))
        p_in = c + (a - c) * ra / np.linalg.norm(c - a)
        p_out = c + (b - c) * rb / np.linalg.norm(b - c)
        n = max(2, int(math.ceil(np.linalg.norm(p_in - start) / spacing)) + 1)
        pieces.append(start + (p_in - start) * np.linspace(0.0, 1.0, n)[1:, None])
        t = np.linspace(0.0, 1.0, 25)[1:, None]
        pieces.append((1 - t) ** 2 * p_in + 2 * (1 - t) * t * c + t**2 * p_out)
        start = p_out
    end = points[-1]
    n = max(2, int(math.ceil(np.linalg.norm(end - start) / spacing)) + 1)
    pieces.append(start + (end - start) * np.linspace(0.0, 1.0, n)[1:, None])
    curve = np.concatenate(pieces)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(curve, axis=0), axis=1) > 1e-9])
    return curve[keep]
