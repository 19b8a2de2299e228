"""Task inputs from the settings in place of wrist angles the cameras cannot see.

The session settings may give the task's wrist posture (``wrist_flexion_deg``,
``wrist_deviation_deg``; ergopose.session, docs/session-format.md). Per frame and side, a wrist
angle is *hidden* when it could not be measured (NaN) or when every hand point it rests on
(wrist, index, pinky of that side) was placed by the body model rather than seen by two cameras
(the tracks table's ``inferred``). Where an angle is hidden and the settings give a value for that
worker and time, the settings' value replaces the measured angle -- in the posture that is scored
and in every uncertainty draw (the value is given, not measured, so it adds no spread). Where the
hand is seen the measurement stays, whatever the settings say.

``inputs_from_settings`` is the frames' record of it: the replaced posture columns of the frame
joined by ";" (e.g. ``"left_wrist_flexion;right_wrist_deviation"``), empty when none.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from ergopose.arrays import BoolArray
from ergopose.keypoints import JOINT_INDEX

SIDES = ("left", "right")
#: The angles the settings can give, as their (unsided) names in Session.task_angles.
TASK_ANGLES = ("wrist_flexion", "wrist_deviation")
#: The posture columns a settings value can replace, in the order inputs_from_settings lists them.
SETTINGS_INPUTS = tuple(f"{side}_{a}" for a in TASK_ANGLES for side in SIDES)
#: The hand points each side's wrist angles are measured from (indices into the 33 joints).
HAND_JOINTS = {side: np.array([JOINT_INDEX[f"{side}_{j}"] for j in ("wrist", "index", "pinky")]) for side in SIDES}
#: The frames' column naming the inputs that came from the settings.
COLUMN = "inputs_from_settings"


def hidden_inputs(posture: pd.DataFrame, inferred: np.ndarray | None) -> dict[str, np.ndarray]:
    """Per SETTINGS_INPUTS column, (n,) True where the angle cannot be seen: NaN, or its side's hand
    points all placed by the body model. inferred: (n, 33) bool, or None (= nothing inferred)."""
    n = len(posture)
    out = {}
    for side in SIDES:
        hand = np.zeros(n, dtype=bool)
        if inferred is not None:
            hand = np.asarray(np.asarray(inferred, dtype=bool)[:, HAND_JOINTS[side]].all(axis=1))
        for a in TASK_ANGLES:
            col = f"{side}_{a}"
            x = posture[col].to_numpy(np.float64, na_value=np.nan) if col in posture else np.full(n, np.nan)
            out[col] = np.isnan(x) | hand
    return out


def settings_use(hidden: dict[str, np.ndarray], task: pd.DataFrame) -> dict[str, np.ndarray]:
    """Per SETTINGS_INPUTS column, (n,) True where the settings' value is used: the angle is hidden
    and ``task`` (Session.task_angles: wrist_flexion, wrist_deviation in radians, NaN = not given)
    gives a value."""
    out = {}
    for col in SETTINGS_INPUTS:
        angle = col.split("_", 1)[1]
        given = np.isfinite(task[angle].to_numpy(np.float64)) if angle in task else np.zeros(len(hidden[col]), bool)
        out[col] = hidden[col] & given
    return out


def apply_settings(table: pd.DataFrame, use: dict[str, np.ndarray], task: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``table`` (a posture table, or one uncertainty draw's angles; rows as ``task``)
    with the settings' value in each used input."""
    out = table.copy()
    for col, mask in use.items():
        if not mask.any():
            continue
        angle = col.split("_", 1)[1]
        x = out[col].to_numpy(np.float64, na_value=np.nan, copy=True) if col in out else np.full(len(out), np.nan)
        x[mask] = task[angle].to_numpy(np.float64)[mask]
        out[col] = x
    return out


def inputs_column(use: dict[str, np.ndarray], n: int) -> pd.Series:
    """The ``inputs_from_settings`` column: the used inputs of each frame joined by ";"."""
    text = np.full(n, "", dtype=object)
    for col in SETTINGS_INPUTS:
        mask = use.get(col)
        if mask is None or not mask.any():
            continue
        text = np.where(mask, np.where(text == "", col, text + ";" + col), text)
    return pd.Series(pd.array(text, dtype="string"), name=COLUMN)


def used_mask(column: pd.Series, name: str) -> BoolArray:
    """(n,) True where the ``inputs_from_settings`` column names the input ``name``."""
    names = column.astype("string").fillna("")
    mask: BoolArray = (";" + names + ";").str.contains(f";{name};", regex=False).to_numpy(dtype=bool, na_value=False)
    return mask


__all__ = [
    "SETTINGS_INPUTS",
    "TASK_ANGLES",
    "HAND_JOINTS",
    "COLUMN",
    "hidden_inputs",
    "settings_use",
    "apply_settings",
    "inputs_column",
    "used_mask",
]
