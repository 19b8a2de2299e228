"""Shift aggregation per worker: distributions over time, holds, repetitions, episodes, exposure.

Input: the frames of ONE worker in time order, with the score columns of
ergopose.ergonomics.scoring (and, for the exposure standards and repetitions, the posture
table's angle columns and the ``rep_*`` action columns of ``score_posture(..., with_events=True)``).
Scores are ordinal: every result is a distribution over time (seconds and percent of the observed
time per level or band), a hold, a count or a rate -- never an average of scores.

Time: every frame stands for one frame period (``frame_period_s``; by default the median time
between the first chunk's frames), so the observed time is frames x period and a hold lasts from
its first to its last frame plus one period. Frames further apart than ``max_gap_s`` (tracking
lost) end a hold. Missing scores (<NA>) are counted as their own "missing" share.

Confidence (the frames' ``confidence`` and ``cause`` columns, ergopose.ergonomics.uncertainty):
the tracked time split into scored with confidence, scored with low confidence and unscored, each
with the time per cause -- seconds and percent of the tracked time, counted once here and shown as
such by the CSV files, the report and the terminal summary. Inputs: per body part (INPUT_GROUPS),
the median over the shift of the per-frame standard deviation of its angles (the largest of its
angles in a frame; from a histogram of 0.01 degree bins up to 90 degrees, so exact to 0.005
degree whatever the chunking) and the share of the tracked frames in which one of its joints was placed by the body
model (inferred) rather than seen by two cameras, and, for the neck, the lower arms and the legs,
the share in which a joint limit of the body model held its angles.

Task inputs (the frames' ``inputs_from_settings`` column, ergopose.ergonomics.task_inputs): per
input given by the settings in place of a hidden wrist angle, and per value used, the frames and
seconds of the scored time (a RULA or REBA grand score present) in which it was used, and their
percent of the scored time.

Chunks: :class:`ShiftAccumulator` takes the shift in pieces (``add`` each chunk, in order) and
gives exactly the answer of the whole series, because holds still open at the end of a chunk are
carried into the next one. :func:`aggregate_shift` is the one-call form.

Exposure: the zones of ISO 11226 and EN 1005-4 and their verdicts (ergopose.ergonomics.exposure),
followed over the shift as runs (ergopose.ergonomics.runs). The records of the summary:
ergopose.ergonomics.shift_records.
"""

from __future__ import annotations

import copy
import math
from types import MappingProxyType
from typing import Any, Callable

import numpy as np
import pandas as pd

from ergopose.ergonomics.activity import check_time, frame_period
from ergopose.ergonomics.exposure import exposure_finding, exposure_specs, exposure_zones, float_column
from ergopose.ergonomics.posture import expand_sides
from ergopose.ergonomics.runs import Runs, int_codes
from ergopose.ergonomics.scoring import BODY_PART_COLUMNS, REPETITION_ANGLES
from ergopose.ergonomics.settings import ScoringSettings
from ergopose.ergonomics.shift_records import (
    CauseTime,
    ConfidenceShare,
    Distribution,
    Episode,
    HourStats,
    InputCertainty,
    Repetitions,
    SettingsInputTime,
    ShiftSummary,
    ValueTime,
)
from ergopose.ergonomics.task_inputs import COLUMN as TASK_INPUTS_COLUMN
from ergopose.ergonomics.task_inputs import SETTINGS_INPUTS, used_mask
from ergopose.ergonomics.uncertainty import (
    CAUSES,
    CONFIDENCE_LEVELS,
    INPUT_GROUP_JOINTS,
    INPUT_GROUP_LIMIT_JOINTS,
    INPUT_GROUPS,
)
from ergopose.errors import InputError
from ergopose.progress import ProgressCallback, report

#: Columns whose distribution over the shift is reported, when present.
DISTRIBUTION_COLUMNS = (
    "rula_action_level",
    "left_rula_action_level",
    "right_rula_action_level",
    "rula_grand",
    "reba_risk_level",
    "reba_score",
    *BODY_PART_COLUMNS["rula"],
    *BODY_PART_COLUMNS["reba"],
)
#: Level columns whose worst episodes are reported, with the score column giving the peak.
EPISODE_COLUMNS = {"rula_action_level": "rula_grand", "reba_risk_level": "reba_score"}
#: Prefix of the per-frame action (repetition) columns: rep_<angle column> = 1 at each action.
REPETITION_PREFIX = "rep_"


#: Standard deviations of the inputs are counted in bins this wide (radians), _SD_BINS of them.
_SD_BIN_RAD = float(np.deg2rad(0.01))
_SD_BINS = 9000  # 0-90 degrees; larger deviations fall in the last bin
NOT_RECORDED = "not recorded"


def nominal_frame_period(time_s: np.ndarray) -> float:
    """1 / (frame rate rounded to 0.001 fps), the rate estimated from the median frame spacing.

    Rounding makes the estimate the same for any stretch of a recording (12 fps gives exactly
    1/12 s, 29.97 fps gives 1/29.97 s); 0 for fewer than two frames.
    """
    dt = frame_period(time_s)
    if dt <= 0:
        return 0.0
    fps = round(1.0 / dt, 3)
    return 1.0 / fps if fps > 0 else dt


# --------------------------------------------------------------------------- the accumulator


class ShiftAccumulator:
    """Aggregate one worker's frames chunk by chunk (each chunk continues the previous one).

    frame_period_s: time one frame stands for; None = :func:`nominal_frame_period` of the first chunk.
    settings: ScoringSettings (max_gap_s ends holds; thresholds for the exposure flags).
    static_hold_s: ISO 11226's static posture (held longer than 4 s).
    episodes: how many worst episodes to keep per level column.
    """

    def __init__(
        self,
        worker: str = "",
        *,
        frame_period_s: float | None = None,
        settings: ScoringSettings | None = None,
        static_hold_s: float = 4.0,
        episodes: int = 10,
        shift_start_s: float = 0.0,
    ):
        self.worker = worker
        self.s = settings or ScoringSettings()
        self.period = frame_period_s
        self.static_hold_s = static_hold_s
        self.n_episodes = episodes
        self.shift_start_s = shift_start_s
        self.frames = 0
        self.start_s = math.nan
        self.end_s = math.nan
        self.last_t: float | None = None
        self.runs: dict[str, Runs] = {}
        self.exposure_runs: dict[str, Runs] = {}
        self.hourly: dict[str, dict[tuple[int, int], int]] = {}
        self.hour_frames: dict[int, int] = {}
        self.rep_total: dict[str, int] = {}
        self.rep_minutes: dict[str, dict[int, int]] = {}
        self.columns: tuple[str, ...] | None = None
        self.exposure_present: dict[str, bool] = {}
        self.confidence_frames: dict[tuple[str, str], int] = {}  # (level, cause) -> frames
        self.input_sd_hist = np.zeros((len(INPUT_GROUPS), _SD_BINS), dtype=np.int64)
        self.input_measured = np.zeros(len(INPUT_GROUPS), dtype=np.int64)
        self.input_inferred = np.zeros(len(INPUT_GROUPS), dtype=np.int64)
        self.input_known = 0
        self.input_limited = np.zeros(len(INPUT_GROUPS), dtype=np.int64)
        self.limit_known = 0
        self.settings_frames: dict[tuple[str, float], int] = {}  # (input, value used) -> scored frames
        self.scored_frames = 0

    def add(self, frames: pd.DataFrame, inferred: np.ndarray | None = None, limited: np.ndarray | None = None) -> None:
        """Take the next chunk of frames (time order, after the previous chunk).

        inferred: (n, 33) joints placed by the body model, one row per frame (the tracks table's
        ``inferred``), for the inputs' inferred shares; limited: (n, 33) joints a joint limit held
        (the tracks table's ``limited``), for the inputs' shares held at a limit; None = not known
        for this chunk."""
        if len(frames) == 0:
            return
        for name, flags in (("inferred", inferred), ("limited", limited)):
            if flags is not None and np.shape(flags)[0] != len(frames):
                raise ValueError(f"{name} has {np.shape(flags)[0]} rows for {len(frames)} frames")
        frames = expand_sides(frames)
        if "time_s" not in frames.columns:
            raise InputError("the frames need a time_s column to be aggregated", field="time_s")
        t = check_time(frames["time_s"].to_numpy(dtype=np.float64, na_value=np.nan))
        if self.last_t is not None and t[0] <= self.last_t:
            raise InputError(
                f"this chunk starts at {t[0]:g} s, not after the previous chunk's end ({self.last_t:g} s)",
                field="time_s",
            )
        if self.period is None:
            self.period = nominal_frame_period(t)
        cols = tuple(c for c in DISTRIBUTION_COLUMNS if c in frames.columns)
        if self.columns is None:
            self.columns = cols
            for c in cols:
                top = self.n_episodes if c in EPISODE_COLUMNS else 0
                self.runs[c] = Runs(self.period, self.s.max_gap_s, top=top)
        elif cols != self.columns:
            raise InputError("every chunk must carry the same score columns")
        self.frames += t.size
        if math.isnan(self.start_s):
            self.start_s = float(t[0])
        self.end_s = float(t[-1] + self.period)
        self.last_t = float(t[-1])

        hours = np.floor((t - self.shift_start_s) / 3600.0).astype(np.int64)
        uh, hc = np.unique(hours, return_counts=True)
        for h, k in zip(uh.tolist(), hc.tolist()):
            self.hour_frames[h] = self.hour_frames.get(h, 0) + k
        for c in self.columns:
            x = frames[c].to_numpy(dtype=np.float64, na_value=np.nan)
            codes = int_codes(x)
            peak = None
            if c in EPISODE_COLUMNS and EPISODE_COLUMNS[c] in frames.columns:
                peak = frames[EPISODE_COLUMNS[c]].to_numpy(dtype=np.float64, na_value=np.nan)
            self.runs[c].add(t, codes, peak)
            if c in EPISODE_COLUMNS:
                key = hours * 64 + (codes + 1)
                uk, kc = np.unique(key, return_counts=True)
                table = self.hourly.setdefault(c, {})
                for k, cnt in zip(uk.tolist(), kc.tolist()):
                    hk = (k // 64, k % 64 - 1)
                    table[hk] = table.get(hk, 0) + cnt

        zones = exposure_zones(frames, self.s)
        for key, z in zones.items():
            present = z is not None
            if key in self.exposure_present and self.exposure_present[key] != present:
                raise InputError(f"every chunk must carry the same angle columns ({key.split('|')[1]})")
            self.exposure_present[key] = present
            if z is None:
                continue
            if key not in self.exposure_runs:
                self.exposure_runs[key] = Runs(self.period, self.s.max_gap_s, static_s=self.static_hold_s)
            self.exposure_runs[key].add(t, int_codes(z))

        self._add_certainty(frames, inferred, limited)
        self._add_task_inputs(frames)

        minutes = np.floor((t - self.shift_start_s) / 60.0).astype(np.int64)
        for angle in REPETITION_ANGLES:
            col = REPETITION_PREFIX + angle
            if col not in frames.columns:
                continue
            ev = frames[col].to_numpy(dtype=np.float64, na_value=0.0) > 0
            self.rep_total[angle] = self.rep_total.get(angle, 0) + int(ev.sum())
            per_min = self.rep_minutes.setdefault(angle, {})
            um, mc = np.unique(minutes[ev], return_counts=True)
            for m, k in zip(um.tolist(), mc.tolist()):
                per_min[m] = per_min.get(m, 0) + k

    def _add_certainty(self, frames: pd.DataFrame, inferred: np.ndarray | None, limited: np.ndarray | None) -> None:
        """Count the chunk's frames per confidence level and cause, and its inputs' deviations."""
        if "confidence" in frames.columns:
            level = frames["confidence"].astype("string").fillna("unscored").to_numpy(dtype=object)
            cause = (
                frames["cause"].astype("string").fillna("").to_numpy(dtype=object)
                if "cause" in frames.columns
                else np.full(len(frames), "", dtype=object)
            )
            cause = np.where(level == "confident", "", np.where(cause == "", NOT_RECORDED, cause))
            keys, counts = np.unique(np.stack([level.astype(str), cause.astype(str)]), axis=1, return_counts=True)
            for (lv, ca), k in zip(keys.T.tolist(), counts.tolist()):
                self.confidence_frames[(lv, ca)] = self.confidence_frames.get((lv, ca), 0) + int(k)
        for g, (_, angles, _) in enumerate(INPUT_GROUPS):
            measured = np.zeros(len(frames), dtype=bool)
            for a in angles:
                x = float_column(frames, a)
                if x is not None:
                    measured |= np.isfinite(x)
            self.input_measured[g] += int(measured.sum())
            sds = [x for x in (float_column(frames, f"{a}_sd") for a in angles) if x is not None]
            if sds:
                sd = np.fmax.reduce(np.stack(sds), axis=0)
                sd = sd[measured & np.isfinite(sd)]
                idx = np.clip((sd / _SD_BIN_RAD).astype(np.int64), 0, _SD_BINS - 1)
                self.input_sd_hist[g] += np.bincount(idx, minlength=_SD_BINS)
            if inferred is not None:
                self.input_inferred[g] += int(np.asarray(inferred)[:, INPUT_GROUP_JOINTS[g]].any(axis=1).sum())
            if limited is not None and len(INPUT_GROUP_LIMIT_JOINTS[g]):
                self.input_limited[g] += int(np.asarray(limited)[:, INPUT_GROUP_LIMIT_JOINTS[g]].any(axis=1).sum())
        if inferred is not None:
            self.input_known += len(frames)
        if limited is not None:
            self.limit_known += len(frames)

    def _add_task_inputs(self, frames: pd.DataFrame) -> None:
        """Count the scored frames, and per task input and value those that used the settings."""
        grand = [x for x in (float_column(frames, "rula_grand"), float_column(frames, "reba_score")) if x is not None]
        if not grand:
            return
        scored = np.fmax.reduce(np.stack(grand), axis=0)
        scored = np.isfinite(scored)
        self.scored_frames += int(scored.sum())
        if TASK_INPUTS_COLUMN not in frames.columns:
            return
        column = frames[TASK_INPUTS_COLUMN]
        for name in SETTINGS_INPUTS:
            x = float_column(frames, name)
            if x is None:
                continue
            sel = used_mask(column, name) & scored
            if not sel.any():
                continue
            values, counts = np.unique(x[sel], return_counts=True)
            for v, k in zip(values.tolist(), counts.tolist()):
                key = (name, float(v))
                self.settings_frames[key] = self.settings_frames.get(key, 0) + int(k)

    def _settings_result(self, period: float) -> tuple[SettingsInputTime, ...]:
        order = {name: i for i, name in enumerate(SETTINGS_INPUTS)}
        out = []
        for (name, value), k in sorted(self.settings_frames.items(), key=lambda kv: (order[kv[0][0]], kv[0][1])):
            out.append(
                SettingsInputTime(
                    name, value, k, k * period, 100.0 * k / self.scored_frames if self.scored_frames else math.nan
                )
            )
        return tuple(out)

    def _confidence_result(self, period: float, pct: Callable[[float], float]) -> tuple[ConfidenceShare, ...]:
        if not self.confidence_frames:
            return ()
        out = []
        for lv in CONFIDENCE_LEVELS:
            n = sum(k for (level, _), k in self.confidence_frames.items() if level == lv)
            causes = tuple(
                CauseTime(ca, k, k * period, pct(k * period))
                for ca in (*CAUSES, NOT_RECORDED)
                if (k := self.confidence_frames.get((lv, ca), 0)) > 0 and lv != "confident"
            )
            out.append(ConfidenceShare(lv, n, n * period, pct(n * period), causes))
        return tuple(out)

    def _inputs_result(self) -> tuple[InputCertainty, ...]:
        out = []
        for g, (part, angles, _) in enumerate(INPUT_GROUPS):
            hist = self.input_sd_hist[g]
            total = int(hist.sum())
            if total:
                k = int(np.searchsorted(np.cumsum(hist), (total + 1) // 2))  # the lower median's bin
                median = (k + 0.5) * _SD_BIN_RAD
            else:
                median = math.nan
            known = self.input_known
            out.append(
                InputCertainty(
                    part,
                    angles,
                    int(self.input_measured[g]),
                    median,
                    int(self.input_inferred[g]),
                    known,
                    float(100.0 * self.input_inferred[g] / known) if known else math.nan,
                    int(self.input_limited[g]),
                    (
                        float(100.0 * self.input_limited[g] / self.limit_known)
                        if self.limit_known and len(INPUT_GROUP_LIMIT_JOINTS[g])
                        else math.nan
                    ),
                )
            )
        return tuple(out)

    # ------------------------------------------------------------------------------ result

    def result(self) -> ShiftSummary:
        """The summary so far (the accumulator can keep taking chunks afterwards)."""
        runs = {c: copy.deepcopy(r) for c, r in self.runs.items()}
        exposure_runs = {k: copy.deepcopy(r) for k, r in self.exposure_runs.items()}
        for r in (*runs.values(), *exposure_runs.values()):
            r.finish()
        period = self.period or 0.0
        observed = self.frames * period

        def pct(x: float) -> float:
            return 100.0 * x / observed if observed > 0 else 0.0

        distributions = {}
        for c, r in runs.items():
            values = []
            for v in sorted(k for k in r.frames if k >= 0):
                d, neg_start = r.longest[v]
                values.append(
                    ValueTime(
                        v, r.frames[v], r.frames[v] * period, pct(r.frames[v] * period), r.holds[v], d, -neg_start
                    )
                )
            miss = r.frames.get(-1, 0)
            distributions[c] = Distribution(
                c, self.frames, observed, miss, miss * period, pct(miss * period), tuple(values)
            )

        hourly = []
        for c, table in self.hourly.items():
            for h in sorted(self.hour_frames):
                by = {v: k * period for (hh, v), k in table.items() if hh == h and v >= 0}
                hourly.append(
                    HourStats(
                        c,
                        h,
                        self.hour_frames[h] * period,
                        table.get((h, -1), 0) * period,
                        MappingProxyType(dict(sorted(by.items()))),
                    )
                )

        episodes = {}
        for c, r in runs.items():
            if c in EPISODE_COLUMNS:
                episodes[c] = tuple(Episode(c, -lv, start, end, -neg_d, peak) for lv, neg_d, start, end, peak in r.best)

        minutes = observed / 60.0
        reps = []
        for angle in REPETITION_ANGLES:
            if angle not in self.rep_total:
                continue
            per_min = self.rep_minutes.get(angle, {})
            reps.append(
                Repetitions(
                    angle,
                    self.rep_total[angle],
                    self.rep_total[angle] / minutes if minutes else 0.0,
                    max(per_min.values(), default=0),
                    sum(1 for k in per_min.values() if k >= 4),
                )
            )

        exposure = [
            exposure_finding(spec, exposure_runs.get(f"{spec.standard}|{spec.body_part}"), period, minutes)
            for spec in exposure_specs()
        ]

        return ShiftSummary(
            worker=self.worker,
            frames=self.frames,
            frame_period_s=period,
            observed_s=observed,
            start_s=self.start_s,
            end_s=self.end_s,
            distributions=MappingProxyType(distributions),
            hourly=tuple(hourly),
            episodes=MappingProxyType(episodes),
            repetitions=tuple(reps),
            exposure=tuple(exposure),
            confidence=self._confidence_result(period, pct),
            inputs=self._inputs_result(),
            from_settings=self._settings_result(period),
            scored_frames=self.scored_frames,
        )


def aggregate_shift(
    frames: pd.DataFrame,
    worker: str = "",
    *,
    chunk_frames: int | None = None,
    progress: ProgressCallback | None = None,
    inferred: np.ndarray | None = None,
    limited: np.ndarray | None = None,
    **options: Any,
) -> ShiftSummary:
    """Aggregate one worker's scored frames (in time order); inferred: (n, 33) joints placed by the
    body model, limited: (n, 33) joints a joint limit held (see :meth:`ShiftAccumulator.add`);
    options as :class:`ShiftAccumulator`."""
    acc = ShiftAccumulator(worker, **options)
    n = len(frames)
    step = n if not chunk_frames else max(1, int(chunk_frames))
    for i in range(0, n, step or 1):
        acc.add(
            frames.iloc[i : i + step],
            None if inferred is None else np.asarray(inferred)[i : i + step],
            None if limited is None else np.asarray(limited)[i : i + step],
        )
        report(progress, "aggregate", min(i + step, n), n, unit="frame")
    return acc.result()


def aggregate_session(
    frames: pd.DataFrame, *, by: str = "worker", progress: ProgressCallback | None = None, **options: Any
) -> dict[str, ShiftSummary]:
    """One ShiftSummary per worker (rows grouped by the ``by`` column, each in time order)."""
    if by not in frames.columns:
        return {"": aggregate_shift(frames, "", **options)}
    out = {}
    groups = list(frames.groupby(by, sort=True, dropna=False))
    for k, (name, g) in enumerate(groups):
        out[str(name)] = aggregate_shift(g, str(name), **options)
        report(progress, "aggregate", k + 1, len(groups), unit="worker")
    return out


__all__ = [
    "NOT_RECORDED",
    "ShiftAccumulator",
    "aggregate_shift",
    "aggregate_session",
    "nominal_frame_period",
    "DISTRIBUTION_COLUMNS",
    "EPISODE_COLUMNS",
    "REPETITION_PREFIX",
]
