"""The task factors of settings.toml: [defaults], [[periods]] and [workers.<id>] (with their own
[[workers.<id>.periods]]): what the cameras cannot see (docs/session-format.md)."""

from __future__ import annotations

import datetime as dt
import math
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field, PlainValidator, model_validator

from ergopose.settings.base import Table

LOAD_MODES = ("intermittent", "static", "repeated")
COUPLINGS = ("good", "fair", "poor", "unacceptable")
#: The accepted range of an angle factor, degrees (inclusive).
ANGLE_FACTOR_RANGE_DEG = (-90.0, 90.0)
#: Plausible adult statures (metres) for a worker's given stature.
STATURE_RANGE_M = (1.2, 2.3)

TIME_ALLOWED = "seconds from the start (a number), a clock time (10:15:00) or a date-time (2024-03-04T10:15:00+01:00)"


def _nonempty(value: str) -> str:
    if not value.strip():
        raise ValueError(f"expected a non-empty text, got {value!r}")
    return value


#: A text that is not empty (nor only spaces).
Text = Annotated[str, AfterValidator(_nonempty)]


def _time_value(value: Any) -> float | dt.time | dt.datetime:
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
        return float(value)
    if isinstance(value, (dt.datetime, dt.time)):
        return value
    raise ValueError(f"expected {TIME_ALLOWED}, got {value!r}")


#: A moment of the recording: seconds from the first frame, a clock time or a date-time.
TimeValue = Annotated[float | dt.time | dt.datetime, PlainValidator(_time_value)]


def _angle(description: str) -> Any:
    lo, hi = ANGLE_FACTOR_RANGE_DEG
    return Field(None, ge=lo, le=hi, description=description, examples=[-20.0])


class TaskFactorsTable(Table):
    """Task factors; a key not given is unknown (the scoring says so), the most specific value wins."""

    load_kg: float | None = Field(None, ge=0, description="load or force handled", examples=[0.0])
    load_mode: Literal["intermittent", "static", "repeated"] | None = Field(
        None,
        description="how the load is handled (RULA force/load): intermittent, static (held) or repeated",
        examples=["intermittent"],
    )
    coupling: Literal["good", "fair", "poor", "unacceptable"] | None = Field(
        None, description="the hand hold (REBA coupling)", examples=["good"]
    )
    shock: bool | None = Field(None, description="shock or rapid build-up of force (REBA)", examples=[False])
    arm_supported: bool | None = Field(
        None, description="upper arm supported or person leaning (RULA)", examples=[False]
    )
    seated: bool | None = Field(None, description="the worker sits (RULA and REBA legs)", examples=[False])
    legs_supported: bool | None = Field(
        None, description="legs and feet supported and balanced (RULA)", examples=[True]
    )
    wrist_twist_end_range: bool | None = Field(
        None, description="wrist twisted near the end of its range (RULA)", examples=[False]
    )
    wrist_flexion_deg: float | None = _angle(
        "the task's wrist posture where the hand is not seen: + flexion (toward the palm), - extension"
    )
    wrist_deviation_deg: float | None = _angle(
        "the task's wrist deviation where the hand is not seen: + radial (toward the thumb), - ulnar"
    )


#: The task factors' keys in settings.toml.
FACTOR_KEYS = tuple(TaskFactorsTable.model_fields)


class PeriodTable(TaskFactorsTable):
    """A time window [start, end) with task factors."""

    start: TimeValue = Field(
        description="where the window starts (inside it)", examples=[0.0], json_schema_extra={"allowed": TIME_ALLOWED}
    )
    end: TimeValue = Field(
        description="where the window ends (outside it)", examples=[600.0], json_schema_extra={"allowed": TIME_ALLOWED}
    )

    @model_validator(mode="after")
    def _some_factor(self) -> "PeriodTable":
        if not set(FACTOR_KEYS) & self.model_fields_set:
            raise ValueError("gives no task factor (load_kg, load_mode, coupling, shock, ...)")
        return self


class WorkerTable(TaskFactorsTable):
    """One worker: name, stature, own task factors and own periods."""

    name: Text | None = Field(
        None, description="name or pseudonym shown in the reports instead of the id", examples=["Worker A"]
    )
    stature_m: float | None = Field(
        None,
        ge=STATURE_RANGE_M[0],
        le=STATURE_RANGE_M[1],
        description="body height, to recognise the worker by stature ([identification])",
        examples=[1.75],
    )
    periods: list[PeriodTable] = Field(default_factory=list, description="time windows for this worker only")
