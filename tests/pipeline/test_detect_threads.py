"""The 2D stage runs OpenCV at the job's thread count (one per worker process) and leaves the
process's setting as it found it (ergopose/pipeline/detect.py, opencv_threads)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from ergopose.pipeline import detect


@pytest.fixture
def restore_cv_threads():
    before = cv2.getNumThreads()
    yield
    cv2.setNumThreads(before)


def test_opencv_threads_sets_and_restores(restore_cv_threads):
    cv2.setNumThreads(3)
    with detect.opencv_threads(1):
        assert cv2.getNumThreads() == 1
    assert cv2.getNumThreads() == 3


def test_opencv_threads_restores_after_an_error(restore_cv_threads):
    cv2.setNumThreads(3)
    with pytest.raises(RuntimeError):
        with detect.opencv_threads(1):
            raise RuntimeError("stage failed")
    assert cv2.getNumThreads() == 3


def test_video_2d_runs_at_the_jobs_thread_count(restore_cv_threads, monkeypatch):
    seen = []

    def fake_stage(job, start, stop, progress):
        seen.append(cv2.getNumThreads())
        return [], np.zeros((0, 0), np.int16)

    monkeypatch.setattr(detect, "_video_2d", fake_stage)
    cv2.setNumThreads(2)
    job = detect.DetectJob(cameras=(), videos=(), fps=12.0, num_threads=1)
    detect.video_2d(job, 0, 1)
    assert seen == [1]
    assert cv2.getNumThreads() == 2
