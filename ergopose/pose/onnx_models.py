"""User-brought top-down 2D pose models in ONNX format (e.g. RTMPose or SimpleBaseline exports).

A model comes with a small TOML card beside it that says how to feed it and how to read it::

    name = "rtmpose-m"
    file = "rtmpose-m.onnx"          # relative to the card
    sha256 = "..."                   # optional; checked when the model is loaded
    licence = "Apache-2.0"
    source = "where it came from"

    [input]
    width = 192
    height = 256
    channel_order = "RGB"            # or "BGR"
    mean = [123.675, 116.28, 103.53] # 8-bit units, in the model's channel order
    std = [58.395, 57.12, 57.375]

    [output]
    type = "simcc"                   # or "heatmap"
    split_ratio = 2.0                # simcc only: bins per input pixel
    confidence = "raw"               # "raw" (clipped to [0, 1]) or "sigmoid"
    keypoints = "coco17"             # "coco17", "halpe26", or a list of names ("" = not used)

The network takes one NCHW float32 input. Decoding:

* heatmap: one output (N, K, Hh, Wh). Per keypoint the arg-max cell, refined by one Newton step
  on the logarithm of the heatmap (a quadratic fit of log values in the 3 x 3 neighbourhood,
  exact for a Gaussian peak); cell (col, row) is input pixel (col, row) * (W / Wh, H / Hh), the
  convention of the MMPose heatmap codecs. Confidence: the peak value.
* simcc: two outputs (N, K, W * split_ratio) and (N, K, H * split_ratio), x first (or named with
  x / y). Per keypoint the arg-max bin of each, divided by split_ratio. Confidence: the smaller
  of the two peak values.

Keypoints map onto ergopose's schema (ergopose.keypoints.BLAZEPOSE33) by name; schema joints
the model does not report are NaN with confidence 0.
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import ConfigError, InputError, ModelError
from ergopose.keypoints import COCO17, JOINT_INDEX, NUM_JOINTS
from ergopose.pose.blazepose import DEFAULT_THREADS, Keypoints2D, sigmoid
from ergopose.pose.models import Normalisation, sha256_file

#: Halpe's 26 keypoints; the big toes become BlazePose's foot_index points, the heels its heels;
#: head, neck, hip centre and small toes have no schema joint ("").
HALPE26_TO_SCHEMA: tuple[str, ...] = COCO17 + (
    "",
    "",
    "",
    "left_foot_index",
    "right_foot_index",
    "",
    "",
    "left_heel",
    "right_heel",
)
KEYPOINT_PRESETS: dict[str, tuple[str, ...]] = {"coco17": COCO17, "halpe26": HALPE26_TO_SCHEMA}
OUTPUT_TYPES = ("heatmap", "simcc")
CONFIDENCE_MODES = ("raw", "sigmoid")


@dataclass(frozen=True)
class OnnxPoseCard:
    """The card of a user-brought ONNX pose model (see the module docstring for the TOML form).

    keypoint_names: the model's keypoints in output order, as schema names ("" = not used).
    schema_index: for each model keypoint, its index in BLAZEPOSE33 or -1.
    input_size: (width, height) pixels.
    """

    name: str
    file: Path
    input_size: tuple[int, int]
    channel_order: str
    normalisation: Normalisation
    output_type: str
    keypoint_names: tuple[str, ...]
    split_ratio: float = 2.0
    confidence: str = "raw"
    sha256: str | None = None
    licence: str = "unknown"
    source: str = "unknown"
    card_path: Path | None = None

    @property
    def schema_index(self) -> tuple[int, ...]:
        return tuple(JOINT_INDEX[n] if n else -1 for n in self.keypoint_names)

    def __post_init__(self) -> None:
        where = self.card_path
        if self.channel_order not in ("RGB", "BGR"):
            raise ConfigError(
                f"expected 'RGB' or 'BGR', got {self.channel_order!r}", path=where, field="input.channel_order"
            )
        if self.output_type not in OUTPUT_TYPES:
            raise ConfigError(
                f"expected one of {OUTPUT_TYPES}, got {self.output_type!r}", path=where, field="output.type"
            )
        if self.confidence not in CONFIDENCE_MODES:
            raise ConfigError(
                f"expected one of {CONFIDENCE_MODES}, got {self.confidence!r}", path=where, field="output.confidence"
            )
        if not (self.split_ratio > 0):
            raise ConfigError(f"must be positive, got {self.split_ratio}", path=where, field="output.split_ratio")
        w, h = self.input_size
        if w <= 0 or h <= 0:
            raise ConfigError(f"input size must be positive, got {w} x {h}", path=where, field="input")
        if any(s <= 0 for s in self.normalisation.std):
            raise ConfigError("std values must be positive", path=where, field="input.std")
        unknown = [n for n in self.keypoint_names if n and n not in JOINT_INDEX]
        if unknown:
            raise ConfigError(
                f"unknown keypoint names {unknown}; use names from ergopose.keypoints.BLAZEPOSE33 "
                "(e.g. 'left_shoulder') or \"\" for a keypoint without a schema joint",
                path=where,
                field="output.keypoints",
            )
        used = [n for n in self.keypoint_names if n]
        if len(set(used)) != len(used):
            raise ConfigError("a schema joint is named twice", path=where, field="output.keypoints")
        if not used:
            raise ConfigError("no keypoint maps onto the schema", path=where, field="output.keypoints")


def _field(table: dict[str, Any], key: str, kind: type, path: Path, prefix: str, default: Any = ...) -> Any:
    if key not in table:
        if default is ...:
            raise ConfigError("missing", path=path, field=f"{prefix}{key}")
        return default
    value = table[key]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or isinstance(value, bool):
        raise ConfigError(f"expected {kind.__name__}, got {value!r}", path=path, field=f"{prefix}{key}")
    return value


def _triple(table: dict[str, Any], key: str, path: Path) -> tuple[float, float, float]:
    value = table.get(key)
    if (
        not isinstance(value, list)
        or len(value) != 3
        or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    ):
        raise ConfigError(f"expected a list of 3 numbers, got {value!r}", path=path, field=f"input.{key}")
    return float(value[0]), float(value[1]), float(value[2])


def load_onnx_card(path: str | os.PathLike[str]) -> OnnxPoseCard:
    """Read a TOML model card; the model file path is taken relative to the card."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError("model card not found", path=path) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the model card: {exc}", path=path) from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"not valid TOML: {exc}", path=path) from None
    inp = data.get("input")
    out = data.get("output")
    if not isinstance(inp, dict):
        raise ConfigError("missing [input] table", path=path, field="input")
    if not isinstance(out, dict):
        raise ConfigError("missing [output] table", path=path, field="output")
    kps = out.get("keypoints")
    if isinstance(kps, str):
        if kps.lower() not in KEYPOINT_PRESETS:
            raise ConfigError(
                f"unknown keypoint preset {kps!r}; use one of {sorted(KEYPOINT_PRESETS)} or a list of names",
                path=path,
                field="output.keypoints",
            )
        names = KEYPOINT_PRESETS[kps.lower()]
    elif isinstance(kps, list) and all(isinstance(n, str) for n in kps):
        names = tuple(kps)
    else:
        raise ConfigError("expected a preset name or a list of keypoint names", path=path, field="output.keypoints")
    sha = data.get("sha256")
    if sha is not None and (not isinstance(sha, str) or len(sha) != 64):
        raise ConfigError("expected 64 hex digits", path=path, field="sha256")
    file = _field(data, "file", str, path, "")
    return OnnxPoseCard(
        name=_field(data, "name", str, path, "", default=path.stem),
        file=(path.parent / file).resolve(),
        input_size=(_field(inp, "width", int, path, "input."), _field(inp, "height", int, path, "input.")),
        channel_order=_field(inp, "channel_order", str, path, "input.", default="RGB").upper(),
        normalisation=Normalisation(_triple(inp, "mean", path), _triple(inp, "std", path)),
        output_type=_field(out, "type", str, path, "output.").lower(),
        keypoint_names=names,
        split_ratio=_field(out, "split_ratio", float, path, "output.", default=2.0),
        confidence=_field(out, "confidence", str, path, "output.", default="raw").lower(),
        sha256=None if sha is None else sha.lower(),
        licence=_field(data, "licence", str, path, "", default="unknown"),
        source=_field(data, "source", str, path, "", default="unknown"),
        card_path=path,
    )


# --------------------------------------------------------------------------------------------
# Decoding


def decode_heatmaps(
    heatmaps: np.ndarray, input_size: tuple[int, int], refine: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """Keypoints from heatmaps (N, K, Hh, Wh): returns (N, K, 2) input pixels and (N, K) peak values.

    Arg-max cell, then (``refine``) one Newton step on log(heatmap) using central differences
    in the 3 x 3 neighbourhood (gradient and Hessian including the cross term), applied when the
    Hessian is negative definite and the peak is not on the border; the step is limited to one
    cell. Cell (col, row) is input pixel (col * W / Wh, row * H / Hh).
    """
    hm = np.asarray(heatmaps, dtype=np.float64)
    if hm.ndim != 4:
        raise ValueError(f"expected heatmaps of shape (N, K, H, W), got {hm.shape}")
    n, k, hh, ww = hm.shape
    flat = hm.reshape(n, k, -1)
    idx = flat.argmax(axis=2)
    peak = np.take_along_axis(flat, idx[..., None], axis=2)[..., 0]
    row, col = np.divmod(idx, ww)
    xy = np.stack([col, row], axis=-1).astype(np.float64)
    if refine and hh >= 3 and ww >= 3:
        r = np.clip(row, 1, hh - 2)
        c = np.clip(col, 1, ww - 2)
        ni, ki = np.meshgrid(np.arange(n), np.arange(k), indexing="ij")
        logs = np.log(np.maximum(hm, 1e-10))

        def at(dr: int, dc: int) -> FloatArray:
            values: FloatArray = logs[ni, ki, r + dr, c + dc]
            return values

        gx = (at(0, 1) - at(0, -1)) / 2.0
        gy = (at(1, 0) - at(-1, 0)) / 2.0
        hxx = at(0, 1) - 2.0 * at(0, 0) + at(0, -1)
        hyy = at(1, 0) - 2.0 * at(0, 0) + at(-1, 0)
        hxy = (at(1, 1) - at(1, -1) - at(-1, 1) + at(-1, -1)) / 4.0
        det = hxx * hyy - hxy * hxy
        ok = (row == r) & (col == c) & (hxx < 0) & (det > 0)
        safe = np.where(ok, det, 1.0)
        dx = -(hyy * gx - hxy * gy) / safe
        dy = -(hxx * gy - hxy * gx) / safe
        step = np.stack([dx, dy], axis=-1)
        xy += np.where(ok[..., None], np.clip(step, -1.0, 1.0), 0.0)
    w, h = input_size
    return xy * np.array([w / ww, h / hh]), peak


def decode_simcc(simcc_x: np.ndarray, simcc_y: np.ndarray, split_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Keypoints from SimCC distributions (N, K, Bx) and (N, K, By).

    Returns (N, K, 2) input pixels (arg-max bin / split_ratio) and (N, K) confidences (the
    smaller of the two peak values).
    """
    sx = np.asarray(simcc_x, dtype=np.float64)
    sy = np.asarray(simcc_y, dtype=np.float64)
    if sx.ndim != 3 or sy.ndim != 3 or sx.shape[:2] != sy.shape[:2]:
        raise ValueError(f"expected SimCC outputs (N, K, Bx) and (N, K, By), got {sx.shape} and {sy.shape}")
    ix = sx.argmax(axis=2)
    iy = sy.argmax(axis=2)
    px = np.take_along_axis(sx, ix[..., None], axis=2)[..., 0]
    py = np.take_along_axis(sy, iy[..., None], axis=2)[..., 0]
    xy = np.stack([ix, iy], axis=-1).astype(np.float64) / split_ratio
    return xy, np.minimum(px, py)


def to_schema(xy: np.ndarray, scores: np.ndarray, schema_index: Sequence[int], confidence: str) -> list[Keypoints2D]:
    """Model keypoints (N, K, 2), (N, K) -> one Keypoints2D per image in the BLAZEPOSE33 schema."""
    index = np.asarray(schema_index, dtype=np.int64)
    used = index >= 0
    conf = sigmoid(scores) if confidence == "sigmoid" else np.clip(scores, 0.0, 1.0)
    out = []
    for i in range(xy.shape[0]):
        pixels = np.full((NUM_JOINTS, 2), np.nan)
        c = np.zeros(NUM_JOINTS)
        pixels[index[used]] = xy[i, used]
        c[index[used]] = conf[i, used]
        out.append(Keypoints2D(pixels=pixels, confidence=c, presence=float(conf[i, used].mean())))
    return out


# --------------------------------------------------------------------------------------------
# Runner


class OnnxPoseModel:
    """Runs a user-brought top-down ONNX pose model on BGR crops of the card's input size."""

    def __init__(self, card: OnnxPoseCard | str | os.PathLike[str], *, num_threads: int = DEFAULT_THREADS):
        # Deferred on purpose: onnxruntime is heavy and only needed for a user-brought ONNX model.
        import onnxruntime as ort

        self.card = card if isinstance(card, OnnxPoseCard) else load_onnx_card(card)
        path = self.card.file
        if not path.is_file():
            raise ModelError("ONNX model file not found (named by the card's 'file')", path=path)
        if self.card.sha256 is not None:
            digest = sha256_file(path)
            if digest != self.card.sha256:
                raise ModelError(
                    f"SHA-256 {digest[:12]}... differs from the card's {self.card.sha256[:12]}...; "
                    "the file is corrupt or not the model the card describes",
                    path=path,
                )
        options = ort.SessionOptions()
        options.intra_op_num_threads = int(num_threads)
        options.inter_op_num_threads = 1
        options.log_severity_level = 3
        try:
            self.session = ort.InferenceSession(str(path), sess_options=options, providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own exception types
            raise ModelError(f"not a loadable ONNX model ({str(exc).strip().splitlines()[0]})", path=path) from None
        self._check_io()

    def _check_io(self) -> None:
        card, path = self.card, self.card.file
        inputs = self.session.get_inputs()
        if len(inputs) != 1 or len(inputs[0].shape) != 4:
            raise ModelError(f"expected one NCHW image input, found {[(i.name, i.shape) for i in inputs]}", path=path)
        self._input = inputs[0].name
        shape = inputs[0].shape
        w, h = card.input_size
        for axis, want in ((1, 3), (2, h), (3, w)):
            if isinstance(shape[axis], int) and shape[axis] != want:
                raise ModelError(f"input shape {shape} does not match the card's 3 x {h} x {w}", path=path)
        self.dynamic_batch = not isinstance(shape[0], int)
        outputs = self.session.get_outputs()
        k = len(card.keypoint_names)
        if card.output_type == "heatmap":
            if len(outputs) < 1 or len(outputs[0].shape) != 4:
                raise ModelError(
                    f"expected a heatmap output (N, K, H, W), found {[(o.name, o.shape) for o in outputs]}", path=path
                )
            self._outputs = [outputs[0].name]
            kk = outputs[0].shape[1]
        else:
            three = [o for o in outputs if len(o.shape) == 3]
            if len(three) < 2:
                raise ModelError(
                    f"expected two SimCC outputs (N, K, bins), found {[(o.name, o.shape) for o in outputs]}", path=path
                )
            pair = three[:2]
            named_x = [o for o in three if "x" in o.name.lower() and "y" not in o.name.lower()]
            named_y = [o for o in three if "y" in o.name.lower() and "x" not in o.name.lower()]
            if len(named_x) == 1 and len(named_y) == 1:
                pair = [named_x[0], named_y[0]]
            self._outputs = [o.name for o in pair]
            kk = pair[0].shape[1]
        if isinstance(kk, int) and kk != k:
            raise ModelError(f"the model outputs {kk} keypoints, the card names {k}", path=path)

    def preprocess(self, images_bgr: np.ndarray) -> np.ndarray:
        """(N, H, W, 3) uint8 BGR -> (N, 3, H, W) float32 in the card's channel order and normalisation."""
        x = images_bgr[..., ::-1] if self.card.channel_order == "RGB" else images_bgr
        mean = np.asarray(self.card.normalisation.mean, dtype=np.float32)
        std = np.asarray(self.card.normalisation.std, dtype=np.float32)
        x = (x.astype(np.float32) - mean) / std
        return np.ascontiguousarray(x.transpose(0, 3, 1, 2), dtype=np.float32)

    def _check(self, image: np.ndarray) -> None:
        w, h = self.card.input_size
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.shape != (h, w, 3):
            got = (
                f"{image.dtype} array of shape {image.shape}" if isinstance(image, np.ndarray) else type(image).__name__
            )
            raise InputError(
                f"expected a uint8 BGR image of shape ({h}, {w}, 3), got {got}", field=f"{self.card.name} input"
            )

    def run_batch(self, images_bgr: Sequence[np.ndarray]) -> list[Keypoints2D]:
        """Keypoints for several crops; one session call when the model's batch axis is dynamic."""
        for image in images_bgr:
            self._check(image)
        if len(images_bgr) == 0:
            return []
        batch = np.stack(images_bgr)
        if self.dynamic_batch:
            outs = self.session.run(self._outputs, {self._input: self.preprocess(batch)})
        else:
            parts = [self.session.run(self._outputs, {self._input: self.preprocess(b[None])}) for b in batch]
            outs = [np.concatenate([p[j] for p in parts]) for j in range(len(self._outputs))]
        if self.card.output_type == "heatmap":
            xy, scores = decode_heatmaps(outs[0], self.card.input_size)
        else:
            xy, scores = decode_simcc(outs[0], outs[1], self.card.split_ratio)
        return to_schema(xy, scores, self.card.schema_index, self.card.confidence)

    def __call__(self, image_bgr: np.ndarray) -> Keypoints2D:
        return self.run_batch([image_bgr])[0]
