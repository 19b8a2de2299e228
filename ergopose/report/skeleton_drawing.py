"""Drawings of a skeleton: the body axes in the floor plane, the front and side projections of
the joints and the figure of both views (a worker's worst moment in the report).

Built on the primitives of :mod:`ergopose.report.svg`.
"""

from __future__ import annotations

import numpy as np
from markupsafe import Markup

from ergopose.keypoints import JOINT_INDEX, LIMBS
from ergopose.report.svg import GRID, MUTED, TEXT, esc, num, svg_element


def body_axes(joints_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(origin, lateral, forward) of a skeleton in the floor plane, from the hips (else shoulders).

    lateral points from the worker's left to right side, forward = up x lateral (where the worker
    faces); origin is the mid point of the pair at floor height. None if neither pair is known.
    """
    j = np.asarray(joints_world, dtype=np.float64)
    for a, b in (("left_hip", "right_hip"), ("left_shoulder", "right_shoulder")):
        pa, pb = j[JOINT_INDEX[a]], j[JOINT_INDEX[b]]
        if np.all(np.isfinite(pa)) and np.all(np.isfinite(pb)):
            lat = (pb - pa) * np.array([1.0, 1.0, 0.0])
            norm = float(np.linalg.norm(lat))
            if norm < 1e-6:
                continue
            lat /= norm
            fwd = np.cross(np.array([0.0, 0.0, 1.0]), lat)
            origin = (pa + pb) / 2 * np.array([1.0, 1.0, 0.0])
            return origin, lat, fwd
    return None


def skeleton_views(
    joints_world: np.ndarray, *, title: str, desc: str, id_prefix: str, panel: float = 170, min_height_m: float = 1.9
) -> Markup:
    """Front and side projections of a 33-joint skeleton (metres, world frame, NaN = missing joint).

    Front view: seen from in front of the worker (the worker's right side on the viewer's left).
    Side view: seen from the worker's right (the worker faces right). Both views share one scale,
    chosen so the whole body fits (at least min_height_m tall); the floor is drawn as a line.
    Left-side limbs are solid blue, right-side limbs dashed red, and L/R mark the wrists.
    """
    j = np.asarray(joints_world, dtype=np.float64).reshape(-1, 3)
    proj = skeleton_projection(j)
    gap = 12
    panel_h = panel * 1.25
    width = 2 * panel + gap + 4
    height = panel_h + 30
    out = []
    if proj is None:
        out.append(
            f'<text x="{num(width / 2)}" y="{num(height / 2)}" text-anchor="middle" fill="{MUTED}">'
            f"skeleton not available</text>"
        )
        return svg_element(width, height, title, desc, id_prefix, out, css_class="fig skeleton")
    front, side, zs = proj
    views = (("front view", front), ("side view (from the right)", side))
    known = np.all(np.isfinite(j), axis=1)
    top_m = max(min_height_m, float(np.nanmax(zs[known])) + 0.15) if known.any() else min_height_m
    spans = [(float(np.min(h[known])), float(np.max(h[known]))) if known.any() else (-0.5, 0.5) for _, h in views]
    widest = max(b - a for a, b in spans) + 0.3
    scale = min((panel_h - 16) / top_m, (panel - 10) / widest)
    floor_y = 4 + panel_h - 8
    for k, (name, hs) in enumerate(views):
        x_left = 2 + k * (panel + gap)
        cx = x_left + panel / 2
        mid = (spans[k][0] + spans[k][1]) / 2
        clip = f"{id_prefix}-clip{k}"

        def P(h: float, z: float) -> tuple[float, float]:
            return cx + (h - mid) * scale, floor_y - z * scale

        out.append(
            f'<clipPath id="{esc(clip)}"><rect x="{num(x_left)}" y="4" width="{num(panel)}" '
            f'height="{num(panel_h)}"/></clipPath>'
        )
        out.append(
            f'<rect x="{num(x_left)}" y="4" width="{num(panel)}" height="{num(panel_h)}" fill="#f7f7f7" stroke="{GRID}"/>'
        )
        out.append(f'<g clip-path="url(#{esc(clip)})">')
        out.append(
            f'<line x1="{num(x_left)}" y1="{num(floor_y)}" x2="{num(x_left + panel)}" y2="{num(floor_y)}" '
            f'stroke="{MUTED}" stroke-width="1.5"/>'
        )
        for limb, a, b in LIMBS:
            ia, ib = JOINT_INDEX[a], JOINT_INDEX[b]
            if not (known[ia] and known[ib]):
                continue
            (xa, ya), (xb, yb) = P(hs[ia], zs[ia]), P(hs[ib], zs[ib])
            if limb.startswith("right"):
                colour, style = "#b2182b", ' stroke-dasharray="5 3"'
            elif limb.startswith("left"):
                colour, style = "#2166ac", ""
            else:
                colour, style = TEXT, ""
            out.append(
                f'<line x1="{num(xa)}" y1="{num(ya)}" x2="{num(xb)}" y2="{num(yb)}" stroke="{colour}" '
                f'stroke-width="3" stroke-linecap="round"{style}/>'
            )
        ls, rs, nose = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"], JOINT_INDEX["nose"]
        if known[ls] and known[rs] and known[nose]:
            xa, ya = P((hs[ls] + hs[rs]) / 2, (zs[ls] + zs[rs]) / 2)
            xb, yb = P(hs[nose], zs[nose])
            out.append(
                f'<line x1="{num(xa)}" y1="{num(ya)}" x2="{num(xb)}" y2="{num(yb)}" stroke="{TEXT}" '
                f'stroke-width="3" stroke-linecap="round"/>'
            )
            out.append(
                f'<circle cx="{num(xb)}" cy="{num(yb)}" r="{num(0.09 * scale)}" fill="none" stroke="{TEXT}" '
                f'stroke-width="2"/>'
            )
        for wrist, letter in (("left_wrist", "L"), ("right_wrist", "R")):
            i = JOINT_INDEX[wrist]
            if known[i]:
                x, y = P(hs[i], zs[i])
                out.append(f'<text x="{num(x + 5)}" y="{num(y + 4)}" font-size="11" font-weight="bold">{letter}</text>')
        out.append("</g>")
        out.append(
            f'<text x="{num(cx)}" y="{num(height - 8)}" text-anchor="middle" font-size="11" fill="{MUTED}">'
            f"{esc(name)}</text>"
        )
    return svg_element(width, height, title, desc, id_prefix, out, css_class="fig skeleton")


def skeleton_projection(joints_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The coordinates skeleton_views draws, per joint (metres; NaN rows = missing joints):
    front: across the body as seen from in front, = minus the distance towards the worker's right
    (the right side is drawn on the viewer's left); side: distance forward of the hips (seen from
    the worker's right, the worker faces the viewer's right); height: above the floor. Origin: the
    floor point under the middle of the hips (else of the shoulders). None when neither pair is
    known."""
    j = np.asarray(joints_world, dtype=np.float64).reshape(-1, 3)
    axes = body_axes(j)
    if axes is None:
        return None
    origin, lat, fwd = axes
    rel = j - origin
    return -(rel @ lat), rel @ fwd, rel[:, 2]
