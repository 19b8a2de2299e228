"""Naming tracked people by the statures given in the settings."""

from __future__ import annotations

from pathlib import Path

from ergopose.pipeline.identify import identify_by_stature
from ergopose.session import Identification as Rules
from ergopose.session import Session, TaskFactors, WorkerInfo


def _session(statures: dict[str, float], rules: Rules = Rules(by_stature=True)) -> Session:
    workers = tuple(WorkerInfo(w, None, TaskFactors(), (), stature_m=s) for w, s in statures.items())
    return Session(
        path=Path("day1"),
        format_version=1,
        recorded_at=None,
        fps=12.0,
        frame_count=10,
        cameras=(),
        defaults=TaskFactors(),
        periods=(),
        workers=workers,
        scoring={},
        description=None,
        ground_truth_dir=None,
        settings_path=Path("day1/settings.toml"),
        calibration_path=Path("day1/calibration.toml"),
        identification=rules,
    )


def test_distinct_heights_are_matched_optimally():
    ident = identify_by_stature(
        {"worker_1": 1.66, "worker_2": 1.83, "worker_3": float("nan")}, _session({"anna": 1.64, "ben": 1.85})
    )
    assert {(m.tracked_id, m.worker_id) for m in ident.matches} == {("worker_1", "anna"), ("worker_2", "ben")}
    assert ident.rename("worker_2") == "ben" and ident.rename("worker_3") == "worker_3"
    assert not ident.notes


def test_too_similar_heights_are_not_guessed():
    ident = identify_by_stature({"worker_1": 1.75, "worker_2": 1.76}, _session({"anna": 1.755, "ben": 1.76}))
    assert not ident.matches
    assert any("another matching" in n for n in ident.notes)


def test_out_of_tolerance_is_left_unnamed():
    ident = identify_by_stature({"worker_1": 1.60}, _session({"anna": 1.80}))
    assert not ident.matches
    assert ident.notes and "no tracked person within" in ident.notes[0]


def test_a_settings_id_equal_to_an_unmatched_pseudonym_is_not_reused():
    ident = identify_by_stature({"worker_1": 1.60, "worker_2": 1.90}, _session({"worker_1": 1.90}))
    assert ident.rename("worker_2") == "worker_1"
    assert ident.rename("worker_1") == "worker_1_unmatched"


def test_tolerance_is_a_setting():
    loose = identify_by_stature(
        {"worker_1": 1.60}, _session({"anna": 1.70}, Rules(by_stature=True, stature_tolerance_m=0.12))
    )
    assert [m.worker_id for m in loose.matches] == ["anna"]


def test_matching_is_off_unless_the_settings_switch_it_on():
    ident = identify_by_stature({"worker_1": 1.64}, _session({"anna": 1.64}, Rules()))
    assert not ident.matches and "by_stature = false" in ident.notes[0]
