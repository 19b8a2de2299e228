"""The static part of the simulated scene in a camera: the hall, floor, walls, furniture and
reference bars ray-cast once per camera into a background image and a depth map, the pixel rays
of a camera, and the shading of a surface under the ceiling light.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from ergopose.geometry.camera import Camera
from ergopose.sim.bodies import unit_vectors
from ergopose.sim.raycast import dot, ray_aabb_planar, ray_capsule
from ergopose.sim.scene import Box, Scene

LIGHT_WORLD = np.array([0.25, 0.35, 1.0]) / np.linalg.norm([0.25, 0.35, 1.0])
AMBIENT = 0.42
DIFFUSE = 0.58


# --- the static scene ---------------------------------------------------------------------------------

#: Walls of the hall around the work area (so the lens's outer ring sees walls, not void).
HALL_HALF = 4.2
HALL_HEIGHT = 3.6


def _hall_boxes() -> list[Box]:
    wall = (188, 196, 200)
    t = 0.2
    h = HALL_HALF
    return [
        Box("wall_n", "wall", (-h - t, h, 0.0), (h + t, h + t, HALL_HEIGHT), wall),
        Box("wall_s", "wall", (-h - t, -h - t, 0.0), (h + t, -h, HALL_HEIGHT), wall),
        Box("wall_e", "wall", (h, -h, 0.0), (h + t, h, HALL_HEIGHT), wall),
        Box("wall_w", "wall", (-h - t, -h, 0.0), (-h, h, HALL_HEIGHT), wall),
    ]


def _bilinear_wrap(tex: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Bilinear lookup of a periodic texture (rows v, columns u, in texels)."""
    h, w = tex.shape
    u0 = np.floor(u)
    v0 = np.floor(v)
    fu = u - u0
    fv = v - v0
    i0 = u0.astype(np.int64) % w
    j0 = v0.astype(np.int64) % h
    i1 = (i0 + 1) % w
    j1 = (j0 + 1) % h
    top = tex[j0, i0] * (1 - fu) + tex[j0, i1] * fu
    bottom = tex[j1, i0] * (1 - fu) + tex[j1, i1] * fu
    return top * (1 - fv) + bottom * fv


def _floor_colour(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Concrete floor: mottled grey, 1 m expansion joints, a yellow border around the 6 x 6 m area."""
    rng = np.random.default_rng(12345)  # fixed texture: the floor is the same in every session
    coarse: np.ndarray = rng.normal(0.0, 1.0, (64, 64)).astype(np.float32)
    coarse = cv2.GaussianBlur(coarse, (0, 0), 1.5)
    fine = rng.normal(0.0, 1.0, (512, 512)).astype(np.float32)
    # bilinear lookup in the periodic textures (10 m and 5 m periods)
    mot = _bilinear_wrap(coarse, (x / 10.0) * 64.0, (y / 10.0) * 64.0)
    grain = _bilinear_wrap(fine, (x / 5.0) * 512.0, (y / 5.0) * 512.0)
    grey = 150.0 + 14.0 * mot + 6.0 * grain
    out = np.stack([grey + 4.0, grey + 2.0, grey - 2.0], axis=-1)
    joint = (np.abs(x - np.round(x)) < 0.006) | (np.abs(y - np.round(y)) < 0.006)
    out[joint] *= 0.7
    border = ((np.abs(np.abs(x) - 3.0) < 0.05) & (np.abs(y) < 3.05)) | (
        (np.abs(np.abs(y) - 3.0) < 0.05) & (np.abs(x) < 3.05)
    )
    stripe = np.floor((x + y) / 0.2) % 2 == 0
    out[border & stripe] = (20.0, 190.0, 230.0)
    out[border & ~stripe] = (30.0, 30.0, 30.0)
    return out


def _box_surface_colour(kind: str, base: np.ndarray, p: np.ndarray, normal_axis: np.ndarray) -> np.ndarray:
    """Surface pattern of a furniture box at hit points p (n, 3)."""
    col = np.broadcast_to(base, (p.shape[0], 3)).astype(np.float32).copy()
    if kind == "shelf":
        # side faces: orange boards every 0.45 m with goods (boxes, bins) between them
        z = p[:, 2]
        side = normal_axis != 2
        board = side & ((z % 0.45) < 0.035)
        col[board] = (40, 110, 220)
        goods = side & ~board
        cell = np.floor(z / 0.45) * 7 + np.floor((p[:, 0] + p[:, 1]) / 0.3)
        pick = (np.abs(np.sin(cell * 12.9898)) * 43758.5453) % 1.0
        palette = np.array(
            [[70, 120, 170], [90, 140, 190], [150, 110, 60], [60, 160, 200], [120, 120, 120]], np.float32
        )
        shade = 0.75 + 0.35 * ((pick * 7.0) % 1.0)
        col[goods] = palette[(pick[goods] * len(palette)).astype(int) % len(palette)] * shade[goods, None]
    elif kind == "carton":
        tape = np.abs(p[:, 0] - np.round(p[:, 0] * 5) / 5) < 0.012
        col[tape] *= 0.75
    elif kind == "pallet":
        slat = (p[:, 0] % 0.2) < 0.1
        col[slat] *= 0.8
    return col


@dataclass(frozen=True)
class StaticScene:
    """The furniture boxes (axis-aligned) and bars, ready for ray casting."""

    boxes: tuple[Box, ...]
    box_lo: np.ndarray
    box_hi: np.ndarray
    bar_a: np.ndarray
    bar_b: np.ndarray
    bar_radius: np.ndarray

    @classmethod
    def from_scene(cls, scene: Scene) -> "StaticScene":
        boxes = tuple(scene.boxes) + tuple(_hall_boxes())
        return cls(
            boxes=boxes,
            box_lo=np.array([b.lo for b in boxes], np.float32),
            box_hi=np.array([b.hi for b in boxes], np.float32),
            bar_a=np.array([b.end_a for b in scene.bars], np.float32).reshape(-1, 3),
            bar_b=np.array([b.end_b for b in scene.bars], np.float32).reshape(-1, 3),
            bar_radius=np.array([b.radius for b in scene.bars], np.float32),
        )

    def hit(self, origin: np.ndarray, d: np.ndarray, camera: Camera | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(t, what) for unit rays d (..., 3): distance of the first hit and what was hit:
        -1 nothing, 0 floor, 1 + k box k, 1 + n_boxes + k bar k.

        With ``camera`` given, d must be the camera's (H, W, 3) pixel rays; each box is then only
        tested on the pixels of its projected bounding region.
        """
        o = np.asarray(origin, np.float64)
        with np.errstate(invalid="ignore", divide="ignore"):
            t_floor = np.where(d[..., 2] < 0, np.float32(-o[2]) / d[..., 2], np.inf).astype(np.float32)
            inv = tuple((np.float32(1.0) / d[..., k]).astype(np.float32) for k in range(3))
        best = t_floor
        what = np.where(np.isfinite(t_floor), 0, -1).astype(np.int16)
        for k in range(len(self.boxes)):
            region = _box_region(camera, self.box_lo[k], self.box_hi[k]) if camera is not None else None
            sl = (Ellipsis,) if region is None else (slice(region[1], region[3]), slice(region[0], region[2]))
            t = ray_aabb_planar(o, tuple(c[sl] for c in inv), self.box_lo[k], self.box_hi[k])
            sub = best[sl]
            closer = t < sub
            sub[closer] = t[closer]
            what[sl][closer] = 1 + k
        for k in range(len(self.bar_a)):
            t = ray_capsule(o.astype(np.float32), d, self.bar_a[k], self.bar_b[k], self.bar_radius[k])
            closer = t < best
            best = np.where(closer, t, best)
            what[closer] = 1 + len(self.boxes) + k
        return best, what


def _box_region(camera: Camera, lo: np.ndarray, hi: np.ndarray) -> tuple[int, int, int, int] | None:
    """Pixel region (u0, v0, u1, v1) holding the image of an axis-aligned box, or None for the
    whole image (when part of the box lies beyond the lens). Edges are sampled densely because
    the fisheye bends straight lines."""
    s = np.linspace(0.0, 1.0, 17)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], np.float64)
    pts = []
    for i in range(8):
        for j in range(i + 1, 8):
            if np.count_nonzero(corners[i] != corners[j]) == 1:  # an edge
                pts.append(corners[i] + (corners[j] - corners[i]) * s[:, None])
    pix = camera.project_world(np.concatenate(pts))
    if not np.isfinite(pix).all():
        return None
    u0 = int(np.clip(np.floor(pix[:, 0].min()) - 3, 0, camera.width))
    v0 = int(np.clip(np.floor(pix[:, 1].min()) - 3, 0, camera.height))
    u1 = int(np.clip(np.ceil(pix[:, 0].max()) + 4, 0, camera.width))
    v1 = int(np.clip(np.ceil(pix[:, 1].max()) + 4, 0, camera.height))
    return u0, v0, max(u0, u1), max(v0, v1)


def lambert_shade(normal: np.ndarray) -> np.ndarray:
    """Brightness of surfaces with these unit normals (world frame): ambient plus diffuse (Lambert)
    light from LIGHT_WORLD."""
    return AMBIENT + DIFFUSE * np.clip(dot(normal, LIGHT_WORLD.astype(np.float32)), 0.0, 1.0)


def render_background(
    camera: Camera, static: StaticScene, rays: np.ndarray, valid: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(image uint8 (H, W, 3), depth float32 (H, W)) of the empty scene; depth inf outside the lens."""
    o = camera.position_world.astype(np.float32)
    t, what = static.hit(o, rays, camera)
    t[~valid] = np.inf
    what[~valid] = -1
    p = o + rays * np.where(np.isfinite(t), t, 0.0)[..., None]
    colour = np.zeros(rays.shape, np.float32)
    normal = np.zeros(rays.shape, np.float32)
    floor = what == 0
    colour[floor] = _floor_colour(p[floor, 0], p[floor, 1])
    normal[floor] = (0.0, 0.0, 1.0)
    n_boxes = len(static.boxes)
    for k, box in enumerate(static.boxes):
        sel = what == 1 + k
        if not sel.any():
            continue
        q = p[sel]
        centre = 0.5 * (static.box_lo[k] + static.box_hi[k])
        half = 0.5 * (static.box_hi[k] - static.box_lo[k])
        rel = (q - centre) / half
        axis = np.argmax(np.abs(rel), axis=1)
        nrm = np.zeros_like(q)
        nrm[np.arange(len(q)), axis] = np.sign(rel[np.arange(len(q)), axis])
        normal[sel] = nrm
        colour[sel] = _box_surface_colour(box.kind, np.array(box.colour, np.float32), q, axis)
    for k in range(len(static.bar_a)):
        sel = what == 1 + n_boxes + k
        if not sel.any():
            continue
        a, b = static.bar_a[k], static.bar_b[k]
        q = p[sel]
        ab = b - a
        s = np.clip(((q - a) @ ab) / float(ab @ ab), 0.0, 1.0)
        nrm = q - (a + s[:, None] * ab)
        normal[sel] = unit_vectors(nrm)
        length = float(np.linalg.norm(ab))
        along = s * length
        stripes = np.where(np.floor(along / 0.1) % 2 == 0, 0, 1)
        col = np.where(
            stripes[:, None] == 0, np.array([20, 200, 235], dtype=np.float32), np.array([25, 25, 25], dtype=np.float32)
        )
        caps = (along < 0.05) | (along > length - 0.05)
        col[caps] = (30, 30, 220)
        colour[sel] = col
    shade = lambert_shade(normal)
    shade[what < 0] = 0.0
    # Lens falloff (vignetting) towards the rim of the image circle.
    rays_cam = rays @ camera.rotation_world_from_cam.astype(np.float32)
    cos_theta = np.clip(rays_cam[..., 2], -1.0, 1.0)
    vignette = 0.78 + 0.22 * np.clip(cos_theta, 0.0, 1.0)
    img = np.clip(colour * (shade * vignette)[..., None], 0, 255)
    img[~valid] = 0
    return img.astype(np.uint8), t.astype(np.float32)


def pixel_rays(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Unit world rays (H, W, 3) float32 of every pixel centre and the (H, W) mask of valid ones."""
    u = np.arange(camera.width, dtype=np.float64)
    v = np.arange(camera.height, dtype=np.float64)
    grid = np.stack(np.meshgrid(u, v), axis=-1)
    rays = camera.rays_world(grid)
    valid = np.isfinite(rays).all(axis=-1)
    rays[~valid] = (0.0, 0.0, 1.0)
    return rays.astype(np.float32), valid
