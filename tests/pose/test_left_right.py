"""One camera's left/right check on made-up skeletons (ergopose/pose/left_right.py), without the
network: the answers are known because the test decides in which frames the "network" labels the
person the other way round.

The memory (``PoseSettings.left_right_memory``): a labelling the network held for most of the
remembered frames is kept through a long run of the other labelling (the Pose2Sim recording's
cam_02, where BlazePose labels the person's sides the other way round for 26 frames on end after
42 right ones), and a wrong start is still given up once the network's other labelling has more
support.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pose2sim_clip import Pose2SimClip

from ergopose.commands.pose import LEFT_RIGHT_MEMORY_S
from ergopose.keypoints import JOINT_INDEX, MIRROR, NUM_JOINTS
from ergopose.pose.blazepose import Keypoints2D
from ergopose.pose.left_right import LeftRightCheck
from ergopose.pose.settings import PoseSettings

L_SH, R_SH = JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]


def _skeleton_rays(t: int) -> np.ndarray:
    """Rays (33, 3) of a person facing the camera, left side at +x, drifting slowly in x."""
    rng = np.random.default_rng(5)
    base = rng.normal(0.0, 0.02, (NUM_JOINTS, 2))
    for name, i in JOINT_INDEX.items():
        if name.startswith("left_"):
            base[i, 0] = abs(base[i, 0]) + 0.05
        elif name.startswith("right_"):
            base[i, 0] = -abs(base[i, 0]) - 0.05
    xy = base + [0.001 * t, 0.0]
    rays = np.column_stack([xy, np.ones(NUM_JOINTS)])
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


def _person(t: int, swapped: bool) -> dict:
    rays = _skeleton_rays(t)
    if swapped:
        rays = rays[MIRROR]
    kp = Keypoints2D(pixels=rays[:, :2] * 500.0, confidence=np.full(NUM_JOINTS, 0.99), presence=1.0)
    hips = rays[[JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]].mean(axis=0)
    return {"kp": kp, "rays_cam": rays, "bearing": (hips / np.linalg.norm(hips), 0.2, None)}


def _labels_out(settings: PoseSettings, network_swapped: list[bool]) -> list[bool]:
    """Per frame: True when the check passes the person on with left at +x (the truth)."""
    check = LeftRightCheck(settings)
    out = []
    for t, swapped in enumerate(network_swapped):
        (p,) = check([_person(t, swapped)])
        out.append(bool(p["rays_cam"][L_SH, 0] > p["rays_cam"][R_SH, 0]))
    return out


def test_a_long_wrong_run_after_a_longer_right_one_is_corrected_with_a_memory():
    network = [False] * 42 + [True] * 26 + [False] * 3 + [True] * 8 + [False] * 21
    without = _labels_out(dataclasses.replace(PoseSettings(), left_right_memory=None), network)
    with_memory = _labels_out(dataclasses.replace(PoseSettings(), left_right_memory=120.0), network)
    # Without a memory the network's new labelling is followed after 5 of 9 frames, and kept.
    assert without[:42] == [True] * 42 and not any(without[47:68]), without
    # With it every frame keeps the labelling the network gave first and most.
    assert all(with_memory), with_memory


def test_a_wrong_start_is_given_up_with_a_memory():
    """The network's first 3 frames are the wrong way round, then right for good: the right
    labelling is followed once it has more support than the wrong one (and 5 of the last 9
    frames), then kept."""
    network = [True] * 3 + [False] * 30
    out = _labels_out(dataclasses.replace(PoseSettings(), left_right_memory=120.0), network)
    assert not any(out[:3]), out  # nothing to tell the first frames are wrong
    first_right = out.index(True)
    assert first_right <= 3 + PoseSettings().left_right_window, out
    assert all(out[first_right:]), out


def test_the_memory_fades():
    """With a short memory an old labelling's support fades: a long wrong run is followed."""
    network = [False] * 42 + [True] * 26
    short = _labels_out(dataclasses.replace(PoseSettings(), left_right_memory=5.0), network)
    long = _labels_out(dataclasses.replace(PoseSettings(), left_right_memory=1e9), network)
    assert not all(short) and all(long)


@pytest.mark.slow
def test_real_frames_cam_02_keeps_its_sides_with_the_pose_commands_memory(shared_data, fetched_model_dir):
    """cam_02 of the Pose2Sim recording, frames 0-79, through the 2D stage as `ergopose pose` runs
    it. BlazePose labels the person's sides the other way round from frame 42 for most of the
    next 37 frames (against Pose2Sim's 3D result projected into the camera); without a memory the
    check follows it after 5 frames, with the command's 2 s memory every frame keeps its sides."""
    clip = Pose2SimClip(shared_data, fetched_model_dir[0], number=2, frames=80)
    crossed = {}
    for name, memory in (("none", None), ("command", LEFT_RIGHT_MEMORY_S * clip.info.fps)):
        scores = clip.scores(dataclasses.replace(PoseSettings(), left_right_memory=memory))
        assert all(s["found"] for s in scores), name
        crossed[name] = sum(bool(s["swapped"]) for s in scores)
    assert crossed["none"] >= 20 and crossed["command"] <= 2, crossed
