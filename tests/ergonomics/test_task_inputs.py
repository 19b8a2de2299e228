"""Wrist angles from the settings where the hand is not seen (ergopose.ergonomics.task_inputs)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ergopose.ergonomics import task_inputs as T
from ergopose.keypoints import JOINT_INDEX, NUM_JOINTS

LEFT_HAND = [JOINT_INDEX[j] for j in ("left_wrist", "left_index", "left_pinky")]


def _posture(n: int = 4) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "left_wrist_flexion": np.radians([5.0, 5.0, np.nan, 5.0][:n]),
            "right_wrist_flexion": np.radians([-8.0] * n),
            "left_wrist_deviation": np.zeros(n),
            "right_wrist_deviation": np.zeros(n),
            "trunk_flexion": np.full(n, 0.3),
        }
    )


def test_hidden_where_nan_or_every_hand_point_inferred():
    inferred = np.zeros((4, NUM_JOINTS), bool)
    inferred[0, LEFT_HAND] = True  # all three: hidden
    inferred[1, LEFT_HAND[1:]] = True  # the wrist itself seen: not hidden
    hidden = T.hidden_inputs(_posture(), inferred)
    assert hidden["left_wrist_flexion"].tolist() == [True, False, True, False]
    assert hidden["left_wrist_deviation"].tolist() == [True, False, False, False]
    assert not hidden["right_wrist_flexion"].any() and not hidden["right_wrist_deviation"].any()
    # without inferred flags only the NaN angle is hidden
    assert T.hidden_inputs(_posture(), None)["left_wrist_flexion"].tolist() == [False, False, True, False]


def test_settings_value_replaces_only_hidden_angles_where_given():
    posture = _posture()
    inferred = np.zeros((4, NUM_JOINTS), bool)
    inferred[0, LEFT_HAND] = True
    task = pd.DataFrame({"wrist_flexion": np.radians([20.0, 20.0, 20.0, np.nan]), "wrist_deviation": np.nan})
    use = T.settings_use(T.hidden_inputs(posture, inferred), task)
    assert use["left_wrist_flexion"].tolist() == [True, False, True, False]
    assert not use["left_wrist_deviation"].any()  # hidden in frame 0, but the settings give no deviation
    out = T.apply_settings(posture, use, task)
    np.testing.assert_allclose(np.degrees(out["left_wrist_flexion"]), [20.0, 5.0, 20.0, 5.0])
    pd.testing.assert_frame_equal(out.drop(columns="left_wrist_flexion"), posture.drop(columns="left_wrist_flexion"))
    assert np.isnan(posture["left_wrist_flexion"][2])  # the input table is not changed
    column = T.inputs_column(use, 4)
    assert column.tolist() == ["left_wrist_flexion", "", "left_wrist_flexion", ""]


def test_inputs_column_lists_several_inputs_in_order_and_is_read_back():
    use = {name: np.array([True, False, name.startswith("right")]) for name in T.SETTINGS_INPUTS}
    column = T.inputs_column(use, 3)
    assert column.tolist() == [
        "left_wrist_flexion;right_wrist_flexion;left_wrist_deviation;right_wrist_deviation",
        "",
        "right_wrist_flexion;right_wrist_deviation",
    ]
    assert T.used_mask(column, "right_wrist_flexion").tolist() == [True, False, True]
    assert T.used_mask(column, "left_wrist_deviation").tolist() == [True, False, False]
    assert T.used_mask(pd.Series(["", None], dtype="string"), "left_wrist_flexion").tolist() == [False, False]
