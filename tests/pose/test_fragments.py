"""Small skeletons squeezed onto part of a bigger one are dropped (ergopose/pose/fragments.py).

Geometry against an independent computation (the nearest point of each bone found by sampling
the great-circle arc densely), made-up skeletons with a known answer, and real frames of the
Pose2Sim recording where the network fitted a small skeleton onto the person and, before the
rule, that skeleton replaced the person for three frames.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pose2sim_clip import Pose2SimClip

from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS
from ergopose.pose.fragments import BONES, distance_to_bones, is_fragment
from ergopose.pose.settings import PoseSettings

RNG_SEED = 17


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _arc_distance(points, a, b, samples=4001):
    """Angle from each point to the great-circle arc a-b, by dense sampling (slerp)."""
    omega = np.arccos(np.clip(a @ b, -1, 1))
    t = np.linspace(0.0, 1.0, samples)[:, None]
    arc = (np.sin((1 - t) * omega) * a + np.sin(t * omega) * b) / np.sin(omega)
    return np.arccos(np.clip(points @ arc.T, -1, 1)).min(axis=1)


#: A standing skeleton in degrees on a tangent plane (x right, y down), hips at the origin,
#: about 25 degrees tall: the 2D layout of a person some metres from the camera.
_LAYOUT_DEG = {
    "nose": (0.0, -11.0),
    "left_shoulder": (-2.0, -8.0),
    "right_shoulder": (2.0, -8.0),
    "left_elbow": (-3.0, -4.5),
    "right_elbow": (3.0, -4.5),
    "left_wrist": (-3.2, -1.0),
    "right_wrist": (3.2, -1.0),
    "left_hip": (-1.2, 0.0),
    "right_hip": (1.2, 0.0),
    "left_knee": (-1.3, 6.0),
    "right_knee": (1.3, 6.0),
    "left_ankle": (-1.4, 12.0),
    "right_ankle": (1.4, 12.0),
}


def _skeleton(centre_deg=(0.0, 0.0), scale=1.0, offset_axis=(0.0, 0.0, 1.0)):
    """Rays (33, 3) and usable mask of the layout, scaled and moved on the sphere around
    ``offset_axis``; joints not in the layout are unusable."""
    rays = np.full((NUM_JOINTS, 3), np.nan)
    good = np.zeros(NUM_JOINTS, bool)
    for name, (x, y) in _LAYOUT_DEG.items():
        ang = np.radians([centre_deg[0] + scale * x, centre_deg[1] + scale * y])
        rays[JOINT_INDEX[name]] = _unit([np.tan(ang[0]), np.tan(ang[1]), 1.0])
        good[JOINT_INDEX[name]] = True
    return rays, good


def _radius(rays, good):
    hip = _unit(rays[[JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]].mean(0))
    return float(np.arccos(np.clip(rays[good] @ hip, -1, 1)).max())


def test_distance_to_bones_matches_dense_arc_sampling():
    rng = np.random.default_rng(RNG_SEED)
    rays, good = _skeleton()
    points = _unit(np.column_stack([rng.uniform(-0.3, 0.3, (50, 2)), np.ones(50)]))
    bones = BONES[good[BONES[:, 0]] & good[BONES[:, 1]]]
    expected = np.min([_arc_distance(points, rays[a], rays[b]) for a, b in bones], axis=0)
    got = distance_to_bones(points, rays, good)
    # The chord stands in for the arc: at angles of about 10-20 degrees they differ by well
    # under a hundredth of a degree.
    assert np.abs(np.degrees(got - expected)).max() < 0.02
    assert bones.shape[0] >= 12  # limbs, trunk and neck


def test_distance_to_bones_without_usable_bones_is_infinite():
    rays, good = _skeleton()
    good[:] = False
    good[JOINT_INDEX["nose"]] = True
    assert np.isinf(distance_to_bones(rays[:2] * 0 + [0, 0, 1.0], rays, good)).all()


def test_a_small_skeleton_on_the_body_is_a_fragment():
    big, big_good = _skeleton()
    r_big = _radius(big, big_good)
    # A skeleton a third of the size fitted onto the upper body: hips on the chest, head on the
    # head, as the network does in a view holding only the top of a person.
    small, small_good = _skeleton(centre_deg=(0.0, -6.0), scale=0.4)
    r_small = _radius(small, small_good)
    assert is_fragment(small, small_good, r_small, big, big_good, r_big, 0.7, 0.2)
    # Never the other way round: the whole person is not a fragment of the small one.
    assert not is_fragment(big, big_good, r_big, small, small_good, r_small, 0.7, 0.2)
    # With the rule off (ratio 0) nothing is a fragment.
    assert not is_fragment(small, small_good, r_small, big, big_good, r_big, 0.0, 0.2)


@pytest.mark.parametrize(
    "centre_deg, scale, why",
    [
        ((14.0, 0.0), 0.9, "a person of about the same size standing beside"),
        ((9.0, -3.0), 0.6, "a smaller (farther) person standing behind, half overlapping"),
        ((0.0, 30.0), 0.3, "a small skeleton on an object below the person"),
    ],
)
def test_other_people_and_things_are_not_fragments(centre_deg, scale, why):
    big, big_good = _skeleton()
    other, other_good = _skeleton(centre_deg=centre_deg, scale=scale)
    assert not is_fragment(
        other, other_good, _radius(other, other_good), big, big_good, _radius(big, big_good), 0.7, 0.2
    ), why


@pytest.mark.slow
def test_real_frames_a_squeezed_skeleton_no_longer_replaces_the_person(shared_data, fetched_model_dir):
    """cam_04 of the Pose2Sim recording, frames 0-29 through the 2D stage alone (as `ergopose
    pose` runs it). The search at frame 24 finds, beside the person, two small skeletons on the
    person's body; before the fragment rule the more upright one won the duplicate merge, the
    person's view was dropped and the person was lost in frames 25-27, and a small skeleton was
    reported beside the person in frames 12-17 and 24. Now the person is found in every frame
    (hips within half a torso of Pose2Sim's 3D result projected into the camera) and nothing else
    is reported."""
    clip = Pose2SimClip(shared_data, fetched_model_dir[0], number=4, frames=30)
    outcome = {}
    for name, ratio in (("before", 0.0), ("after", PoseSettings().fragment_ratio)):
        scores = clip.scores(dataclasses.replace(PoseSettings(), fragment_ratio=ratio))
        outcome[name] = ([s["found"] for s in scores], [s["people"] for s in scores])
    found, counts = outcome["before"]
    assert not all(found[25:28]) and max(counts) > 1, outcome["before"]
    found, counts = outcome["after"]
    assert all(found), found
    assert counts == [1] * clip.frames, counts
