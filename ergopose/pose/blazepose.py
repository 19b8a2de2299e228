"""BlazePose with LiteRT: the person detector and the 33-landmark network, image in, keypoints out.

Both runners take an 8-bit BGR image (OpenCV order) of exactly the network's input size; the
caller builds that view (an upright virtual view aimed at a person, or a crop made with
:meth:`Roi.crop`). Pixel coordinates follow OpenCV: x right, y down, the centre of the top-left
pixel at (0, 0). The networks themselves count from the image corner; the runners convert.

Decoding (model cards in :mod:`ergopose.pose.models`, measurements in docs/models.md):

* detector: 2254 SSD anchors (strides 8, 16 and three merged layers of stride 32; 2 anchors per
  cell per layer; centres at cell + 0.5; fixed size), offsets / 224 added to the anchor
  centres, sigmoid scores above ``min_score``, weighted non-maximum suppression. Each person
  comes with the hip centre and a point on the circle around the whole body, which give the
  crop for the landmark network (:meth:`PersonDetection.roi`).
* landmarks: 39 x (x, y, z, visibility, presence); the first 33 are the ergopose schema
  (ergopose.keypoints.BLAZEPOSE33). Visibility and presence are logits; the pose flag is
  already a probability. x, y are refined with the 64 x 64 heatmap as MediaPipe does.

A runner holds one LiteRT interpreter and is not thread-safe: use one runner per thread.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import cv2
import numpy as np

from ergopose.arrays import FloatArray
from ergopose.errors import InputError, ModelError
from ergopose.keypoints import NUM_JOINTS
from ergopose.pose.models import BLAZEPOSE_DETECTOR, ModelCard, ensure_model, landmark_card, model_card
from ergopose.progress import ProgressCallback

DEFAULT_THREADS = 2


def sigmoid(x: np.ndarray) -> FloatArray:
    """The logistic function of network logits (float64, clipped to +-100 against overflow)."""
    x = np.clip(np.asarray(x, dtype=np.float64), -100.0, 100.0)
    probability: FloatArray = 1.0 / (1.0 + np.exp(-x))
    return probability


# --------------------------------------------------------------------------------------------
# Records


@dataclass(frozen=True)
class Keypoints2D:
    """2D pose of one person in one image.

    pixels: (33, 2) float64, x right / y down in the given image's pixels (OpenCV convention:
        the top-left pixel's centre is (0, 0)); joints in ergopose.keypoints.BLAZEPOSE33 order.
        NaN where the network does not report that joint (models with fewer keypoints).
    confidence: (33,) in [0, 1]; for BlazePose the landmark's visibility (sigmoid), i.e. the
        likelihood that it is in the image and not occluded. 0 where pixels is NaN.
    presence: probability that a person is in the image at all (BlazePose's pose flag; for
        top-down ONNX models the mean confidence of the reported joints).
    depth: (33,) relative depth in the same pixel scale (smaller = nearer the camera, 0 near the
        hips), or None when the model gives none.
    landmark_presence: (33,) likelihood that each landmark lies inside the image, or None.
    world_m: (33, 3) metres, origin between the hips, axes of the input image (x right, y down,
        z away from the camera), as regressed by the network; None unless asked for.
    alignment: (2, 2) pixels of the network's two alignment points, or None when the model
        gives none: the hip centre and a point on the circle around the whole body along the
        body axis (the same two points as :class:`PersonDetection`'s first two keypoints;
        BlazePose's landmarks 33 and 34, which MediaPipe uses to place the next frame's crop).
    """

    pixels: np.ndarray
    confidence: np.ndarray
    presence: float
    depth: np.ndarray | None = None
    landmark_presence: np.ndarray | None = None
    world_m: np.ndarray | None = None
    alignment: np.ndarray | None = None

    def transformed(self, matrix: np.ndarray) -> "Keypoints2D":
        """The same keypoints with pixels mapped by a 2x3 affine matrix (e.g. crop -> image).

        depth is scaled by the matrix's mean scale so it keeps the pixel scale.
        """
        m = np.asarray(matrix, dtype=np.float64).reshape(2, 3)
        pixels = self.pixels @ m[:, :2].T + m[:, 2]
        scale = float(np.sqrt(abs(np.linalg.det(m[:, :2]))))
        depth = None if self.depth is None else self.depth * scale
        alignment = None if self.alignment is None else self.alignment @ m[:, :2].T + m[:, 2]
        return Keypoints2D(
            pixels, self.confidence, self.presence, depth, self.landmark_presence, self.world_m, alignment
        )


@dataclass(frozen=True)
class Roi:
    """A square, rotated region of an image.

    centre: (2,) pixels; side: length of the square's side in pixels; rotation: radians, the
    angle from the image's "up" to the region's "up", positive clockwise on screen (towards +x).
    """

    centre: np.ndarray
    side: float
    rotation: float

    def image_to_crop(self, size: int) -> np.ndarray:
        """2x3 affine matrix mapping image pixels to pixels of a ``size`` x ``size`` crop."""
        c, s = np.cos(self.rotation), np.sin(self.rotation)
        rot_t = np.array([[c, s], [-s, c]])  # transpose of the crop -> image rotation
        a = rot_t * (size / self.side)
        b = (size - 1) / 2.0 - a @ np.asarray(self.centre, dtype=np.float64)
        return np.hstack([a, b[:, None]])

    def crop_to_image(self, size: int) -> np.ndarray:
        """2x3 affine matrix mapping crop pixels back to image pixels."""
        return cv2.invertAffineTransform(self.image_to_crop(size))

    def crop(self, image: np.ndarray, size: int) -> np.ndarray:
        """The region resampled (bilinear) to ``size`` x ``size``, black outside the image."""
        return cv2.warpAffine(
            image,
            self.image_to_crop(size),
            (size, size),
            flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=0,
        )


@dataclass(frozen=True)
class PersonDetection:
    """One person found by the BlazePose detector, in the detector image's pixels.

    score: detection confidence in [0, 1].
    keypoints: (4, 2) pixels: hip centre, full-body extent point, shoulder centre, upper-body
        extent point. The distance from the hip centre to the full-body point is the radius
        of a circle around the whole body; its direction is the body's axis.
    ssd_box: (4,) x0, y0, x1, y1 pixels of the box the network regresses (near the head, of
        almost constant size in this model; used for non-maximum suppression only).
    """

    score: float
    keypoints: np.ndarray
    ssd_box: np.ndarray

    @property
    def hip_centre(self) -> FloatArray:
        hip: FloatArray = self.keypoints[0]
        return hip

    @property
    def radius(self) -> float:
        """Radius in pixels of the circle around the whole body, centred on the hips."""
        return float(np.linalg.norm(self.keypoints[1] - self.keypoints[0]))

    @property
    def rotation(self) -> float:
        """Body axis angle from the image's up, radians, positive clockwise on screen."""
        v = self.keypoints[1] - self.keypoints[0]
        return float(np.arctan2(v[0], -v[1]))

    @property
    def box(self) -> np.ndarray:
        """(4,) x0, y0, x1, y1: the square around the body circle."""
        c, r = self.hip_centre, self.radius
        return np.array([c[0] - r, c[1] - r, c[0] + r, c[1] + r])

    def roi(self, scale: float = 1.25) -> Roi:
        """The crop for the landmark network: hips centred, body axis up, side 2 * radius * scale."""
        return Roi(np.array(self.hip_centre, dtype=np.float64), 2.0 * self.radius * scale, self.rotation)


# --------------------------------------------------------------------------------------------
# Interpreter loading and input checks


def without_outputs(model: bytes, shapes: Sequence[tuple[int, ...]]) -> bytes | None:
    """A LiteRT model (its flatbuffer bytes) without the outputs of the given shapes and without
    every operator that only they need (found backwards from the outputs kept); the kept outputs
    are computed by the same operators from the same weights, so they are the same numbers.
    None when no output has one of these shapes, when every output has, or when the model is not
    one this reading understands (one subgraph): the caller then runs the whole model.

    BlazePose's landmark models compute a 256 x 256 person mask that ergopose never reads: its
    decoder is 46 of the full model's 332 operators and about a quarter of its time.
    """
    try:
        # Deferred: needed only when a network is loaded; a LiteRT without its schema runs whole.
        import flatbuffers
        from ai_edge_litert import schema_py_generated as schema

        tree = schema.ModelT.InitFromObj(schema.Model.GetRootAs(model, 0))
        if not tree.subgraphs or len(tree.subgraphs) != 1:
            return None
        graph = tree.subgraphs[0]
        drop = {tuple(int(n) for n in shape) for shape in shapes}
        kept = [int(i) for i in graph.outputs if tuple(int(n) for n in graph.tensors[i].shape) not in drop]
        if not kept or len(kept) == len(graph.outputs):
            return None
        needed = set(kept)
        operators = []
        for op in reversed(graph.operators):  # the operators are stored in execution order
            if any(int(o) in needed for o in op.outputs):
                operators.append(op)
                needed.update(int(i) for i in op.inputs if i >= 0)
                if op.intermediates is not None:
                    needed.update(int(i) for i in op.intermediates if i >= 0)
        graph.outputs = kept
        graph.operators = operators[::-1]
        builder = flatbuffers.Builder(len(model) + 4096)
        builder.Finish(tree.Pack(builder), file_identifier=b"TFL3")
        return bytes(builder.Output())
    except Exception:  # a model this reading does not understand runs whole  # noqa: BLE001
        return None


def _load_interpreter(path: Path, card: ModelCard, num_threads: int, unused: Sequence[str] = ()) -> Any:
    """The interpreter of the model at ``path`` (checked against its card), its input index and
    its outputs' indices in the card's order. unused: names of the card's outputs never read;
    the operators only they need are left out (:func:`without_outputs`) and their indices are
    not returned."""
    # Deferred on purpose: the LiteRT runtime is heavy and only needed when a network runs
    # (not for scoring, reports or --help).
    from ai_edge_litert.interpreter import Interpreter

    path = Path(path)
    if not path.is_file():
        raise ModelError("model file not found; run 'ergopose models fetch'", path=path)
    pruned = None
    if unused:
        shapes = [tuple(o.shape) for o in card.outputs if o.role in unused]
        pruned = without_outputs(path.read_bytes(), shapes)
    used = tuple(o for o in card.outputs if pruned is None or o.role not in unused)
    try:
        if pruned is None:
            interpreter = Interpreter(model_path=str(path), num_threads=int(num_threads))
        else:
            interpreter = Interpreter(model_content=pruned, num_threads=int(num_threads))
        interpreter.allocate_tensors()
    except (ValueError, RuntimeError) as exc:
        raise ModelError(
            f"not a loadable LiteRT model ({str(exc).strip().splitlines()[0]}); "
            "run 'ergopose models verify' or 'ergopose models fetch --force'",
            path=path,
        ) from None
    inputs = interpreter.get_input_details()
    w, h = card.input_size
    if len(inputs) != 1 or tuple(inputs[0]["shape"]) != (1, h, w, 3) or inputs[0]["dtype"] != np.float32:
        found = [(tuple(d["shape"]), np.dtype(d["dtype"]).name) for d in inputs]
        raise ModelError(
            f"expected one float32 input of shape (1, {h}, {w}, 3) for {card.name}, found {found}", path=path
        )
    outputs = {tuple(d["shape"][1:]): d["index"] for d in interpreter.get_output_details()}
    expected = [tuple(o.shape[1:]) for o in used]
    missing = [s for s in expected if s not in outputs]
    if missing or len(outputs) != len(expected):
        raise ModelError(
            f"outputs do not match the {card.name} card: expected shapes {expected}, found {sorted(outputs)}", path=path
        )
    return interpreter, inputs[0]["index"], {o.role: outputs[s] for o, s in zip(used, expected)}


def _check_image(image: np.ndarray, size: tuple[int, int], what: str) -> np.ndarray:
    w, h = size
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.shape != (h, w, 3):
        got = f"{image.dtype} array of shape {image.shape}" if isinstance(image, np.ndarray) else type(image).__name__
        raise InputError(f"expected a uint8 BGR image of shape ({h}, {w}, 3), got {got}", field=what)
    return image


def _to_tensor(images_bgr: np.ndarray, card: ModelCard) -> np.ndarray:
    """(N, H, W, 3) uint8 BGR -> float32 network input in the card's channel order and range.

    One pass per image with OpenCV's channel swap and one fused multiply into float32 (the
    straightforward numpy expression with its temporaries took 1.5 ms per 256 x 256 image, this
    takes 0.06 ms).
    """
    mean = np.asarray(card.normalisation.mean, dtype=np.float32)
    inv_std = (1.0 / np.asarray(card.normalisation.std, dtype=np.float64)).astype(np.float32)
    offset = mean * inv_std
    if np.all(inv_std == inv_std[0]) and np.all(offset == offset[0]):
        inv_std, offset = inv_std[0], offset[0]  # scalars: no per-channel broadcasting
    out = np.empty(images_bgr.shape, dtype=np.float32)
    for i, image in enumerate(images_bgr):  # per image (a batch is a handful of crops), not per pixel
        x = cv2.cvtColor(image, cv2.COLOR_BGR2RGB) if card.channel_order == "RGB" else image
        np.multiply(x, inv_std, out=out[i], casting="unsafe")
        out[i] -= offset
    return out


# --------------------------------------------------------------------------------------------
# Detector


def ssd_anchors(
    input_size: int = 224, strides: Sequence[int] = (8, 16, 32, 32, 32), anchors_per_layer: int = 2, offset: float = 0.5
) -> np.ndarray:
    """SSD anchor centres (N, 2), normalised to [0, 1], in the order the detector outputs them.

    Consecutive layers with the same stride share one feature map: for each cell (row-major)
    all their anchors follow one another. Anchors have a fixed size of 1 (not returned).
    """
    centres = []
    i = 0
    while i < len(strides):
        j = i
        while j < len(strides) and strides[j] == strides[i]:
            j += 1
        n = int(np.ceil(input_size / strides[i]))
        ys, xs = np.mgrid[0:n, 0:n]
        cells = np.stack([(xs.ravel() + offset) / n, (ys.ravel() + offset) / n], axis=1)
        centres.append(np.repeat(cells, anchors_per_layer * (j - i), axis=0))
        i = j
    return np.concatenate(centres).astype(np.float64)


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    x0 = np.maximum(box[0], boxes[:, 0])
    y0 = np.maximum(box[1], boxes[:, 1])
    x1 = np.minimum(box[2], boxes[:, 2])
    y1 = np.minimum(box[3], boxes[:, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    area = (box[2] - box[0]) * (box[3] - box[1])
    areas = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    union = area + areas - inter
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0)


def weighted_nms(
    scores: np.ndarray, boxes: np.ndarray, keypoints: np.ndarray, iou_threshold: float
) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """Weighted non-maximum suppression.

    Repeatedly take the best remaining candidate and every remaining candidate overlapping it by
    more than ``iou_threshold`` (IoU); report the best score with the score-weighted mean box and
    keypoints of that group, and drop the group. Returns (score, box, keypoints) best first.
    """
    order = np.argsort(-scores, kind="stable")
    out = []
    while order.size:
        best = order[0]
        overlap = _iou(boxes[best], boxes[order])
        group = order[overlap > iou_threshold]
        group = group if group.size else order[:1]
        w = scores[group] / scores[group].sum()
        out.append(
            (
                float(scores[best]),
                (boxes[group] * w[:, None]).sum(axis=0),
                (keypoints[group] * w[:, None, None]).sum(axis=0),
            )
        )
        order = order[overlap <= iou_threshold]
        order = order[order != best]
    return out


def decode_detections(
    raw_regressors: np.ndarray,
    raw_scores: np.ndarray,
    anchors: np.ndarray,
    input_size: int = 224,
    min_score: float = 0.5,
    iou_threshold: float = 0.3,
) -> list[PersonDetection]:
    """Turn the detector's raw outputs (N, 12) and (N,) into detections in input pixels."""
    scores = sigmoid(raw_scores.reshape(-1))
    keep = np.flatnonzero(scores >= min_score)
    if keep.size == 0:
        return []
    raw = raw_regressors.reshape(-1, 12)[keep].astype(np.float64)
    anc = anchors[keep]
    centre = raw[:, 0:2] / input_size + anc
    half = raw[:, 2:4] / input_size / 2.0
    boxes = np.hstack([centre - half, centre + half])
    kps = raw[:, 4:12].reshape(-1, 4, 2) / input_size + anc[:, None, :]
    detections = []
    for score, box, kp in weighted_nms(scores[keep], boxes, kps, iou_threshold):
        # normalised (corner convention) -> pixels with pixel centres at integers
        detections.append(PersonDetection(score, kp * input_size - 0.5, box * input_size - 0.5))
    return detections


class BlazePoseDetector:
    """Finds people in a 224 x 224 BGR image with MediaPipe's pose detector.

    model_path: a pose_detection.tflite; default: the cached model (fetched on first use).
    min_score: minimum detection score; iou_threshold: non-maximum suppression overlap.
    """

    def __init__(
        self,
        model_path: str | os.PathLike[str] | None = None,
        *,
        model_dir: str | os.PathLike[str] | None = None,
        num_threads: int = DEFAULT_THREADS,
        min_score: float = 0.5,
        iou_threshold: float = 0.3,
        progress: ProgressCallback | None = None,
    ):
        self.card = model_card(BLAZEPOSE_DETECTOR)
        path = (
            Path(model_path)
            if model_path is not None
            else ensure_model(BLAZEPOSE_DETECTOR, progress, model_dir=model_dir)
        )
        self.model_path = path
        self._interp, self._input, outs = _load_interpreter(path, self.card, num_threads)
        self._regressors, self._scores = (outs[o.role] for o in self.card.outputs)
        self.input_size = self.card.input_size
        self.anchors = ssd_anchors(self.input_size[0])
        n = self.card.outputs[0].shape[1]
        if self.anchors.shape[0] != n:
            raise ModelError(f"anchor layout gives {self.anchors.shape[0]} anchors, model has {n}", path=path)
        self.min_score = float(min_score)
        self.iou_threshold = float(iou_threshold)

    def raw(self, image_bgr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The network's raw outputs for one image: regressors (2254, 12) and score logits (2254,)."""
        image = _check_image(image_bgr, self.input_size, "detector image")
        self._interp.set_tensor(self._input, _to_tensor(image[None], self.card))
        self._interp.invoke()
        return (
            self._interp.get_tensor(self._regressors)[0].copy(),
            self._interp.get_tensor(self._scores)[0, :, 0].copy(),
        )

    def __call__(self, image_bgr: np.ndarray) -> list[PersonDetection]:
        """People in the image, best score first (empty list if none)."""
        regressors, scores = self.raw(image_bgr)
        return decode_detections(
            regressors, scores, self.anchors, self.input_size[0], self.min_score, self.iou_threshold
        )


# --------------------------------------------------------------------------------------------
# Landmarks


def refine_with_heatmap(
    xy_model: np.ndarray, heatmap_logits: np.ndarray, input_size: int, kernel: int = 7, min_peak: float = 0.5
) -> np.ndarray:
    """Refine landmark positions with the landmark heatmap, as MediaPipe's landmark graph does.

    xy_model: (K, 2) positions in input pixels, corner convention (0..input_size).
    heatmap_logits: (Hh, Wh, >=K). For each landmark, a kernel x kernel window of cells around
    the cell holding the position is weighted by sigmoid(logit); where the window's largest
    weight is at least ``min_peak`` the position becomes the weighted mean cell index times the
    cell size (cell i at i * cell size, the convention the network was trained with: it agrees
    with the regressed positions to 0.5 px on a drawn person, against 1.5 px for cell centres).
    Positions outside the heatmap are kept.
    """
    hm_h, hm_w = heatmap_logits.shape[:2]
    k = xy_model.shape[0]
    col = np.floor(xy_model[:, 0] / input_size * hm_w).astype(np.int64)
    row = np.floor(xy_model[:, 1] / input_size * hm_h).astype(np.int64)
    inside = (col >= 0) & (col < hm_w) & (row >= 0) & (row < hm_h)
    half = (kernel - 1) // 2
    d = np.arange(-half, half + 1)
    rows = row[:, None, None] + d[None, :, None]  # (K, kernel, 1)
    cols = col[:, None, None] + d[None, None, :]  # (K, 1, kernel)
    valid = (rows >= 0) & (rows < hm_h) & (cols >= 0) & (cols < hm_w)
    rr = np.clip(rows, 0, hm_h - 1)
    cc = np.clip(cols, 0, hm_w - 1)
    chan = np.arange(k)[:, None, None]
    weights = np.where(valid, sigmoid(heatmap_logits[rr, cc, chan]), 0.0)  # (K, kernel, kernel)
    total = weights.sum(axis=(1, 2))
    peak = weights.max(axis=(1, 2))
    safe = np.where(total > 0, total, 1.0)
    mean_col = (weights * cols).sum(axis=(1, 2)) / safe
    mean_row = (weights * rows).sum(axis=(1, 2)) / safe
    use = inside & (peak >= min_peak) & (total > 0)
    out = np.array(xy_model, dtype=np.float64, copy=True)
    out[use, 0] = mean_col[use] * (input_size / hm_w)
    out[use, 1] = mean_row[use] * (input_size / hm_h)
    return out


class BlazePoseLandmarker:
    """The 33 BlazePose landmarks of the person in a 256 x 256 BGR crop.

    The crop should hold one person, hips near the centre, body axis up, the body filling about
    80 % of the side (:meth:`PersonDetection.roi` gives such a crop).
    model: the landmark model, "lite", "full" or "heavy" (or its card name); None: the default
        (ergopose.pose.models.DEFAULT_LANDMARK_MODEL). Its card's confidence gates are
        ``self.card.gates``.
    refine: refine positions with the heatmap (MediaPipe's default). world: keep world landmarks.
    """

    def __init__(
        self,
        model_path: str | os.PathLike[str] | None = None,
        *,
        model: str | None = None,
        model_dir: str | os.PathLike[str] | None = None,
        num_threads: int = DEFAULT_THREADS,
        refine: bool = True,
        world: bool = False,
        progress: ProgressCallback | None = None,
    ):
        self.card = landmark_card(model)
        path = (
            Path(model_path) if model_path is not None else ensure_model(self.card.name, progress, model_dir=model_dir)
        )
        self.model_path = path
        # The person mask is never read, nor the world landmarks unless asked for: the network
        # runs without the operators only they need (the same landmarks, about 25 % faster).
        self.world = bool(world)
        unused = ("segmentation",) if self.world else ("segmentation", "world_landmarks")
        self._interp, self._input, outs = _load_interpreter(path, self.card, num_threads, unused)
        self._landmarks, self._flag, self._heatmap = outs["landmarks"], outs["pose_flag"], outs["heatmap"]
        self._world = outs.get("world_landmarks")
        self.input_size = self.card.input_size
        self.refine = bool(refine)

    def __call__(self, image_bgr: np.ndarray) -> Keypoints2D:
        image = _check_image(image_bgr, self.input_size, "landmark image")
        self._interp.set_tensor(self._input, _to_tensor(image[None], self.card))
        self._interp.invoke()
        return self._decode()

    def run_batch(self, images_bgr: Sequence[np.ndarray]) -> list[Keypoints2D]:
        """Landmarks for several crops (one interpreter, one crop after another)."""
        return [self(image) for image in images_bgr]

    def _decode(self) -> Keypoints2D:
        get = self._interp.get_tensor
        raw = get(self._landmarks)[0].reshape(-1, 5).astype(np.float64)
        flag = float(get(self._flag).reshape(-1)[0])
        size = self.input_size[0]
        xy = raw[:NUM_JOINTS, 0:2]
        if self.refine:
            xy = refine_with_heatmap(xy, get(self._heatmap)[0][..., :NUM_JOINTS], size)
        world = None
        if self.world:
            world = get(self._world)[0].reshape(-1, 3)[:NUM_JOINTS].astype(np.float64)
        return Keypoints2D(
            pixels=xy - 0.5,
            confidence=sigmoid(raw[:NUM_JOINTS, 3]),
            presence=flag,
            depth=raw[:NUM_JOINTS, 2].copy(),
            landmark_presence=sigmoid(raw[:NUM_JOINTS, 4]),
            world_m=world,
            alignment=raw[NUM_JOINTS : NUM_JOINTS + 2, 0:2] - 0.5 if raw.shape[0] >= NUM_JOINTS + 2 else None,
        )
