"""A drawn cartoon person with known joint positions, for tests of the 2D pose networks."""

from __future__ import annotations

import cv2
import numpy as np

#: Joint positions (pixels) of the cartoon person as drawn on a 256 x 256 image: standing,
#: facing the viewer (its left side on the image's right), hips near the centre.
MANNEQUIN_JOINTS: dict[str, tuple[float, float]] = {
    "left_shoulder": (150, 66),
    "right_shoulder": (106, 66),
    "left_elbow": (170, 102),
    "right_elbow": (86, 102),
    "left_wrist": (180, 136),
    "right_wrist": (76, 136),
    "left_hip": (141, 130),
    "right_hip": (115, 130),
    "left_knee": (145, 180),
    "right_knee": (111, 180),
    "left_ankle": (147, 226),
    "right_ankle": (109, 226),
}

SKIN = (140, 180, 230)  # BGR
SHIRT = (180, 80, 40)
PANTS = (60, 60, 60)
SHOES = (30, 30, 120)
HAIR = (30, 50, 80)


def draw_mannequin(
    image: np.ndarray, scale: float = 1.0, offset: tuple[float, float] = (0.0, 0.0)
) -> dict[str, np.ndarray]:
    """Draw the cartoon person onto ``image`` (in place), its 256-pixel layout scaled by ``scale``
    and shifted by ``offset``; return the drawn joint positions (pixels) by name."""
    off = np.asarray(offset, dtype=np.float64)
    joints = {n: np.asarray(p, dtype=np.float64) * scale + off for n, p in MANNEQUIN_JOINTS.items()}

    def pt(p):
        return tuple(int(round(v)) for v in np.asarray(p, dtype=np.float64) * scale + off)

    def t(v):
        return max(1, int(round(v * scale)))

    def j(name):
        return pt(MANNEQUIN_JOINTS[name])

    cv2.fillConvexPoly(
        image, np.array([pt((106, 116)), pt((150, 116)), pt((152, 140)), pt((104, 140))], np.int32), PANTS
    )
    cv2.fillConvexPoly(
        image,
        np.array(
            [pt((106, 58)), pt((150, 58)), j("left_shoulder"), pt((146, 120)), pt((110, 120)), j("right_shoulder")],
            np.int32,
        ),
        SHIRT,
    )
    for side, d in (("left", 1), ("right", -1)):
        cv2.line(image, j(f"{side}_hip"), j(f"{side}_knee"), PANTS, t(17))
        cv2.line(image, j(f"{side}_knee"), j(f"{side}_ankle"), PANTS, t(14))
        ax, ay = MANNEQUIN_JOINTS[f"{side}_ankle"]
        cv2.line(image, pt((ax, ay)), pt((ax + 12 * d, ay + 6)), SHOES, t(9))
        cv2.line(image, j(f"{side}_shoulder"), j(f"{side}_elbow"), SHIRT, t(14))
        cv2.circle(image, j(f"{side}_shoulder"), t(8), SHIRT, -1)
        cv2.line(image, j(f"{side}_elbow"), j(f"{side}_wrist"), SKIN, t(11))
        (ex, ey), (wx, wy) = MANNEQUIN_JOINTS[f"{side}_elbow"], MANNEQUIN_JOINTS[f"{side}_wrist"]
        cv2.circle(image, pt((wx + (wx - ex) * 0.25, wy + (wy - ey) * 0.25)), t(8), SKIN, -1)
    cv2.line(image, pt((128, 62)), pt((128, 48)), SKIN, t(12))  # neck
    cv2.ellipse(image, pt((128, 32)), (t(19), t(18)), 0, 180, 360, HAIR, -1)
    cv2.ellipse(image, pt((128, 36)), (t(17), t(18)), 0, 0, 180, SKIN, -1)
    cv2.rectangle(image, pt((111, 28)), pt((145, 36)), SKIN, -1)
    cv2.ellipse(image, pt((128, 28)), (t(17), t(8)), 0, 180, 360, HAIR, -1)
    cv2.circle(image, pt((122, 35)), t(2), (40, 40, 40), -1)  # eyes
    cv2.circle(image, pt((134, 35)), t(2), (40, 40, 40), -1)
    cv2.ellipse(image, pt((128, 45)), (t(6), t(3)), 0, 0, 180, (40, 40, 150), t(2))  # mouth
    return joints


def mannequin_image(size: int = 256, scale: float = 1.0, offset=(0.0, 0.0), background=(200, 200, 200)):
    """A (size, size, 3) uint8 BGR image with one drawn person; returns (image, joints)."""
    image = np.empty((size, size, 3), np.uint8)
    image[:] = background
    joints = draw_mannequin(image, scale, offset)
    return image, joints
