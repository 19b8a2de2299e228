"""User-brought ONNX pose models: tiny networks built here with the onnx package whose outputs
are known (constant Gaussian heatmaps, constant SimCC distributions, a pooled input channel), so
decoding, normalisation, channel order and the schema mapping are checked against exact answers."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import onnx
import pytest
from onnx import TensorProto, helper, numpy_helper

from ergopose.errors import ConfigError, InputError, ModelError
from ergopose.keypoints import COCO17, JOINT_INDEX
from ergopose.pose.onnx_models import OnnxPoseModel, decode_heatmaps, decode_simcc, load_onnx_card

W, H = 192, 256  # input width, height (the RTMPose / SimpleBaseline body size)
STRIDE = 4


def _save(graph: onnx.GraphProto, path: Path) -> Path:
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    onnx.save(model, path)
    return path


def _constant_outputs_model(path: Path, outputs: dict[str, np.ndarray], batch="N") -> Path:
    """A network whose outputs are the given constants (first axis 1) repeated for each image."""
    inp = helper.make_tensor_value_info("input", TensorProto.FLOAT, [batch, 3, H, W])
    nodes = [
        helper.make_node("Shape", ["input"], ["shape"]),
        helper.make_node("Slice", ["shape", "zero", "one"], ["n"]),
    ]
    inits = [
        numpy_helper.from_array(np.array([0], np.int64), "zero"),
        numpy_helper.from_array(np.array([1], np.int64), "one"),
    ]
    outs = []
    for name, value in outputs.items():
        value = value.astype(np.float32)
        inits += [
            numpy_helper.from_array(value, f"{name}_const"),
            numpy_helper.from_array(np.array(value.shape[1:], np.int64), f"{name}_rest"),
        ]
        nodes += [
            helper.make_node("Concat", ["n", f"{name}_rest"], [f"{name}_shape"], axis=0),
            helper.make_node("Expand", [f"{name}_const", f"{name}_shape"], [name]),
        ]
        outs.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, [batch, *value.shape[1:]]))
    return _save(helper.make_graph(nodes, "constant", [inp], outs, inits), path)


def _pooled_channel_model(path: Path, k: int) -> Path:
    """Heatmap k x (H/4) x (W/4): the first input channel average-pooled over 4 x 4 cells."""
    inp = helper.make_tensor_value_info("input", TensorProto.FLOAT, ["N", 3, H, W])
    out = helper.make_tensor_value_info("heatmaps", TensorProto.FLOAT, ["N", k, H // STRIDE, W // STRIDE])
    inits = [
        numpy_helper.from_array(np.array([0], np.int64), "c0"),
        numpy_helper.from_array(np.array([1], np.int64), "c1"),
        numpy_helper.from_array(np.array([1], np.int64), "axis1"),
        numpy_helper.from_array(np.array([1, k, 1, 1], np.int64), "reps"),
    ]
    nodes = [
        helper.make_node("Slice", ["input", "c0", "c1", "axis1"], ["first"]),
        helper.make_node("AveragePool", ["first"], ["pooled"], kernel_shape=[STRIDE, STRIDE], strides=[STRIDE, STRIDE]),
        helper.make_node("Tile", ["pooled", "reps"], ["heatmaps"]),
    ]
    return _save(helper.make_graph(nodes, "pooled", [inp], [out], inits), path)


def _card(
    path: Path,
    model: Path,
    output_type: str,
    keypoints,
    *,
    channel_order="RGB",
    mean=(123.675, 116.28, 103.53),
    std=(58.395, 57.12, 57.375),
    extra: str = "",
) -> Path:
    kp = f'"{keypoints}"' if isinstance(keypoints, str) else "[" + ", ".join(f'"{n}"' for n in keypoints) + "]"
    path.write_text(
        f'name = "{path.stem}"\nfile = "{model.name}"\nlicence = "test"\n{extra}\n'
        f'[input]\nwidth = {W}\nheight = {H}\nchannel_order = "{channel_order}"\n'
        f"mean = {list(mean)}\nstd = {list(std)}\n"
        f'[output]\ntype = "{output_type}"\nsplit_ratio = 2.0\nkeypoints = {kp}\n',
        encoding="utf-8",
    )
    return path


def _gaussian(shape, centre, sigma_x, sigma_y, rho=0.0, peak=1.0):
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float64)
    dx, dy = (xx - centre[0]) / sigma_x, (yy - centre[1]) / sigma_y
    return peak * np.exp(-(dx * dx - 2 * rho * dx * dy + dy * dy) / (2 * (1 - rho * rho)))


# ---------------------------------------------------------------------------- heatmaps


def test_heatmap_model_recovers_sub_cell_gaussian_peaks(tmp_path):
    hh, ww = H // STRIDE, W // STRIDE
    rng = np.random.default_rng(17)
    centres = np.column_stack([rng.uniform(3, ww - 4, 17), rng.uniform(3, hh - 4, 17)])
    peaks = rng.uniform(0.3, 0.95, 17)
    maps = np.stack(
        [
            _gaussian((hh, ww), c, sx, sy, rho, p)
            for c, sx, sy, rho, p in zip(
                centres, rng.uniform(1.5, 3, 17), rng.uniform(1.5, 3, 17), rng.uniform(-0.5, 0.5, 17), peaks
            )
        ]
    )[None]
    model = _constant_outputs_model(tmp_path / "hm.onnx", {"heatmaps": maps})
    runner = OnnxPoseModel(_card(tmp_path / "hm.toml", model, "heatmap", "coco17"))
    kp = runner(np.zeros((H, W, 3), np.uint8))
    schema = [JOINT_INDEX[n] for n in COCO17]
    # Gaussian peaks: the Newton step on log values is exact (float32 storage limits it).
    np.testing.assert_allclose(kp.pixels[schema], centres * STRIDE, atol=0.02)
    # confidence: the sampled peak value, at most the true peak and close to it
    assert np.all(kp.confidence[schema] <= peaks + 1e-6) and np.all(kp.confidence[schema] > 0.8 * peaks)
    others = [i for i in range(33) if i not in schema]
    assert np.isnan(kp.pixels[others]).all() and not kp.confidence[others].any()
    assert kp.presence == pytest.approx(kp.confidence[schema].mean())


def test_heatmap_decoding_without_refinement_and_at_the_border():
    hm = np.zeros((1, 2, 8, 10))
    hm[0, 0] = _gaussian((8, 10), (4.3, 5.0), 1.5, 1.5)
    hm[0, 1, 0, 9] = 1.0  # peak on the border: no neighbourhood, kept on the cell
    xy, peak = decode_heatmaps(hm, (40, 32), refine=False)
    np.testing.assert_allclose(xy[0], [[4 * 4, 5 * 4], [9 * 4, 0]])
    xy, peak = decode_heatmaps(hm, (40, 32))
    np.testing.assert_allclose(xy[0], [[4.3 * 4, 5 * 4], [9 * 4, 0]], atol=1e-9)
    assert peak[0, 1] == 1.0


def test_input_dependent_model_checks_channel_order_and_normalisation(tmp_path):
    """The network pools the FIRST channel it is given. The images carry a red square and a blue
    decoy square; mean/std map red 255 to exactly 1 and the background to 0."""
    model = _pooled_channel_model(tmp_path / "pool.onnx", k=17)
    mean, std = (10.0, 20.0, 30.0), (245.0, 235.0, 225.0)
    rgb = OnnxPoseModel(_card(tmp_path / "rgb.toml", model, "heatmap", "coco17", mean=mean, std=std))
    cells = [(10, 20), (40, 3), (25, 50)]  # (col, row) of the red square, one image each
    decoy = (5, 5)
    images = []
    for col, row in cells:
        img = np.zeros((H, W, 3), np.uint8)
        img[..., 2] = 10  # red background -> 0 after normalisation
        img[row * 4 : row * 4 + 4, col * 4 : col * 4 + 4, 2] = 255
        img[decoy[1] * 4 : decoy[1] * 4 + 4, decoy[0] * 4 : decoy[0] * 4 + 4, 0] = 255
        images.append(img)
    results = rgb.run_batch(images)
    wrist = JOINT_INDEX["left_wrist"]
    for (col, row), kp in zip(cells, results):
        np.testing.assert_allclose(kp.pixels[wrist], [col * STRIDE, row * STRIDE], atol=1e-6)
        assert kp.confidence[wrist] == pytest.approx(1.0, abs=1e-5)
    # The same network read as BGR sees the blue channel first and finds the decoy.
    bgr = OnnxPoseModel(
        _card(
            tmp_path / "bgr.toml", model, "heatmap", "coco17", channel_order="BGR", mean=(0, 0, 0), std=(255, 255, 255)
        )
    )
    kp = bgr(images[0])
    np.testing.assert_allclose(kp.pixels[wrist], [decoy[0] * STRIDE, decoy[1] * STRIDE], atol=1e-6)
    x = rgb.preprocess(images[0][None])
    assert x.shape == (1, 3, H, W) and x.dtype == np.float32
    assert x[0, 0, 0, 0] == pytest.approx(0.0) and x[0, 2, 20, 20] == pytest.approx((255 - 30) / 225)


# ---------------------------------------------------------------------------- SimCC


def _simcc(bins: int, where: np.ndarray, peaks: np.ndarray) -> np.ndarray:
    out = np.full((1, len(where), bins), 0.01)
    out[0, np.arange(len(where)), where] = peaks
    return out


def test_simcc_model_decodes_bins_and_maps_halpe26(tmp_path):
    rng = np.random.default_rng(26)
    k = 26
    bx, by = rng.integers(0, 2 * W, k), rng.integers(0, 2 * H, k)
    px, py = rng.uniform(0.2, 1.0, k), rng.uniform(0.2, 1.0, k)
    model = _constant_outputs_model(
        tmp_path / "simcc.onnx", {"simcc_x": _simcc(2 * W, bx, px), "simcc_y": _simcc(2 * H, by, py)}
    )
    kp = OnnxPoseModel(_card(tmp_path / "simcc.toml", model, "simcc", "halpe26"))(np.zeros((H, W, 3), np.uint8))
    # Halpe 0-16 are COCO's; 20/21 big toes -> foot_index; 24/25 heels; head/neck/hip/small toes unused.
    pairs = [(i, JOINT_INDEX[n]) for i, n in enumerate(COCO17)]
    pairs += [
        (20, JOINT_INDEX["left_foot_index"]),
        (21, JOINT_INDEX["right_foot_index"]),
        (24, JOINT_INDEX["left_heel"]),
        (25, JOINT_INDEX["right_heel"]),
    ]
    src, dst = np.array(pairs).T
    np.testing.assert_allclose(kp.pixels[dst], np.column_stack([bx[src], by[src]]) / 2.0)
    np.testing.assert_allclose(kp.confidence[dst], np.minimum(px, py)[src], rtol=1e-6)
    assert np.isnan(kp.pixels[JOINT_INDEX["left_pinky"]]).all()


def test_simcc_decoding_direct():
    sx = np.zeros((2, 1, 10))
    sy = np.zeros((2, 1, 6))
    sx[0, 0, 7], sy[0, 0, 2] = 0.9, 0.4
    sx[1, 0, 0], sy[1, 0, 5] = 0.3, 0.8
    xy, conf = decode_simcc(sx, sy, split_ratio=2.0)
    np.testing.assert_allclose(xy[:, 0], [[3.5, 1.0], [0.0, 2.5]])
    np.testing.assert_allclose(conf[:, 0], [0.4, 0.3])


def test_static_batch_model_runs_one_image_at_a_time(tmp_path):
    maps = np.zeros((1, 17, H // STRIDE, W // STRIDE))
    maps[0, :, 7, 9] = 0.7
    model = _constant_outputs_model(tmp_path / "static.onnx", {"heatmaps": maps}, batch=1)
    runner = OnnxPoseModel(
        _card(
            tmp_path / "static.toml",
            model,
            "heatmap",
            "coco17",
            extra='sha256 = "' + hashlib.sha256(model.read_bytes()).hexdigest() + '"',
        )
    )
    assert not runner.dynamic_batch
    out = runner.run_batch([np.zeros((H, W, 3), np.uint8)] * 3)
    assert len(out) == 3
    for kp in out:
        np.testing.assert_allclose(kp.pixels[JOINT_INDEX["nose"]], [36.0, 28.0])


# ---------------------------------------------------------------------------- cards and errors


def test_card_errors_name_the_field(tmp_path):
    maps = np.zeros((1, 17, H // STRIDE, W // STRIDE))
    model = _constant_outputs_model(tmp_path / "m.onnx", {"heatmaps": maps})
    names = list(COCO17)
    names[3] = "left_eer"
    with pytest.raises(ConfigError, match=r"output\.keypoints: unknown keypoint names \['left_eer'\]"):
        load_onnx_card(_card(tmp_path / "a.toml", model, "heatmap", names))
    with pytest.raises(ConfigError, match=r"output\.type"):
        load_onnx_card(_card(tmp_path / "b.toml", model, "paf", "coco17"))
    with pytest.raises(ConfigError, match="unknown keypoint preset"):
        load_onnx_card(_card(tmp_path / "c.toml", model, "heatmap", "mpii"))
    bad = tmp_path / "d.toml"
    bad.write_text(
        'file = "m.onnx"\n[input]\nwidth = 192\n[output]\ntype = "heatmap"\nkeypoints = "coco17"\n', encoding="utf-8"
    )
    with pytest.raises(ConfigError, match=r"d\.toml: input\.height: missing"):
        load_onnx_card(bad)
    with pytest.raises(ConfigError, match="model card not found"):
        load_onnx_card(tmp_path / "none.toml")
    # 17 channels but 26 names
    with pytest.raises(ModelError, match="outputs 17 keypoints, the card names 26"):
        OnnxPoseModel(_card(tmp_path / "e.toml", model, "heatmap", "halpe26"))
    # a simcc card on a heatmap network
    with pytest.raises(ModelError, match="SimCC"):
        OnnxPoseModel(_card(tmp_path / "f.toml", model, "simcc", "coco17"))


def test_model_file_problems_are_model_errors(tmp_path):
    maps = np.zeros((1, 17, H // STRIDE, W // STRIDE))
    model = _constant_outputs_model(tmp_path / "m.onnx", {"heatmaps": maps})
    wrong = "0" * 64
    with pytest.raises(ModelError, match="differs from the card"):
        OnnxPoseModel(_card(tmp_path / "a.toml", model, "heatmap", "coco17", extra=f'sha256 = "{wrong}"'))
    missing = _card(tmp_path / "b.toml", tmp_path / "gone.onnx", "heatmap", "coco17")
    with pytest.raises(ModelError, match="not found"):
        OnnxPoseModel(missing)
    junk = tmp_path / "junk.onnx"
    junk.write_bytes(b"\x08\x01garbage")
    with pytest.raises(ModelError, match="not a loadable ONNX model"):
        OnnxPoseModel(_card(tmp_path / "c.toml", junk, "heatmap", "coco17"))
    runner = OnnxPoseModel(_card(tmp_path / "d.toml", model, "heatmap", "coco17"))
    with pytest.raises(InputError, match=r"\(256, 192, 3\)"):
        runner(np.zeros((256, 256, 3), np.uint8))
