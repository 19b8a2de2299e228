"""Is a 2D detection the size of a person where its hips are? (a plausibility check before 3D)

A pose network shown part of a person -- a worker behind a shelf, only the upper body in sight --
still returns a whole skeleton, squeezed into the part it sees: hips at the edge of the shelf,
legs folded under them. Its rays are the rays of a person much smaller, or much farther away,
than anyone standing there. One camera's squeezed skeleton then places a body far along those
rays, crouched, and follows it for seconds (the simulated demo: one worker 0.9 m from where the
row said, knees bent 50-75 degrees, for 88 frames); in a pair it spoils the association.

The check compares the angle a detection's keypoints span (the largest angle between the rays of
any two of them, every keypoint the network placed) with the angle a standing person would span
whose hips lie on the detection's hip rays: hips :data:`HIPS_M` above the floor, the head's top
:data:`HEAD_TOP_M`, the soles at the floor. The ratio is about 1 for a standing person of average
height (0.80-1.07 for the person of the Pose2Sim recording, 0.67 and above for every simulated
worker, stooping and lifting included); a seated, crouching or bending person spans less (a deep
squat about half). A ratio below ``ReconSettings.min_person_scale`` (0.4) is not a person there
(docs/reconstruction.md, "Person-sized detections only", for the measurements that chose it).

The check needs the camera above the hips and the hips' ray going down; where it cannot be made
(a camera at hip height or below, a ray level or upwards) the ratio is infinite: the detection
stays. The camera's centre comes from each person's view projection, so the check needs nothing
but the record itself.
"""

from __future__ import annotations

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.view_geometry import angle_between, unit
from ergopose.records import Detections2D

#: Height above the floor (metres) of a standing person's mid-hip point and the top of their head
#: (1.70 m tall; the body model's neutral pose has its hips 0.93 m above the soles).
HIPS_M = 0.95
HEAD_TOP_M = 1.70

_HIPS = np.array([JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]])


def person_scale(det: Detections2D) -> FloatArray:
    """(N,) for each person of ``det``: the angle its keypoints span over the angle a standing
    person with hips on its hip rays would span (module docstring); inf where that cannot be
    told (no hips, camera not above the hips, hips' ray not going down), NaN never."""
    n = det.count
    out = np.full(n, np.inf)
    if n == 0:
        return out
    rays = det.world_rays()  # (N, 33, 3) unit, NaN where not found
    seen = (det.confidence > 0) & np.isfinite(rays).all(axis=-1)
    origin = det.centres_world()  # (N, 3)
    hips = unit(rays[:, _HIPS].mean(axis=1))  # (N, 3); NaN without the hips
    drop = -hips[:, 2]
    ok = seen[:, _HIPS].all(axis=1) & (drop > 1e-3) & (origin[:, 2] > HIPS_M) & (seen.sum(axis=1) >= 2)
    if not ok.any():
        return out
    hips, origin, r, s = hips[ok], origin[ok], rays[ok], seen[ok]
    hips_world = origin + hips * ((origin[:, 2] - HIPS_M) / drop[ok])[:, None]
    top = unit(hips_world + np.array([0.0, 0.0, HEAD_TOP_M - HIPS_M]) - origin)
    soles = unit(hips_world - np.array([0.0, 0.0, HIPS_M]) - origin)
    expected = angle_between(top, soles)  # (n,)
    r = np.where(s[..., None], r, 0.0)
    pair = s[:, :, None] & s[:, None, :]
    spanned = np.where(pair, angle_between(r[:, :, None], r[:, None, :]), 0.0).max(axis=(1, 2))
    out[ok] = spanned / expected
    return out


def keep_person_sized(det: Detections2D, min_scale: float) -> Detections2D:
    """``det`` without the people whose :func:`person_scale` is below ``min_scale`` (0: all kept)."""
    if min_scale <= 0 or det.count == 0:
        return det
    keep = person_scale(det) >= min_scale
    if keep.all():
        return det
    return det.subset(keep)
