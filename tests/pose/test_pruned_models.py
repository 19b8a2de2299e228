"""Networks run without the outputs ergopose never reads (ergopose/pose/blazepose.py,
without_outputs): the kept outputs are the same numbers, the left-out operators do not run."""

from __future__ import annotations

import numpy as np
import pytest
from mannequin import mannequin_image

from ergopose.pose.blazepose import BlazePoseLandmarker, _to_tensor, without_outputs


def _tiny_model() -> bytes:
    """A LiteRT model made here: inputs a (1, 2) and b (1, 3); outputs a + a (1, 2) and b * b (1, 3)."""
    import flatbuffers
    from ai_edge_litert import schema_py_generated as schema

    def tensor(name, shape):
        t = schema.TensorT()
        t.name, t.shape, t.type, t.buffer = name, [1, shape], schema.TensorType.FLOAT32, 0
        return t

    def code(op):
        c = schema.OperatorCodeT()
        c.builtinCode, c.deprecatedBuiltinCode, c.version = op, op, 1
        return c

    def operator(code_index, inputs, output, options_type, options):
        o = schema.OperatorT()
        o.opcodeIndex, o.inputs, o.outputs = code_index, inputs, [output]
        o.builtinOptionsType, o.builtinOptions = options_type, options
        return o

    graph = schema.SubGraphT()
    graph.tensors = [tensor(b"a", 2), tensor(b"b", 3), tensor(b"sum", 2), tensor(b"square", 3)]
    graph.inputs, graph.outputs = [0, 1], [2, 3]
    graph.operators = [
        operator(0, [0, 0], 2, schema.BuiltinOptions.AddOptions, schema.AddOptionsT()),
        operator(1, [1, 1], 3, schema.BuiltinOptions.MulOptions, schema.MulOptionsT()),
    ]
    model = schema.ModelT()
    model.version, model.subgraphs, model.buffers = 3, [graph], [schema.BufferT()]
    model.operatorCodes = [code(schema.BuiltinOperator.ADD), code(schema.BuiltinOperator.MUL)]
    builder = flatbuffers.Builder(1024)
    builder.Finish(model.Pack(builder), file_identifier=b"TFL3")
    return bytes(builder.Output())


def _run(content: bytes, a: np.ndarray, b: np.ndarray) -> dict[tuple[int, ...], np.ndarray]:
    from ai_edge_litert.interpreter import Interpreter

    interp = Interpreter(model_content=content, num_threads=1)
    interp.allocate_tensors()
    for detail, value in zip(interp.get_input_details(), (a, b)):
        interp.set_tensor(detail["index"], value)
    interp.invoke()
    return {
        tuple(int(n) for n in d["shape"]): interp.get_tensor(d["index"]).copy() for d in interp.get_output_details()
    }


def test_an_output_and_the_operators_only_it_needs_are_left_out():
    model = _tiny_model()
    a, b = np.array([[1.5, -2.0]], np.float32), np.array([[3.0, 0.5, -1.0]], np.float32)
    whole = _run(model, a, b)
    np.testing.assert_array_equal(whole[(1, 2)], [[3.0, -4.0]])
    np.testing.assert_array_equal(whole[(1, 3)], [[9.0, 0.25, 1.0]])
    pruned = without_outputs(model, [(1, 3)])
    assert pruned is not None
    from ai_edge_litert.interpreter import Interpreter

    interp = Interpreter(model_content=pruned, num_threads=1)
    assert [op["op_name"] for op in interp._get_ops_details()] == ["ADD"]
    assert [tuple(d["shape"]) for d in interp.get_output_details()] == [(1, 2)]
    out = _run(pruned, a, b)
    assert list(out) == [(1, 2)]
    np.testing.assert_array_equal(out[(1, 2)], [[3.0, -4.0]])


def test_nothing_to_leave_out_or_not_a_model_gives_none():
    model = _tiny_model()
    assert without_outputs(model, [(1, 7)]) is None  # no output of that shape
    assert without_outputs(model, [(1, 2), (1, 3)]) is None  # nothing would be left to run
    assert without_outputs(b"\x00garbage" * 100, [(1, 3)]) is None


@pytest.mark.network
def test_the_landmark_network_without_its_mask_gives_the_same_landmarks(fetched_model_dir, landmarker):
    from ai_edge_litert.interpreter import Interpreter

    lean = BlazePoseLandmarker(model_dir=fetched_model_dir[0], num_threads=1)  # world=False
    whole = Interpreter(model_path=str(lean.model_path), num_threads=1)
    whole.allocate_tensors()
    n_lean, n_whole = len(lean._interp._get_ops_details()), len(whole._get_ops_details())
    assert n_lean < n_whole - 40  # the mask's decoder (46 operators) and the world head are out
    assert {tuple(d["shape"]) for d in lean._interp.get_output_details()} == {(1, 195), (1, 1), (1, 64, 64, 39)}
    image, _ = mannequin_image()
    kp = lean(image)
    whole.set_tensor(whole.get_input_details()[0]["index"], _to_tensor(image[None], lean.card))
    whole.invoke()
    outs = {tuple(d["shape"]): whole.get_tensor(d["index"]) for d in whole.get_output_details()}
    np.testing.assert_array_equal(lean._interp.get_tensor(lean._landmarks), outs[(1, 195)])
    np.testing.assert_array_equal(lean._interp.get_tensor(lean._heatmap), outs[(1, 64, 64, 39)])
    ref = landmarker(image)  # world=True keeps the world landmarks, and gives the same keypoints
    np.testing.assert_array_equal(kp.pixels, ref.pixels)
    assert kp.presence == ref.presence and kp.world_m is None and ref.world_m is not None
