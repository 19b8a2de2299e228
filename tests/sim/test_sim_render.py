"""The renderer: exact ray intersections, z-buffering, joints on the mannequins, visibility."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.keypoints import JOINT_INDEX as J
from ergopose.sim.motion import simulate_motion
from ergopose.sim.bodies import N_PRIMITIVES, all_body_primitives
from ergopose.sim.raycast import ray_box, ray_capsule, ray_ellipsoid
from ergopose.sim.render import CameraRenderer, RenderOptions
from ergopose.sim.visibility import OCCLUDED_BY_SCENE, OCCLUDED_BY_WORKER, VISIBLE, joint_visibility
from ergopose.sim.scene import default_scene, rig_cameras

CLEAN = RenderOptions(noise_sigma=0.0, blur_sigma=0.0, brightness_drift=0.0)
SIZE = (640, 480)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _march(origin, d, inside, t_max=6.0, step=1e-4):
    """Brute force: the first distance along each ray where ``inside`` holds (inf if none)."""
    t = np.arange(0.0, t_max, step)
    out = np.full(len(d), np.inf)
    for i in range(len(d)):  # a test oracle, few rays
        p = origin + t[:, None] * d[i]
        hit = np.flatnonzero(inside(p, i))
        if hit.size:
            out[i] = t[hit[0]]
    return out


def test_ray_capsule_matches_brute_force(rng):
    origin = np.array([0.1, -0.2, 3.0])
    a = rng.uniform(-0.5, 0.5, (40, 3)) + [0, 0, 1.0]
    b = a + rng.uniform(-0.4, 0.4, (40, 3))
    r = rng.uniform(0.03, 0.12, 40)
    target = 0.5 * (a + b) + rng.normal(0, 0.05, (40, 3))
    d = _unit(target - origin)
    t = ray_capsule(origin, d, a, b, r)

    def inside(p, i):
        ab = b[i] - a[i]
        s = np.clip((p - a[i]) @ ab / (ab @ ab), 0, 1)
        return np.linalg.norm(p - (a[i] + s[:, None] * ab), axis=1) <= r[i]

    ref = _march(origin, d, inside)
    assert np.isfinite(t).sum() > 20
    assert np.array_equal(np.isfinite(t), np.isfinite(ref))
    assert np.abs(t[np.isfinite(t)] - ref[np.isfinite(ref)]).max() < 2e-4


@pytest.mark.slow
def test_ray_ellipsoid_and_box_match_brute_force(rng):
    origin = np.array([-0.3, 0.4, 3.0])
    centre = rng.uniform(-0.5, 0.5, (30, 3)) + [0, 0, 1.0]
    q, _ = np.linalg.qr(rng.normal(size=(30, 3, 3)))
    axes = q * np.sign(np.linalg.det(q))[:, None, None]
    radii = rng.uniform(0.05, 0.25, (30, 3))
    d = _unit(centre + rng.normal(0, 0.1, (30, 3)) - origin)
    t_e = ray_ellipsoid(origin, d, centre, axes, radii)
    t_b = ray_box(origin, d, centre, axes, radii)

    def in_ellipsoid(p, i):
        loc = (p - centre[i]) @ axes[i] / radii[i]
        return (loc * loc).sum(axis=1) <= 1.0

    def in_box(p, i):
        loc = (p - centre[i]) @ axes[i]
        return (np.abs(loc) <= radii[i]).all(axis=1)

    for t, inside in ((t_e, in_ellipsoid), (t_b, in_box)):
        ref = _march(origin, d, inside)
        assert np.isfinite(t).sum() > 15
        assert np.array_equal(np.isfinite(t), np.isfinite(ref))
        assert np.abs(t[np.isfinite(t)] - ref[np.isfinite(ref)]).max() < 2e-4


@pytest.fixture(scope="module")
def world():
    scene = default_scene()
    motion = simulate_motion(scene, 3, 30.0, 12.0, seed=21)
    return scene, motion, all_body_primitives(motion), rig_cameras(*SIZE)


def test_batched_kernels_equal_the_reference_intersections(world):
    scene, motion, bodies, cams = world
    r = CameraRenderer(cams[0], scene, bodies[:1], CLEAN)
    body, f = bodies[0], 100
    box = r._frame_boxes(f)[0]
    flat, prim = r._pixels_of_boxes(box[:14])
    t = r._capsules(flat, prim, body.capsule_a[f], body.capsule_b[f], body.capsule_radius)
    d = r.rays_flat[flat].astype(np.float64)
    ref = ray_capsule(
        cams[0].position_world,
        d,
        body.capsule_a[f][prim].astype(np.float64),
        body.capsule_b[f][prim].astype(np.float64),
        body.capsule_radius[prim].astype(np.float64),
    )
    both = np.isfinite(t) & np.isfinite(ref)
    assert both.sum() > 100
    assert (np.isfinite(t) != np.isfinite(ref)).mean() < 0.005  # grazing rays may differ in float32
    err = np.abs(t - ref)[both]
    assert np.percentile(err, 99) < 1e-3 and err.max() < 1e-2  # float32 rays: a few mm at grazing hits
    flat, prim = r._pixels_of_boxes(box[14:19])
    t = r._ellipsoids(flat, prim, body.ellipsoid_centre[f], body.ellipsoid_axes[f], body.ellipsoid_radii)
    d = r.rays_flat[flat].astype(np.float64)
    ref = ray_ellipsoid(
        cams[0].position_world,
        d,
        body.ellipsoid_centre[f][prim].astype(np.float64),
        body.ellipsoid_axes[f][prim].astype(np.float64),
        body.ellipsoid_radii[prim].astype(np.float64),
    )
    both = np.isfinite(t) & np.isfinite(ref)
    assert both.sum() > 100
    assert (np.isfinite(t) != np.isfinite(ref)).mean() < 0.005
    err = np.abs(t - ref)[both]
    assert np.percentile(err, 99) < 1e-3 and err.max() < 1e-2


@pytest.mark.slow
def test_every_primitive_is_inside_its_box(world):
    """No part of a mannequin is clipped: no surface pixel lies on the rim of its bounding box."""
    scene, motion, bodies, cams = world
    for cam in cams:
        r = CameraRenderer(cam, scene, bodies, CLEAN)
        for f in range(0, motion.n_frames, 45):
            for w, box in enumerate(r._frame_boxes(f)):
                for k in range(14):
                    u0, v0, u1, v1 = box[k]
                    if u1 - u0 < 3 or v1 - v0 < 3:
                        continue
                    flat, prim = r._pixels_of_boxes(box[k : k + 1])
                    t = r._capsules(
                        flat,
                        prim,
                        bodies[w].capsule_a[f, k : k + 1],
                        bodies[w].capsule_b[f, k : k + 1],
                        bodies[w].capsule_radius[k : k + 1],
                    )
                    rows, cols = flat // cam.width, flat % cam.width
                    rim = (rows == v0) | (rows == v1 - 1) | (cols == u0) | (cols == u1 - 1)
                    inside_image = (u0 > 0) & (v0 > 0) & (u1 < cam.width) & (v1 < cam.height)
                    if inside_image:
                        assert not np.isfinite(t[rim]).any()


@pytest.mark.slow
def test_joints_land_on_the_mannequins_and_far_pixels_show_the_background(world):
    scene, motion, bodies, cams = world
    sturdy = [J[n] for n in ("left_hip", "right_hip", "left_shoulder", "right_shoulder", "nose", "left_knee")]
    for c, cam in enumerate(cams):
        r = CameraRenderer(cam, scene, bodies, CLEAN)
        pixels, _, codes = joint_visibility(cam, scene, motion, bodies)
        hits = total = 0
        for f in range(0, motion.n_frames, 30):
            img = r.render(f)
            diff = np.any(img != r.background, axis=-1)
            for w in range(len(bodies)):
                for j in sturdy:
                    if codes[f, w, j] != VISIBLE:
                        continue
                    u, v = np.rint(pixels[f, w, j]).astype(int)
                    total += 1
                    hits += diff[v, u]
            # pixels far from every worker: identical to the background
            proj = pixels[f].reshape(-1, 2)
            proj = proj[np.isfinite(proj).all(axis=1)]
            vv, uu = np.mgrid[0 : cam.height : 7, 0 : cam.width : 7]
            far = np.min(np.hypot(uu[..., None] - proj[:, 0], vv[..., None] - proj[:, 1]), axis=-1) > 60
            assert far.sum() > 1000
            assert np.array_equal(img[vv[far], uu[far]], r.background[vv[far], uu[far]])
        assert total > 50 and hits / total > 0.97, (cam.name, hits, total)


@pytest.mark.slow
def test_visibility_agrees_with_the_z_buffer(world):
    """Visible joints show their own worker; joints hidden by furniture show no worker there;
    joints hidden by another worker show that worker."""
    scene, motion, bodies, cams = world
    counts = {VISIBLE: [0, 0], OCCLUDED_BY_SCENE: [0, 0], OCCLUDED_BY_WORKER: [0, 0]}
    sturdy = [J[n] for n in ("left_hip", "right_hip", "left_shoulder", "right_shoulder", "left_knee", "right_knee")]
    for cam in cams:
        r = CameraRenderer(cam, scene, bodies, CLEAN)
        pixels, _, codes = joint_visibility(cam, scene, motion, bodies)
        for f in range(0, motion.n_frames, 6):
            ids, _ = r.surface_ids(f)
            owner = np.where(ids >= 0, ids // N_PRIMITIVES, -1)
            for w in range(len(bodies)):
                for j in sturdy:
                    code = int(codes[f, w, j])
                    if code not in counts:
                        continue
                    u, v = np.rint(pixels[f, w, j]).astype(int)
                    o = owner[v, u]
                    ok = {VISIBLE: o == w, OCCLUDED_BY_SCENE: o == -1, OCCLUDED_BY_WORKER: o not in (-1, w)}[code]
                    counts[code][0] += int(ok)
                    counts[code][1] += 1
    assert counts[VISIBLE][1] > 200 and counts[VISIBLE][0] / counts[VISIBLE][1] > 0.97
    assert counts[OCCLUDED_BY_SCENE][1] > 10, "the scene should hide some joints (shelves)"
    assert counts[OCCLUDED_BY_SCENE][0] / counts[OCCLUDED_BY_SCENE][1] > 0.9
    if counts[OCCLUDED_BY_WORKER][1]:
        assert counts[OCCLUDED_BY_WORKER][0] / counts[OCCLUDED_BY_WORKER][1] > 0.8


def test_background_depth_is_the_distance_to_the_floor():
    scene = default_scene()
    cam = rig_cameras(*SIZE)[0]
    r = CameraRenderer(cam, scene, [], CLEAN)
    floor = np.array([[0.3, 0.6, 0.0], [-0.8, -1.6, 0.0], [1.2, -0.9, 0.0]])
    pix = cam.project_world(floor)
    for p, q in zip(floor, pix):
        # the ray through the nearest pixel centre meets the floor close to the point
        u, v = np.rint(q).astype(int)
        ray = r.rays[v, u].astype(np.float64)
        t = -cam.position_world[2] / ray[2]
        assert r.bg_depth[v, u] == pytest.approx(t, rel=1e-5)
        assert np.linalg.norm(cam.position_world + t * ray - p) < 0.03


@pytest.mark.slow
def test_camera_effects_are_seeded(world):
    scene, motion, bodies, cams = world
    a = CameraRenderer(cams[1], scene, bodies, RenderOptions(seed=5)).render(10)
    b = CameraRenderer(cams[1], scene, bodies, RenderOptions(seed=5)).render(10)
    c = CameraRenderer(cams[1], scene, bodies, RenderOptions(seed=6)).render(10)
    clean = CameraRenderer(cams[1], scene, bodies, CLEAN).render(10)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    noise = a.astype(int) - clean.astype(int)
    assert 1.0 < noise.std() < 6.0
