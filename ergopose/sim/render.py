"""Z-buffered mannequins through the real fisheye lens: the simulated camera images.

Every image pixel is a ray from the camera centre (``camera.rays_world`` of the pixel centre,
computed once per camera and kept as a (H, W, 3) float32 array). The static part of the scene
(floor, walls, furniture, reference bars) is ray-cast once per camera into a background image
and a depth map (distance along the ray, metres). For each frame, each body part of each worker
(:class:`BodyPrimitives`: capsules for limbs, neck, shoulders, hands and feet; ellipsoids for
chest, abdomen, pelvis, head and nose; an oriented box for a carried carton) is intersected
analytically with the rays of the pixels inside its projected bounding box only; a pixel takes
the nearest surface (shelves hide people, limbs hide each other). Visible body pixels are then
shaded once (Lambert from a ceiling light plus ambient; a face with eyes, nose and mouth, and
hair, on the head).

The camera effects: a slight blur (the optics; it also smooths the mannequins' edges), sensor
noise (a few precomputed noise frames, picked per frame from the seed) and a slow change of
the overall brightness.

Ray-casting the same primitives for single rays gives each joint's visibility per camera
(:func:`joint_visibility`): the ground truth of which joints a camera can see.

The bodies, ray intersections, static scene and visibility live in :mod:`ergopose.sim.bodies`,
:mod:`ergopose.sim.raycast`, :mod:`ergopose.sim.backdrop` and :mod:`ergopose.sim.visibility`;
``__all__`` names the simulator's rendering interface.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

from ergopose.atomic import atomic_path
from ergopose.geometry.camera import Camera
from ergopose.sim.backdrop import StaticScene, lambert_shade, pixel_rays, render_background
from ergopose.sim.bodies import (
    CARTON,
    HEAD,
    N_CAPSULES,
    N_ELLIPSOIDS,
    N_PRIMITIVES,
    PRIMITIVE_NAMES,
    BodyPrimitives,
    all_body_primitives,
    body_primitives,
    head_axes,
    unit_vectors,
)
from ergopose.sim.raycast import dot, ray_box, ray_capsule, ray_ellipsoid
from ergopose.sim.scene import Scene
from ergopose.video import open_video_writer
from ergopose.sim.visibility import (
    OCCLUDED_BY_SCENE,
    OCCLUDED_BY_WORKER,
    OUTSIDE_IMAGE,
    SELF_OCCLUDED,
    VISIBILITY_CODES,
    VISIBLE,
    joint_visibility,
)


@dataclass(frozen=True)
class RenderOptions:
    """Camera effects. noise_sigma: sensor noise (grey levels); blur_sigma: optical blur (pixels,
    0 = none); brightness_drift: relative amplitude of the slow brightness change; seed: for the
    noise."""

    noise_sigma: float = 2.5
    blur_sigma: float = 0.7
    brightness_drift: float = 0.04
    seed: int = 0


# --- per-frame rendering ------------------------------------------------------------------------------


def _quiet(fn):
    """Run a ray kernel with NaN/inf arithmetic silent (NaN marks a miss, by design)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            return fn(*args, **kwargs)

    return wrapper


def _sphere_samples() -> np.ndarray:
    pts = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
    pts += [(x, y, z) for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]
    return unit_vectors(np.array(pts, np.float64))


#: Points on a sphere, inflated: the fisheye image of a sphere is not exactly bounded by the
#: images of 14 of its points; 25 % more radius and 2 pixels of margin cover the difference.
_SAMPLES = _sphere_samples() * 1.25
_NAN = np.float32(np.nan)


class CameraRenderer:
    """Renders frames of one camera: background once, then the workers per frame.

    The rays are kept as planes (three (H, W) float32 arrays) plus their six pairwise products,
    so every primitive costs a few dozen array operations on the pixels of its own bounding box.
    """

    def __init__(self, camera: Camera, scene: Scene, bodies: list[BodyPrimitives], options: RenderOptions):
        self.camera = camera
        self.bodies = bodies
        self.options = options
        self.origin = camera.position_world.astype(np.float64)
        rays, self.valid = pixel_rays(camera)
        self.rays = rays
        self.rx, self.ry, self.rz = (np.ascontiguousarray(rays[..., k]) for k in range(3))
        self.xx, self.yy, self.zz = self.rx * self.rx, self.ry * self.ry, self.rz * self.rz
        self.xy, self.xz, self.yz = self.rx * self.ry, self.rx * self.rz, self.ry * self.rz
        self.rays_flat = rays.reshape(-1, 3)
        self.rx_flat, self.ry_flat, self.rz_flat = (a.reshape(-1) for a in (self.rx, self.ry, self.rz))
        self.xx_flat, self.yy_flat, self.zz_flat = (a.reshape(-1) for a in (self.xx, self.yy, self.zz))
        self.xy_flat, self.xz_flat, self.yz_flat = (a.reshape(-1) for a in (self.xy, self.xz, self.yz))
        self.static = StaticScene.from_scene(scene)
        self.sharp_background, self.bg_depth = render_background(camera, self.static, rays, self.valid)
        self.bg_depth_flat = self.bg_depth.reshape(-1)
        self.background = self._blur(self.sharp_background)
        h, w = camera.height, camera.width
        self._noise: list[tuple[np.ndarray, np.ndarray]] = []
        if options.noise_sigma > 0:
            rng = np.random.default_rng(np.random.SeedSequence([options.seed, 7]))
            for _ in range(4):
                n = np.rint(rng.standard_normal((h, w, 3), dtype=np.float32) * np.float32(options.noise_sigma))
                n = n.astype(np.int16)
                n[~self.valid] = 0
                self._noise.append((np.clip(n, 0, 255).astype(np.uint8), np.clip(-n, 0, 255).astype(np.uint8)))
        self._noise_pick = np.random.default_rng(np.random.SeedSequence([options.seed, 11]))

    def _blur(self, img: np.ndarray) -> np.ndarray:
        if self.options.blur_sigma <= 0:
            return img.copy()
        return cv2.GaussianBlur(img, (0, 0), self.options.blur_sigma)

    # bounding boxes -------------------------------------------------------------------------
    def _boxes(self, centres: np.ndarray, radii: np.ndarray) -> np.ndarray:
        """(P, 4) int pixel boxes (u0, v0, u1, v1), end exclusive, of spheres (P, 3), (P,)."""
        pts = centres[:, None, :].astype(np.float64) + radii[:, None, None] * _SAMPLES[None, :, :]
        pix = self.camera.project_world(pts)
        with np.errstate(invalid="ignore"):
            lo = np.floor(np.nanmin(pix, axis=1)) - 2
            hi = np.ceil(np.nanmax(pix, axis=1)) + 3
        bad = ~np.isfinite(pix).all(axis=(1, 2))  # part of the sphere beyond the lens: whole image
        w, h = self.camera.width, self.camera.height
        box = np.empty((len(centres), 4), np.int64)
        box[:, 0] = np.clip(np.nan_to_num(lo[:, 0], nan=0), 0, w)
        box[:, 1] = np.clip(np.nan_to_num(lo[:, 1], nan=0), 0, h)
        box[:, 2] = np.clip(np.nan_to_num(hi[:, 0], nan=w), 0, w)
        box[:, 3] = np.clip(np.nan_to_num(hi[:, 1], nan=h), 0, h)
        box[bad] = (0, 0, w, h)
        return box

    def _frame_boxes(self, frame: int) -> list[np.ndarray]:
        """Per worker (N_PRIMITIVES, 4) pixel boxes, from one projection call for the frame."""
        centres, radii = [], []
        for body in self.bodies:
            r = body.capsule_radius
            centres += [
                body.capsule_a[frame],
                body.capsule_b[frame],
                body.ellipsoid_centre[frame],
                body.carton_centre[frame][None, :],
            ]
            radii += [
                r,
                r,
                body.ellipsoid_radii.max(axis=1),
                np.array([np.linalg.norm(body.carton_half[frame])], np.float32),
            ]
        box = self._boxes(np.concatenate(centres), np.concatenate(radii))
        per = 2 * N_CAPSULES + N_ELLIPSOIDS + 1
        out = []
        for w in range(len(self.bodies)):
            b = box[w * per : (w + 1) * per]
            ba, bb = b[:N_CAPSULES], b[N_CAPSULES : 2 * N_CAPSULES]
            caps = np.concatenate([np.minimum(ba[:, :2], bb[:, :2]), np.maximum(ba[:, 2:], bb[:, 2:])], axis=1)
            out.append(np.concatenate([caps, b[2 * N_CAPSULES :]]))
        return out

    # batched intersections: every pixel of every primitive's box in one array -------------
    def _pixels_of_boxes(self, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(flat pixel index (N,), primitive row (N,)) of all pixels inside the boxes (P, 4)."""
        w_img = self.camera.width
        bw = np.maximum(boxes[:, 2] - boxes[:, 0], 0)
        bh = np.maximum(boxes[:, 3] - boxes[:, 1], 0)
        n = bw * bh
        total = int(n.sum())
        prim = np.repeat(np.arange(len(boxes)), n)
        start = np.cumsum(n) - n
        local = np.arange(total) - np.repeat(start, n)
        bwp = bw[prim]
        row = boxes[prim, 1] + local // bwp
        col = boxes[prim, 0] + local % bwp
        return row * w_img + col, prim

    @_quiet
    def _capsules(self, flat: np.ndarray, prim: np.ndarray, a: np.ndarray, b: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Hit distances (N,) of pixel rays with capsules a, b (P, 3), r (P,) by primitive row; NaN = miss."""
        o = self.origin
        ba = (b - a).astype(np.float64)
        oa = o - a
        ob = oa - ba
        baba = np.einsum("ij,ij->i", ba, ba)
        baoa = np.einsum("ij,ij->i", ba, oa)
        oaoa = np.einsum("ij,ij->i", oa, oa)
        r2 = r.astype(np.float64) ** 2
        consts = np.stack(
            [baba, baoa, baba * oaoa - baoa * baoa - r2 * baba, oaoa - r2, np.einsum("ij,ij->i", ob, ob) - r2], axis=1
        ).astype(np.float32)[prim]
        vec = np.concatenate([ba, oa], axis=1).astype(np.float32)[prim]
        rx, ry, rz = self.rx_flat[flat], self.ry_flat[flat], self.rz_flat[flat]
        bard = rx * vec[:, 0] + ry * vec[:, 1] + rz * vec[:, 2]
        rdoa = rx * vec[:, 3] + ry * vec[:, 4] + rz * vec[:, 5]
        baba_p, baoa_p = consts[:, 0], consts[:, 1]
        qa = baba_p - bard * bard
        qb = baba_p * rdoa - baoa_p * bard
        t = (-qb - np.sqrt(qb * qb - qa * consts[:, 2])) / qa
        y = baoa_p + t * bard
        t[(y <= 0) | (y >= baba_p)] = _NAN
        t1 = -rdoa - np.sqrt(rdoa * rdoa - consts[:, 3])
        rdob = rdoa - bard
        t2 = -rdob - np.sqrt(rdob * rdob - consts[:, 4])
        return np.fmin(np.fmin(t, t1), t2)

    @_quiet
    def _ellipsoids(
        self, flat: np.ndarray, prim: np.ndarray, centre: np.ndarray, axes: np.ndarray, radii: np.ndarray
    ) -> np.ndarray:
        """Hit distances (N,) of pixel rays with ellipsoids (P, ...) by primitive row; NaN = miss."""
        m = axes.astype(np.float64) / radii.astype(np.float64)[:, None, :]  # columns axis_i / r_i
        q = np.einsum("pik,pjk->pij", m, m)  # d'.d' = d^T q d
        o_l = np.einsum("pji,pj->pi", m, self.origin - centre)
        wv = np.einsum("pij,pj->pi", m, o_l)  # o'.d' = d . wv
        c = np.einsum("pi,pi->p", o_l, o_l) - 1.0
        coef = np.stack(
            [
                q[:, 0, 0],
                q[:, 1, 1],
                q[:, 2, 2],
                2 * q[:, 0, 1],
                2 * q[:, 0, 2],
                2 * q[:, 1, 2],
                wv[:, 0],
                wv[:, 1],
                wv[:, 2],
                c,
            ],
            axis=1,
        ).astype(np.float32)[prim]
        qa = (
            self.xx_flat[flat] * coef[:, 0]
            + self.yy_flat[flat] * coef[:, 1]
            + self.zz_flat[flat] * coef[:, 2]
            + self.xy_flat[flat] * coef[:, 3]
            + self.xz_flat[flat] * coef[:, 4]
            + self.yz_flat[flat] * coef[:, 5]
        )
        qb = self.rx_flat[flat] * coef[:, 6] + self.ry_flat[flat] * coef[:, 7] + self.rz_flat[flat] * coef[:, 8]
        return (-qb - np.sqrt(qb * qb - qa * coef[:, 9])) / qa

    @_quiet
    def _obb(self, flat: np.ndarray, centre: np.ndarray, axes: np.ndarray, half: np.ndarray) -> np.ndarray:
        o_l = axes.T.astype(np.float64) @ (self.origin - centre)
        rx, ry, rz = self.rx_flat[flat], self.ry_flat[flat], self.rz_flat[flat]
        los, his = [], []
        for i in range(3):
            d_l = rx * np.float32(axes[0, i]) + ry * np.float32(axes[1, i]) + rz * np.float32(axes[2, i])
            t1 = (np.float32(-half[i] - o_l[i])) / d_l
            t2 = (np.float32(half[i] - o_l[i])) / d_l
            los.append(np.fmin(t1, t2))
            his.append(np.fmax(t1, t2))
        near = np.fmax(np.fmax(los[0], los[1]), los[2])
        far = np.fmin(np.fmin(his[0], his[1]), his[2])
        near[(near > far) | (near <= 0)] = _NAN
        return near

    def render(self, frame: int) -> np.ndarray:
        """The camera image (H, W, 3) uint8 BGR of one frame."""
        self._set_gain(frame)
        img = self.background_gained.copy()
        if not self.bodies:
            return self._noise_add(img)
        boxes = self._frame_boxes(frame)
        pix, t, gid = self._depth_pass(frame, boxes)
        if pix.size:
            colours = np.empty((len(pix), 3), np.uint8)
            worker = gid // N_PRIMITIVES
            for w in range(len(self.bodies)):
                sel = worker == w
                if sel.any():
                    colours[sel] = self._shade_body(
                        frame, w, gid[sel] - w * N_PRIMITIVES, t[sel], self.rays_flat[pix[sel]]
                    )
            self._composite(img, pix, colours, boxes)
        return self._noise_add(img)

    def surface_ids(self, frame: int) -> tuple[np.ndarray, np.ndarray]:
        """(ids, depth) of one frame, (H, W) each: what each pixel's ray meets first.

        ids: worker index * N_PRIMITIVES + primitive index (PRIMITIVE_NAMES), or -1 for the static
        scene (floor, furniture, bars) and outside the lens. depth: distance along the ray, metres.
        """
        ids = np.full(self.camera.height * self.camera.width, -1, np.int16)
        depth = self.bg_depth_flat.copy()
        if self.bodies:
            pix, t, gid = self._depth_pass(frame, self._frame_boxes(frame))
            ids[pix] = gid
            depth[pix] = t
        shape = (self.camera.height, self.camera.width)
        return ids.reshape(shape), depth.reshape(shape)

    def _depth_pass(self, frame: int, boxes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Body pixels nearer than the static scene: (flat pixel index, distance, global id), one per pixel."""
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            # capsules of all workers in one batch, then ellipsoids, then carried cartons
            cap_boxes = np.concatenate([b[:N_CAPSULES] for b in boxes])
            flat_c, prim_c = self._pixels_of_boxes(cap_boxes)
            t_c = self._capsules(
                flat_c,
                prim_c,
                np.concatenate([body.capsule_a[frame] for body in self.bodies]),
                np.concatenate([body.capsule_b[frame] for body in self.bodies]),
                np.concatenate([body.capsule_radius for body in self.bodies]),
            )
            gid_c = (prim_c // N_CAPSULES) * N_PRIMITIVES + prim_c % N_CAPSULES
            ell_boxes = np.concatenate([b[N_CAPSULES:CARTON] for b in boxes])
            flat_e, prim_e = self._pixels_of_boxes(ell_boxes)
            t_e = self._ellipsoids(
                flat_e,
                prim_e,
                np.concatenate([body.ellipsoid_centre[frame] for body in self.bodies]),
                np.concatenate([body.ellipsoid_axes[frame] for body in self.bodies]),
                np.concatenate([body.ellipsoid_radii for body in self.bodies]),
            )
            gid_e = (prim_e // N_ELLIPSOIDS) * N_PRIMITIVES + N_CAPSULES + prim_e % N_ELLIPSOIDS
            flats, ts, gids = [flat_c, flat_e], [t_c, t_e], [gid_c, gid_e]
            for w, body in enumerate(self.bodies):
                if body.carrying[frame]:
                    f_b, _ = self._pixels_of_boxes(boxes[w][CARTON : CARTON + 1])
                    flats.append(f_b)
                    ts.append(
                        self._obb(f_b, body.carton_centre[frame], body.carton_axes[frame], body.carton_half[frame])
                    )
                    gids.append(np.full(len(f_b), w * N_PRIMITIVES + CARTON))
            flat = np.concatenate(flats)
            t = np.concatenate(ts)
            gid = np.concatenate(gids).astype(np.int16)
            hit = t < self.bg_depth_flat[flat]  # NaN (miss) compares False
            flat, t, gid = flat[hit], t[hit], gid[hit]
        # z-buffer: the nearest surface per pixel (sort by pixel, then distance; keep the first)
        order = np.lexsort((t, flat))
        flat, t, gid = flat[order], t[order], gid[order]
        first = np.ones(len(flat), bool)
        first[1:] = flat[1:] != flat[:-1]
        return flat[first], t[first], gid[first]

    def _composite(self, img: np.ndarray, pix: np.ndarray, colours: np.ndarray, boxes: list[np.ndarray]) -> None:
        """Paint the body pixels into the sharp background, blur around them, paste into ``img``."""
        h, w = self.camera.height, self.camera.width
        sharp = self.sharp_gained.copy()
        sharp.reshape(-1, 3)[pix] = colours
        if self.options.blur_sigma <= 0:
            img.reshape(-1, 3)[pix] = colours
            return
        margin = 2 + int(math.ceil(3 * self.options.blur_sigma))
        rows, cols = pix // w, pix % w
        regions = []
        for b in boxes:  # one region per worker: the pixels it covers, plus the blur margin
            regions.append([int(b[:, 0].min()), int(b[:, 1].min()), int(b[:, 2].max()), int(b[:, 3].max())])
        merged = _merge_regions(regions)
        for u0, v0, u1, v1 in merged:
            inside = (rows >= v0) & (rows < v1) & (cols >= u0) & (cols < u1)
            if not inside.any():
                continue
            r0, r1 = int(rows[inside].min()), int(rows[inside].max()) + 1
            c0, c1 = int(cols[inside].min()), int(cols[inside].max()) + 1
            # blur a region larger by 2 margins; paste the inner part (one margin) whose blur saw full kernels
            a0, a1 = max(0, r0 - 2 * margin), min(h, r1 + 2 * margin)
            b0, b1 = max(0, c0 - 2 * margin), min(w, c1 + 2 * margin)
            blurred = self._blur(sharp[a0:a1, b0:b1])
            i0, i1 = max(0, r0 - margin), min(h, r1 + margin)
            j0, j1 = max(0, c0 - margin), min(w, c1 + margin)
            img[i0:i1, j0:j1] = blurred[i0 - a0 : i1 - a0, j0 - b0 : j1 - b0]

    def _set_gain(self, frame: int) -> None:
        """Slow brightness drift; the background is rescaled only when the quantised gain changes."""
        gain = 1.0 + self.options.brightness_drift * math.sin(2 * math.pi * frame / (12.0 * 47.0))
        level = round(gain * 400.0) / 400.0
        if level != getattr(self, "_gain", None):
            self._gain = level
            lut = np.clip(np.arange(256, dtype=np.float64) * level + 0.5, 0, 255).astype(np.uint8)
            self.background_gained = cv2.LUT(self.background, lut)
            self.sharp_gained = cv2.LUT(self.sharp_background, lut)

    def _noise_add(self, img: np.ndarray) -> np.ndarray:
        if self._noise:
            pos, neg = self._noise[int(self._noise_pick.integers(len(self._noise)))]
            cv2.add(img, pos, dst=img)
            cv2.subtract(img, neg, dst=img)
        return img

    def _shade_body(self, frame: int, w: int, local: np.ndarray, t: np.ndarray, d: np.ndarray) -> np.ndarray:
        """Colours (n, 3) uint8 of body pixels: primitive index, hit distance, ray."""
        body = self.bodies[w]
        p = (self.origin + d * t[:, None]).astype(np.float32)
        normal = np.empty_like(p)
        cap = local < N_CAPSULES
        if cap.any():
            k = local[cap]
            a = body.capsule_a[frame][k]
            ab = body.capsule_b[frame][k] - a
            s = np.clip(dot(p[cap] - a, ab) / np.maximum(dot(ab, ab), 1e-12), 0.0, 1.0)
            normal[cap] = p[cap] - (a + s[:, None] * ab)
        ell = (local >= N_CAPSULES) & (local < CARTON)
        colour = body.colours[local].copy()
        if ell.any():
            e = local[ell] - N_CAPSULES
            axes = body.ellipsoid_axes[frame][e]
            radii = body.ellipsoid_radii[e]
            q = np.einsum("nji,nj->ni", axes, p[ell] - body.ellipsoid_centre[frame][e]) / radii
            normal[ell] = np.einsum("nij,nj->ni", axes, q / radii)
            head = e == HEAD - N_CAPSULES
            if head.any():
                colour[np.flatnonzero(ell)[head]] = self._face(body, unit_vectors(q[head]), colour[ell][head])
        box = local == CARTON
        if box.any():
            axes = body.carton_axes[frame]
            q = (p[box] - body.carton_centre[frame]) @ axes / body.carton_half[frame]
            ax = np.argmax(np.abs(q), axis=1)
            sign = np.sign(q[np.arange(len(q)), ax])
            normal[box] = axes.T[ax] * sign[:, None]
        normal = unit_vectors(normal)
        shade = lambert_shade(normal)
        return np.clip(colour * (shade * self._gain)[:, None], 0, 255).astype(np.uint8)

    @staticmethod
    def _face(body: BodyPrimitives, q: np.ndarray, skin: np.ndarray) -> np.ndarray:
        """Head colours from the unit direction q (n, 3) in the head ellipsoid's scaled frame."""
        col = skin.copy()
        hair = (q[:, 2] > 0.42) | ((q[:, 0] < -0.15) & (q[:, 2] > -0.3))
        col[hair] = body.hair
        for e in body.eye_dirs:
            col[dot(q, e) > math.cos(0.16)] = (35, 30, 30)
        m = body.mouth_dir
        mouth = (dot(q, m) > math.cos(0.3)) & (np.abs(q[:, 2] - m[2]) < 0.05)
        col[mouth] = (60, 50, 150)
        return col


def _merge_regions(regions: list[list[int]]) -> list[list[int]]:
    """Merge overlapping boxes (u0, v0, u1, v1) until none overlap."""
    merged = [list(r) for r in regions]
    changed = True
    while changed:
        changed = False
        for i in range(len(merged)):
            for j in range(i + 1, len(merged)):
                a, b = merged[i], merged[j]
                if a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]:
                    merged[i] = [min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])]
                    del merged[j]
                    changed = True
                    break
            if changed:
                break
    return merged


# --- videos ------------------------------------------------------------------------------------------------


def render_video(
    camera: Camera,
    scene: Scene,
    bodies: list[BodyPrimitives],
    path: str | Path,
    fps: float,
    options: RenderOptions = RenderOptions(),
    on_frame: Callable[[int], None] | None = None,
) -> Path:
    """Render every frame of one camera into an mp4v video at ``path`` (written atomically)."""
    n_frames = bodies[0].n_frames if bodies else 0
    renderer = CameraRenderer(camera, scene, bodies, options)
    path = Path(path)
    with atomic_path(path) as tmp:
        writer = open_video_writer(tmp, fps, camera.width, camera.height)
        try:
            for f in range(n_frames):
                writer.write(renderer.render(f))
                if on_frame is not None:
                    on_frame(f + 1)
        finally:
            writer.release()
    return path


__all__ = [
    "RenderOptions",
    "BodyPrimitives",
    "body_primitives",
    "all_body_primitives",
    "CameraRenderer",
    "render_video",
    "render_background",
    "pixel_rays",
    "joint_visibility",
    "StaticScene",
    "VISIBILITY_CODES",
    "VISIBLE",
    "SELF_OCCLUDED",
    "OCCLUDED_BY_WORKER",
    "OCCLUDED_BY_SCENE",
    "OUTSIDE_IMAGE",
    "PRIMITIVE_NAMES",
    "ray_capsule",
    "ray_ellipsoid",
    "ray_box",
    "head_axes",
]
