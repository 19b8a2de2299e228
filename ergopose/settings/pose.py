"""The [pose] table: the knobs of the fisheye 2D stage a user may want to turn
(docs/pose-in-fisheye.md explains the stage).

ergopose.pose.settings.PoseSettings is the record the stage uses, with angles in radians: a key
ending in ``_deg`` here is the field without that ending there, converted (degrees at the edge,
radians inside); a key ending in ``_m`` is the field without it (metres both sides). The
stage's other fields are measured choices, not settings.
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, field_validator, model_validator

from ergopose.settings.base import Table


def _as_tuple(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value


class PoseTable(Table):
    """The user-settable part of the 2D stage's settings, with the stage's defaults."""

    search_every: int = Field(
        12,
        gt=0,
        description="frames one pass over the search views takes while someone is followed (spread over those frames)",
    )
    idle_search_every: int = Field(
        4, gt=0, description="frames one pass over the search views takes while nobody is followed"
    )
    search_views_per_frame: float = Field(
        0.5,
        gt=0,
        description="most detector runs per frame on search views, on "
        "average, while someone is followed (a pass takes longer)",
    )
    idle_search_views_per_frame: float = Field(4.5, gt=0, description="the same while nobody is followed")
    search_layout: Literal["lens", "fixed"] = Field(
        "lens",
        description="lens: search views placed and sized from the lens, image circle and detector "
        "(docs/pose-in-fisheye.md); fixed: the search_rings_deg layout",
    )
    search_person_px: float = Field(
        60.0,
        gt=0,
        description="smallest person to find, as their length in detector "
        "pixels at search_max_distance_m (lens layout)",
    )
    search_person_height_m: float = Field(1.7, gt=0, description="height of that person (lens layout)")
    search_max_distance_m: float = Field(
        6.0, gt=0, description="farthest working distance, horizontally from the camera (lens layout)"
    )
    search_where_lost: bool = Field(True, description="search again where a followed person was lost")
    coast_frames: int = Field(2, ge=0, description="frames a person not found is still looked for in the same view")
    max_people: int = Field(8, gt=0, description="most people followed per camera (more are counted and reported)")
    other_camera_every: int = Field(
        2,
        ge=0,
        description="look where another camera sees a person this camera does not, every this many frames (0: never)",
    )
    min_presence: float = Field(0.5, ge=0, le=1, description="a view whose pose flag is below this holds no person")
    min_keypoint_confidence: float = Field(
        0.3, ge=0, le=1, description="keypoints below this do not steer the next view"
    )
    min_detector_score: float = Field(0.5, ge=0, le=1, description="detector score to accept a search cue")
    body_margin: float = Field(
        1.3, gt=0, description="a person view's half field of view is the body's angular radius times this"
    )
    min_half_fov_deg: float = Field(8.0, gt=0, lt=90, description="smallest half field of view of a person view")
    max_half_fov_deg: float = Field(55.0, gt=0, lt=90, description="largest half field of view of a person view")
    search_half_fov_deg: float = Field(
        42.0, gt=0, lt=90, description="half field of view of the search views (fixed layout)"
    )
    search_rings_deg: Annotated[tuple[float, ...], BeforeValidator(_as_tuple)] = Field(
        (0.0, 45.0, 75.0),
        description="angles off the lens axis of the rings of search views, fixed layout (the first at 0 is one view)",
        json_schema_extra={"allowed": "increasing angles from 0 to 90 (degrees)"},
    )
    search_views_per_ring: int = Field(8, gt=0, description="search views on each ring after the first (fixed layout)")
    align_views: bool = Field(
        True, description="roll each person view towards the body axis (false: every view upright)"
    )
    max_body_roll_deg: float = Field(
        45.0, ge=0, le=180, description="the body axis rolls a view at most this far from upright"
    )
    left_right_check: bool = Field(True, description="keep each person's left and right consistent from frame to frame")

    @model_validator(mode="after")
    def _fov(self) -> "PoseTable":
        if not self.min_half_fov_deg < self.max_half_fov_deg:
            raise ValueError(
                f"min_half_fov_deg ({self.min_half_fov_deg:g}) must be below max_half_fov_deg "
                f"({self.max_half_fov_deg:g})"
            )
        return self

    @field_validator("search_rings_deg")
    @classmethod
    def _rings(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        if not v or not all(0 <= a <= 90 for a in v) or any(b <= a for a, b in zip(v, v[1:])):
            raise ValueError(f"expected increasing angles from 0 to 90 degrees, got {list(v)!r}")
        return v

    def record_values(self) -> dict[str, Any]:
        """The given keys as PoseSettings fields (radians inside)."""
        out: dict[str, Any] = {}
        for key, value in self.given().items():
            if key.endswith("_deg"):
                key = key.removesuffix("_deg")
                value = tuple(math.radians(a) for a in value) if isinstance(value, tuple) else math.radians(value)
            elif key.endswith("_m"):
                key = key.removesuffix("_m")
            out[key] = value
        return out
