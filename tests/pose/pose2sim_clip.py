"""The first frames of one Pose2Sim camera through the 2D stage as `ergopose pose` runs it, and
the recording's 3D result projected into that camera (for tests on real frames)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ergopose.evaluation.pose_csv import frames_from_csv, trc_reference
from ergopose.evaluation.refisheye import score_frame
from ergopose.geometry.calibration_file import camera_for_video, read_any_calibration
from ergopose.geometry.camera import Camera
from ergopose.pipeline.pose_video import pose_video
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
from ergopose.pose.settings import PoseSettings
from ergopose.video import VideoInfo, probe_video


@dataclass
class Pose2SimClip:
    """Frames 0 .. frames-1 of camera cam_0N of the recording in ``shared_data``."""

    shared_data: Path
    model_dir: Path
    number: int
    frames: int

    def __post_init__(self) -> None:
        root = self.shared_data / "pose2sim-demo"
        self.video = root / "videos" / f"cam0{self.number}.mp4"
        self.info: VideoInfo = probe_video(self.video)
        cameras, _ = read_any_calibration(root / "Calib_qualisys.toml")
        named = next(c for c in cameras if c.name == f"cam_0{self.number}")
        self.camera: Camera = camera_for_video(named, self.info.width, self.info.height)
        self.landmarker = BlazePoseLandmarker(model_dir=self.model_dir)
        self.detector = BlazePoseDetector(model_dir=self.model_dir)
        self.reference = trc_reference(root, self.frames, self.camera)

    def scores(self, settings: PoseSettings) -> list[dict[str, Any]]:
        """Per frame, the stage's people scored against the projected 3D result (found,
        swapped, ...: ``refisheye.score_frame``), and the number of people reported."""
        settings = settings.with_gates(self.landmarker.card.gates)
        result = pose_video(
            self.video, self.camera, self.info.fps, 0, self.frames, self.landmarker, self.detector, settings
        )
        people = frames_from_csv(result.table, self.camera, self.frames)
        out = []
        for f in range(self.frames):
            score = score_frame(self.reference["rays"][f], self.reference["conf"][f], people[f])
            score["people"] = people[f].count
            out.append(score)
        return out
