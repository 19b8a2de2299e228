"""The measurement behind the landmark cards' gates (ergopose/evaluation/model_cards.py): the
quantile-matched gate and the pooled gate table on hand-made values with known answers, and the
crops of the real recording placed on the person."""

from __future__ import annotations

import numpy as np
import pytest

from ergopose.evaluation.model_cards import RIGHT_TORSO, crops_of_recording, gate_table, matched_gate


def test_matched_gate_keeps_the_reference_share():
    reference = np.linspace(0.0, 1.0, 101)  # 30 of 101 below 0.3
    values = np.linspace(0.0, 0.5, 101)  # the same ranks, half the scale
    gate = matched_gate(values, reference, 0.3)
    assert gate == pytest.approx(0.15)
    assert np.mean(values < gate) == pytest.approx(np.mean(reference < 0.3))
    # Nothing below the reference gate: the gate keeps everything (the smallest value).
    assert matched_gate(values, reference + 2.0, 0.3) == 0.0


def _result(visibility, errors, presence, empty):
    return {
        "visibility": np.asarray(visibility, float),
        "errors": np.asarray(errors, float),
        "presence": np.asarray(presence, float),
        "empty_presence": np.asarray(empty, float),
    }


def test_gate_table_pools_sources_and_reports_the_cards_gates():
    right, wrong = RIGHT_TORSO / 2, RIGHT_TORSO * 2
    full = _result([[0.1, 0.9, 0.95, 0.99]], [[right, right, right, wrong]], [0.9], [0.0, 0.1])
    heavy = _result([[0.01, 0.05, 0.5, 0.99]], [[right, right, right, right]], [0.95], [0.04])
    rows = gate_table({"a": {"full": full, "heavy": heavy}, "b": {"full": full, "heavy": heavy}})
    by = {r["model"]: r for r in rows}
    # full: 1 of 3 right keypoints below 0.3 in each source; heavy: 2 of 4.
    assert by["full"]["right_keypoints"] == 6 and by["full"]["right_below_0.3"] == pytest.approx(1 / 3)
    assert by["heavy"]["right_below_0.3"] == pytest.approx(0.5)
    # The matched gate keeps heavy's top two thirds: its third-smallest right visibility of 8.
    assert by["heavy"]["matched_min_keypoint_confidence"] == pytest.approx(0.05)
    assert by["full"]["matched_min_keypoint_confidence"] == pytest.approx(0.9)
    assert by["heavy"]["empty_presence_max"] == pytest.approx(0.04) and by["full"]["empty_kept_by_card_gate"] == 0
    assert by["heavy"]["card_min_keypoint_confidence"] < by["full"]["card_min_keypoint_confidence"]


def test_crops_of_the_real_recording_hold_the_person(shared_data):
    crops = crops_of_recording(shared_data / "pose2sim-demo", frames=2, step=1)
    assert crops["person"].shape == (8, 256, 256, 3)  # 2 frames x 4 cameras
    # The reference hip centre sits at the crop's centre, the body inside the crop.
    hips = crops["reference"][:, [23, 24]].mean(axis=1)
    np.testing.assert_allclose(hips, 127.5, atol=1e-6)
    inside = crops["reference"][:, [11, 12, 23, 24, 25, 26, 27, 28]]
    assert np.nanmin(inside) > 0 and np.nanmax(inside) < 256
    assert np.all(crops["torso"] > 30)
    assert crops["empty"].ndim == 4 and crops["empty"].shape[1:] == (256, 256, 3)
