"""Which tracked people are most likely one worker when more are tracked than the area holds
(ergopose.pipeline.headcount): known answers on frame sets written by hand."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ergopose.pipeline.headcount import MAX_TOGETHER, excess_message, likely_same, report_notice


def test_the_pair_followed_together_least_is_one_worker():
    frames = {
        "worker_1": np.arange(0, 100),  # all the time
        "worker_2": np.arange(0, 40),  # one worker, lost at frame 40 ...
        "worker_3": np.arange(100),  # another, all the time
        "worker_4": np.arange(35, 100),  # ... found again at 35 under a new id: 5 frames together
    }
    pairs = likely_same(frames, expected=3)
    assert len(pairs) == 1
    p = pairs[0]
    assert (p.first, p.second, p.together, p.shorter) == ("worker_2", "worker_4", 5, 40)
    assert p.together_pct == 12.5


def test_one_at_a_time_until_the_area_holds_as_many_and_never_two_people_seen_together():
    frames = {
        "worker_1": np.arange(0, 30),
        "worker_2": np.arange(30, 60),
        "worker_3": np.arange(60, 100),
        "worker_4": np.arange(0, 100),
    }
    pairs = likely_same(frames, expected=2)
    # worker_1 + worker_2 first (no frame together, tracker order), then worker_3 joins them.
    assert [(p.first, p.second, p.together) for p in pairs] == [
        ("worker_1", "worker_2", 0),
        ("worker_1", "worker_3", 0),
    ]
    # The area holds one: the last two were followed together throughout, so they are two people.
    assert len(likely_same(frames, expected=1)) == 2
    assert likely_same(frames, expected=0) == ()  # unknown: nothing is suggested
    assert likely_same(frames, expected=4) == ()


def test_ties_go_to_the_closer_statures_and_a_large_overlap_is_never_suggested():
    frames = {"worker_1": np.arange(0, 50), "worker_2": np.arange(50, 100), "worker_3": np.arange(50, 100)}
    statures = {"worker_1": 1.80, "worker_2": 1.60, "worker_3": 1.79}
    pairs = likely_same(frames, expected=2, statures=statures)
    assert [(p.first, p.second) for p in pairs] == [("worker_1", "worker_3")]
    # worker_2 (40 frames) and worker_3 overlap in half of worker_2's frames at most to be one worker.
    limit = int(MAX_TOGETHER * 40)
    frames = {"worker_1": np.arange(0, 100), "worker_2": np.arange(0, 40), "worker_3": np.arange(40 - limit, 100)}
    assert [p.together for p in likely_same(frames, expected=2)] == [limit]
    frames["worker_3"] = np.arange(40 - limit - 1, 100)  # one frame more together than that
    assert likely_same(frames, expected=2) == ()


def test_the_warning_names_the_command_or_says_there_is_no_pair():
    frames = {"worker_1": np.arange(0, 50), "worker_2": np.arange(60, 100)}
    pairs = likely_same(frames, expected=1)
    text = excess_message(Path("day1"), "settings.toml", 1, list(frames), pairs)
    assert text.startswith("settings.toml: [reconstruction] expected_workers = 1, but 2 people were tracked")
    assert "worker_2 with worker_1 (followed at the same time in 0 of the 40 frames" in text
    assert "'ergopose workers --session day1 --name worker_1=NAME --name worker_2=NAME'" in text
    text = excess_message(Path("day1"), "settings.toml", 1, ["worker_1", "worker_2"], ())
    assert "no two of them were followed apart often enough" in text


def test_the_reports_notice():
    frames = {"worker_1": np.arange(0, 50), "worker_2": np.arange(0, 100), "worker_3": np.arange(40, 100)}
    pairs = likely_same(frames, expected=2)
    text = report_notice(2, list(frames), pairs)
    assert text.startswith("the settings say the area holds 2 workers, but 3 people are reported here")
    assert "worker_1 and worker_3 (followed at the same time in 20 % of the shorter one's frames)" in text
    assert report_notice(1, ["worker_1", "worker_2"], ()).endswith("or a visitor.")
