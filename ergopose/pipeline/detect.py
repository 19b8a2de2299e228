"""The per-chunk stages of an assessment: find people, 2D, body model (video frames -> 2D poses ->
people in 3D).

One chunk is a run of consecutive frames of every camera of the session. Its work depends only on the chunk
(every chunk starts its 2D stage afresh with a search for people), so chunks can run in any
order and in any process, and an interrupted assessment recomputes only the chunks it had not
finished, with the same result as an uninterrupted run.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
from dataclasses import dataclass
from typing import Iterator, Mapping, Protocol, Sequence

import cv2
import numpy as np

from ergopose.errors import InputError
from ergopose.geometry.camera import Camera
from ergopose.pose.appearance import appearance_fisheye
from ergopose.pose.blazepose import BlazePoseDetector, BlazePoseLandmarker
from ergopose.pose.fisheye import FisheyePoseEstimator
from ergopose.pose.handoff import pass_cues
from ergopose.pose.records import FrameDetections
from ergopose.pose.settings import PoseSettings
from ergopose.progress import ProgressCallback, report
from ergopose.recon.records import People3D
from ergopose.recon.settings import ReconSettings
from ergopose.recon.triangulate import reconstruct_frames
from ergopose.records import Detections2D
from ergopose.video import SKIP_CODES, read_frames_checked


@dataclass(frozen=True)
class DetectJob:
    """Everything a worker process needs to process chunks (picklable).

    cameras, videos: the session's cameras and their video files, in the session's order.
    fps: frame rate; time of frame i is i / fps.
    model_dir: the pose model cache (None: the default cache).
    model: the landmark model ("lite", "full", "heavy"; None: the default); ``pose`` should carry
        its card's confidence gates (PoseSettings.with_gates).
    num_threads: LiteRT threads per network in one worker process, and OpenCV's threads while
        the 2D stage runs (:func:`opencv_threads`).
    max_bad_share: the share of a chunk's frames of one video that may be skipped (undecodable or
        of the wrong size); more is an error naming the video and the time.
    """

    cameras: tuple[Camera, ...]
    videos: tuple[str, ...]
    fps: float
    model_dir: str | None = None
    model: str | None = None
    num_threads: int = 1
    max_bad_share: float = 0.2
    pose: PoseSettings = PoseSettings()
    recon: ReconSettings = ReconSettings()


@dataclass(frozen=True)
class ChunkResult:
    """The result of one chunk: frames start .. stop-1.

    people: the People3D rows of the chunk (association + triangulation, before tracking).
    detections: (stop - start, C) int16, people found by the 2D stage per frame and camera; a
        negative value marks a frame that was skipped (ergopose.video.SKIP_CODES: -1 could not be
        decoded, -2 had the wrong size).
    """

    start: int
    stop: int
    people: People3D
    detections: np.ndarray


_NETWORKS: dict[tuple[str | None, str | None, int], tuple[BlazePoseLandmarker, BlazePoseDetector]] = {}


def networks(
    model_dir: str | None, num_threads: int, model: str | None = None
) -> tuple[BlazePoseLandmarker, BlazePoseDetector]:
    """The pose networks of this process (landmarker of ``model``, detector), loaded once and
    reused for every chunk (a Dask worker loads them when it starts: ergopose.pipeline.cluster)."""
    key = (model_dir, model, num_threads)
    if key not in _NETWORKS:
        _NETWORKS[key] = (
            BlazePoseLandmarker(model=model, model_dir=model_dir, num_threads=num_threads),
            BlazePoseDetector(model_dir=model_dir, num_threads=num_threads),
        )
    return _NETWORKS[key]


def _networks(job: DetectJob) -> tuple[BlazePoseLandmarker, BlazePoseDetector]:
    return networks(job.model_dir, job.num_threads, job.model)


@contextlib.contextmanager
def opencv_threads(n: int) -> Iterator[None]:
    """OpenCV's worker threads set to ``n`` for the block, restored after.

    The 2D stage runs one process per core, each network single-threaded; OpenCV's default (a
    thread per core in every process) made each process's small remaps, resizes and the
    background model hand work to threads competing with the other process: measured on a
    simulated chunk (120 frames, 2 cameras), 9 % more CPU time than one thread, with identical
    output (docs/assess.md, "Speed").
    """
    before = cv2.getNumThreads()
    cv2.setNumThreads(max(1, int(n)))
    try:
        yield
    finally:
        cv2.setNumThreads(before)


class Source2D(Protocol):
    """Where the stages *find people* and *2D* get their records from: the pose networks on the
    session's videos (:func:`video_2d`, the product's), or a source an evaluation brings (the
    simulator's ORACLE keypoints, ergopose.evaluation.oracle), injected into the same driver."""

    def frames_2d(self, start: int, stop: int) -> tuple[list[Sequence[Detections2D]], np.ndarray]:
        """Frames start .. stop-1: per frame, one Detections2D per camera (the session's order),
        and the people found per frame and camera ((stop - start, C) int16; negative: a frame
        that was skipped, ergopose.video.SKIP_CODES)."""
        ...


def video_2d(
    job: DetectJob, start: int, stop: int, progress: ProgressCallback | None = None
) -> tuple[list[Sequence[Detections2D]], np.ndarray]:
    """Stages *find people* and *2D* on the videos: the pose networks in every camera for frames
    start .. stop-1 (:class:`ergopose.pose.fisheye.FisheyePoseEstimator`); the records of
    :meth:`Source2D.frames_2d`.

    A frame of one camera that cannot be read is skipped (no people from that camera in that
    frame) and marked in the counts; more than ``job.max_bad_share`` of the chunk's frames of
    one video skipped is an InputError naming the video and the time.
    """
    with opencv_threads(job.num_threads):
        return _video_2d(job, start, stop, progress)


def _video_2d(
    job: DetectJob, start: int, stop: int, progress: ProgressCallback | None
) -> tuple[list[Sequence[Detections2D]], np.ndarray]:
    landmarker, detector = _networks(job)
    stages = [
        FisheyePoseEstimator(cam, i, landmarker, detector, job.pose, progress=progress)
        for i, cam in enumerate(job.cameras)
    ]
    readers = [read_frames_checked(path, start, stop) for path in job.videos]
    frames_2d: list[Sequence[Detections2D]] = []
    counts = np.zeros((stop - start, len(job.cameras)), np.int16)
    limit = job.max_bad_share * (stop - start)
    for k, frames in enumerate(zip(*readers)):
        index = frames[0][0]
        time_s = index / job.fps
        per_camera = []
        found_now = []
        for c, ((_, image, problem), stage, cam) in enumerate(zip(frames, stages, job.cameras)):
            if image is None:
                counts[k, c] = SKIP_CODES[problem]
                if np.count_nonzero(counts[:, c] < 0) > limit:
                    raise _too_many_bad(job, c, start, stop, counts[: k + 1, c])
                nobody = FrameDetections.empty(c, index)
                per_camera.append(nobody.to_recon(cam, time_s))
                found_now.append(nobody)
                continue
            found = stage.process(image, index)
            counts[k, c] = found.count
            found_now.append(found)
            look = appearance_fisheye(image, found.pixels_fisheye, found.confidence)
            per_camera.append(found.to_recon(cam, time_s, look))
        if job.pose.other_camera_every > 0:
            pass_cues(stages, found_now, job.cameras, job.pose.min_keypoint_confidence)
        frames_2d.append(per_camera)
        report(progress, "pose", k + 1, stop - start, unit="frame")
    return frames_2d, counts


def body_model(
    start: int, stop: int, frames_2d: Sequence[Sequence[Detections2D]], counts: np.ndarray, recon: ReconSettings
) -> ChunkResult:
    """Stage *body model* (3D): the 2D records of frames start .. stop-1 associated across the
    cameras and triangulated into people in 3D (:func:`ergopose.recon.triangulate.reconstruct_frames`)."""
    return ChunkResult(start, stop, reconstruct_frames(frames_2d, recon), counts)


def detect_chunk(
    job: DetectJob, start: int, stop: int, progress: ProgressCallback | None = None, source: Source2D | None = None
) -> ChunkResult:
    """One chunk through *find people*, *2D* (the videos, :func:`video_2d`, or ``source``) and
    *body model* (:func:`body_model`): frames start .. stop-1 as people in 3D."""
    frames_2d, counts = video_2d(job, start, stop, progress) if source is None else source.frames_2d(start, stop)
    return body_model(start, stop, frames_2d, counts, job.recon)


def _too_many_bad(job: DetectJob, camera: int, start: int, stop: int, codes: np.ndarray) -> InputError:
    bad = np.flatnonzero(codes < 0) + start
    return InputError(
        f"{bad.size} of the {stop - start} frames between {_clock(start / job.fps)} and "
        f"{_clock(stop / job.fps)} of the video cannot be read (first bad frame {bad[0]}, at "
        f"{_clock(bad[0] / job.fps)}); more than the {100 * job.max_bad_share:g} % allowed "
        "(--max-bad-frames): the video is damaged there",
        path=job.videos[camera],
    )


def _clock(seconds: float) -> str:
    """h:mm:ss.s of video time."""
    h, rem = divmod(float(seconds), 3600.0)
    m, s = divmod(rem, 60.0)
    return f"{int(h)}:{int(m):02d}:{s:04.1f}"


def chunk_ranges(n_frames: int, chunk_frames: int) -> list[tuple[int, int]]:
    """[(start, stop), ...] covering frames 0 .. n_frames-1 in chunks of chunk_frames."""
    if chunk_frames <= 0:
        raise ValueError("chunk_frames must be positive")
    return [(s, min(n_frames, s + chunk_frames)) for s in range(0, n_frames, chunk_frames)]


def default_workers() -> int:
    """Worker processes: one per core (each network runs single-threaded inside its process)."""
    return max(1, os.cpu_count() or 1)


#: The per-row array fields of People3D (everything but the camera names), in declaration order.
_FIELDS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(People3D) if f.name != "cameras")


def people_to_arrays(people: People3D) -> dict[str, np.ndarray]:
    """People3D as named arrays (for storing a chunk with numpy.savez)."""
    out = {f: getattr(people, f) for f in _FIELDS}
    out["cameras"] = np.array(people.cameras)
    return out


def people_from_arrays(arrays: Mapping[str, np.ndarray]) -> People3D:
    missing = [f for f in _FIELDS if f not in arrays]
    if missing:
        raise KeyError(f"stored chunk lacks {', '.join(missing)}")
    return People3D(tuple(str(c) for c in arrays["cameras"]), *(np.asarray(arrays[f]) for f in _FIELDS))
