"""Synthetic scenes shared by the reconstruction tests (built once per test session, seeded)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from ergopose.sim.synthetic import WorkerScript, observe, rig, walk_workers

FPS = 12.0


@dataclass
class Scenario:
    cameras: tuple
    truth: np.ndarray  # (F, P, 33, 3)
    frames: list  # per frame (Detections2D cam_1, Detections2D cam_2)
    order: list  # per frame, per camera: ground-truth person of each detection
    visible: np.ndarray  # (F, C, P)
    statures: tuple


@pytest.fixture(scope="session")
def cameras():
    return rig()


def crossing_scripts() -> list[WorkerScript]:
    """Four people whose paths cross near the middle, two of them walking in opposite
    directions on lines parallel to the camera baseline (the epipolar "ghost" case)."""
    return [
        WorkerScript(1.62, np.array([[-2.6, 0.3], [2.6, 0.3]]), pause_s=1.0, speed_m_s=1.3, work_phase=0.0),
        WorkerScript(1.74, np.array([[2.6, -0.3], [-2.6, -0.3]]), pause_s=1.0, speed_m_s=1.2, work_phase=1.0),
        WorkerScript(1.83, np.array([[0.4, -2.6], [-0.4, 2.6]]), pause_s=1.5, speed_m_s=1.1, work_phase=2.0),
        WorkerScript(1.93, np.array([[-1.8, 2.4], [1.6, -2.4]]), pause_s=0.5, speed_m_s=1.3, work_phase=3.0),
    ]


@pytest.fixture(scope="session")
def crossing(cameras) -> Scenario:
    scripts = crossing_scripts()
    n = int(6.0 * FPS)
    truth = walk_workers(scripts, n, FPS)
    frames, order = observe(cameras, truth, noise_px=2.0, dropout=0.02, seed=11, fps=FPS)
    vis = np.ones((n, 2, len(scripts)), bool)
    return Scenario(cameras, truth, frames, order, vis, tuple(s.stature for s in scripts))


def shift_scripts() -> list[WorkerScript]:
    return [
        WorkerScript(
            1.62,
            np.array([[-2.2, -1.5], [-1.0, 1.6], [-2.4, 1.9], [-1.4, -2.2], [0.5, 0.2], [-2.0, 0.0]]),
            pause_s=6.0,
            speed_m_s=1.1,
            work_phase=0.0,
        ),
        WorkerScript(
            1.72,
            np.array([[2.3, 1.5], [0.8, -1.8], [2.4, -2.3], [1.2, 2.2], [-0.5, -0.4], [2.0, 0.5]]),
            pause_s=5.0,
            speed_m_s=1.2,
            work_phase=1.1,
        ),
        WorkerScript(
            1.82,
            np.array([[0.2, 2.4], [0.0, -2.4], [1.8, 0.2], [-1.9, 0.6], [0.3, 2.3], [0.2, -1.0]]),
            pause_s=4.0,
            speed_m_s=1.0,
            work_phase=2.3,
        ),
        WorkerScript(
            1.92,
            np.array([[-0.5, -2.5], [-2.3, 2.4], [2.4, 2.4], [-0.3, -0.6], [2.3, -2.0], [-2.3, -2.0]]),
            pause_s=3.0,
            speed_m_s=1.3,
            work_phase=3.7,
        ),
    ]


@pytest.fixture(scope="session")
def shift(cameras) -> Scenario:
    """80 s of four workers: one hidden from camera 1 for 5 s (single view), one hidden from
    both cameras for 1 s (coasting), one leaving the area for 25 s and one hidden for 5 s
    while the other is away (both re-linked by their body measurements)."""
    scripts = shift_scripts()
    n = int(80 * FPS)
    truth = walk_workers(scripts, n, FPS)
    vis = np.ones((n, 2, len(scripts)), bool)
    s = lambda a, b: slice(int(a * FPS), int(b * FPS))  # noqa: E731
    vis[s(10, 15), 0, 0] = False  # worker 0 behind a shelf for camera 1
    vis[s(20, 21), :, 1] = False  # worker 1 hidden from both for 1 s
    vis[s(30, 55), :, 2] = False  # worker 2 leaves the area for 25 s
    vis[s(40, 45), :, 3] = False  # worker 3 hidden from both for 5 s
    frames, order = observe(cameras, truth, noise_px=2.0, dropout=0.02, visible=vis, seed=7, fps=FPS)
    return Scenario(cameras, truth, frames, order, vis, tuple(s.stature for s in scripts))
