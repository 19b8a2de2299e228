"""ergopose assess --cluster (ergopose.pipeline.cluster) on Dask LocalClusters of this machine: the
same CSV bytes as a local run, a worker killed mid-run, and many sessions of which one fails."""

from __future__ import annotations

import logging
import os
import shutil
import signal

import pytest

from ergopose import cli
from ergopose.errors import ConfigError
from ergopose.pipeline.assess import AssessOptions
from tests.pipeline.helpers import assess_args, csv_bytes, user_lines

distributed = pytest.importorskip("distributed")
from ergopose.pipeline import cluster  # noqa: E402  (needs Dask)

# End to end (simulated sessions, whole runs): left out by make test-fast.
pytestmark = pytest.mark.slow


def test_addresses():
    assert cluster.parse_address("local:3") == ("local", 3)
    assert cluster.parse_address("tcp://10.0.0.5:8786") == ("remote", "tcp://10.0.0.5:8786")
    for bad in ("local:0", "local:x", "nowhere"):
        with pytest.raises(ConfigError, match="--cluster"):
            cluster.parse_address(bad)


def test_local_cluster_writes_the_csv_bytes_of_a_local_run(
    reference, tiny_session, fetched_model_dir, tmp_path, capsys
):
    _, expected = reference
    out = tmp_path / "report"
    capsys.readouterr()
    assert cli.main(assess_args(tiny_session, out, fetched_model_dir[0], "--cluster", "local:2")) == 0
    err = capsys.readouterr().err
    assert csv_bytes(out) == expected
    assert any("dashboard" in ln and "2 workers" in ln for ln in err.splitlines()), err
    assert not [p for p in out.rglob("*") if ".tmp" in p.name]


def test_a_worker_killed_mid_run_the_run_completes_with_the_same_csv_bytes(
    reference, tiny_session, fetched_model_dir, tmp_path
):
    """SIGKILL one of two workers as soon as the first chunk is stored: Dask reschedules its work
    (the nanny starts a new worker, which loads the networks again) and the results are unchanged."""
    _, expected = reference
    out = tmp_path / "report"
    killed = []
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=logging.CRITICAL
    ) as lc:
        pids = [n.pid for n in lc.workers.values()]

        def kill_one(event):
            if event.stage == "pose" and event.done > 0 and not killed:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])

        options = AssessOptions(out_dir=out, chunk_seconds=0.5, model_dir=str(fetched_model_dir[0]))
        (outcome,) = cluster.assess_sessions([tiny_session], lc.scheduler_address, options, progress=kill_one)
        assert killed, "no chunk finished before the end"
        restarted = [n.pid for n in lc.workers.values()]
    assert outcome.error is None, outcome.error
    assert pids[0] not in restarted
    assert outcome.result.chunks_total == 6
    assert csv_bytes(out) == expected


def test_one_damaged_session_of_three_fails_alone(reference, tiny_session, fetched_model_dir, tmp_path, capsys):
    """Three sessions in one submission, the middle one with a damaged stretch of video (more bad
    frames than --max-bad-frames allows): the other two are assessed (the CSV bytes of a local run),
    the damaged one gets one clear error naming the video, and the exit code says one failed."""
    from tests.test_video import damage_middle

    _, expected = reference
    sessions = [tmp_path / name for name in ("day_a", "day_b", "day_c")]
    for s in sessions:
        shutil.copytree(tiny_session, s)
    damage_middle(tiny_session / "cam_2.mp4", sessions[1] / "cam_2.mp4", length=3000)
    out = tmp_path / "reports"
    capsys.readouterr()
    code = cli.main(
        [
            "assess",
            "--sessions",
            *map(str, sessions),
            "--out",
            str(out),
            "--cluster",
            "local:2",
            "--model-dir",
            str(fetched_model_dir[0]),
            "--chunk-seconds",
            "0.5",
            "--max-bad-frames",
            "0.1",
        ]
    )
    captured = capsys.readouterr()
    assert code == 1
    assert csv_bytes(out / "day_a") == expected
    assert csv_bytes(out / "day_c") == expected
    assert not (out / "day_b" / "index.html").exists()
    errors = [ln for ln in user_lines(captured.err) if ln.startswith("ergopose: error:")]
    assert len(errors) == 1, captured.err
    assert "day_b" in errors[0] and "cam_2.mp4" in errors[0] and "cannot be read" in errors[0]
    assert "Traceback" not in captured.err
    assert "2 of 3 sessions assessed; 1 failed" in captured.out
    # progress per session: each session's own pose bar
    for name in ("day_a", "day_b", "day_c"):
        assert f"{name} pose" in captured.err


def test_videos_given_as_urls_are_copied_to_the_workers_and_removed(
    reference, tiny_session, fetched_model_dir, tmp_path, monkeypatch
):
    """The session's settings name its videos by file:// URL (in a folder of their own): the client
    and the worker each read a copy from the cache folder (here one on this machine), the CSV bytes
    are those of a local run of the folder, and no copy is left once the session is done."""
    from tests.test_remote import with_url_videos

    _, expected = reference
    cache = tmp_path / "cache"
    monkeypatch.setenv("ERGOPOSE_VIDEO_CACHE", str(cache))  # the LocalCluster's workers inherit it
    session = with_url_videos(tiny_session, tmp_path / "by_url" / "day1", tmp_path / "store")
    out = tmp_path / "report"
    options = AssessOptions(out_dir=out, chunk_seconds=0.5, model_dir=str(fetched_model_dir[0]))
    (outcome,) = cluster.assess_sessions([session], "local:1", options)
    assert outcome.error is None, outcome.error
    assert csv_bytes(out) == expected
    assert cache.is_dir() and not [p for p in cache.rglob("*") if p.is_file()]
