"""``PoseSettings.min_follow_presence``: a person once found is followed down to a lower pose flag
than a new person needs (measured and not the default: docs/pose-in-fisheye.md, "A lower gate for
people already followed").

The real BlazePose networks on the drawn person warped into a fisheye frame (test_fisheye), with
the network's pose flag replaced by a chosen value: with the lower gate the stage keeps a followed
person at a flag between it and ``min_presence`` and drops them below it; a new person (search
view) is never taken at such a flag; without it (the default) the same flag loses the person.
"""

from __future__ import annotations

import dataclasses

import pytest
from test_fisheye import LENS, SIZE, fisheye_with_person

from ergopose.geometry.camera import ceiling_camera
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.models import landmark_card
from ergopose.pose.records import SOURCE_REFOCUS, SOURCE_SEARCH
from ergopose.pose.settings import PoseSettings


class _Flagged:
    """The real landmark network, its pose flag set to ``flag`` (None: the network's own)."""

    def __init__(self, landmarker):
        self.inner, self.flag = landmarker, None
        self.input_size = landmarker.input_size

    def __call__(self, image):
        kp = self.inner(image)
        return kp if self.flag is None else dataclasses.replace(kp, presence=float(self.flag))


def _counts(stage, frame, frames):
    out = []
    for f in frames:
        found = stage.process(frame, f)
        out.append((found.count, tuple(int(s) for s in found.source)))
    return out


#: The gate measured in docs/pose-in-fisheye.md.
FOLLOW = PoseSettings(min_follow_presence=0.2)


def test_the_follow_gate_is_the_lower_of_the_two():
    assert PoseSettings().min_follow_presence is None  # the default: one gate for every view
    assert PoseSettings().follow_presence == PoseSettings().min_presence
    assert FOLLOW.follow_presence == 0.2 < FOLLOW.min_presence
    # A follow gate above min_presence would make a followed person harder to keep than a new one.
    assert dataclasses.replace(FOLLOW, min_follow_presence=0.9).follow_presence == FOLLOW.min_presence
    # A model card's gates leave it as it is.
    assert FOLLOW.with_gates(landmark_card("lite").gates).follow_presence == 0.2


@pytest.mark.slow
def test_a_followed_person_is_kept_at_a_flag_a_new_person_is_not_found_at(camera, landmarker, detector):
    frame, _ = fisheye_with_person(camera, (1.2, 0.8, 1.0))
    s = FOLLOW
    middle = 0.5 * (s.follow_presence + s.min_presence)  # 0.35: between the two gates
    net = _Flagged(landmarker)

    # Found by the search on the first frame, then the flag drops between the gates: followed.
    stage = FisheyePoseEstimator(camera, 0, net, detector, s)
    net.flag = None
    assert _counts(stage, frame, [0]) == [(1, (SOURCE_SEARCH,))]
    net.flag = middle
    assert _counts(stage, frame, range(1, 8)) == [(1, (SOURCE_REFOCUS,))] * 7
    # Below the follow gate the person is dropped (and not found again by the search either).
    net.flag = 0.5 * s.follow_presence
    assert [c for c, _ in _counts(stage, frame, range(8, 14))] == [0] * 6

    # Without the lower gate the same flag loses the person at once.
    stage = FisheyePoseEstimator(camera, 0, net, detector, dataclasses.replace(s, min_follow_presence=None))
    net.flag = None
    assert _counts(stage, frame, [0]) == [(1, (SOURCE_SEARCH,))]
    net.flag = middle
    assert [c for c, _ in _counts(stage, frame, range(1, 8))] == [0] * 7

    # A new person needs min_presence: at the same flag the search never takes them (the first
    # frame runs the whole pass of search views; a pass spreads over the next frames).
    stage = FisheyePoseEstimator(camera, 0, net, detector, s)
    net.flag = middle
    frames = range(stage.search_period(False) + 1)
    assert [c for c, _ in _counts(stage, frame, frames)] == [0] * len(frames)
    assert stage.landmark_runs > 0  # the search's cues were run through the network and refused
    # With the network's own flag the next pass finds them.
    net.flag = None
    later = range(len(frames), 2 * len(frames))
    assert [c for c, _ in _counts(stage, frame, later)][-1] == 1


@pytest.fixture(scope="module")
def camera():
    return ceiling_camera("cam_1", LENS, SIZE, SIZE, position_world=(0.0, 0.0, 3.0))
