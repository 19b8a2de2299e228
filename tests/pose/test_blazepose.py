"""BlazePose runners: decoding pieces against hand-computed answers, and the real networks on a
drawn cartoon person whose joint positions are known."""

from __future__ import annotations

import numpy as np
import pytest
from mannequin import draw_mannequin, mannequin_image

from ergopose.errors import InputError, ModelError
from ergopose.keypoints import JOINT_INDEX
from ergopose.pose.blazepose import (
    BlazePoseDetector,
    BlazePoseLandmarker,
    Keypoints2D,
    PersonDetection,
    Roi,
    _to_tensor,
    decode_detections,
    refine_with_heatmap,
    ssd_anchors,
    weighted_nms,
)
from ergopose.pose.models import BLAZEPOSE_DETECTOR, BLAZEPOSE_LANDMARK_FULL, model_card

# Tolerances (pixels, 256 x 256 crop) for the drawn person. Measured errors: shoulders 0.3-0.8,
# elbows 3.9-4.9, wrists 1.8-2.4, hips 3.3-3.5, knees 3.6-4.3, ankles 5.4-5.7 (docs/models.md).
TOLERANCE_PX = {"shoulder": 3.0, "elbow": 7.0, "wrist": 6.0, "hip": 6.0, "knee": 7.0, "ankle": 9.0}


def _errors(kp: Keypoints2D, joints: dict[str, np.ndarray]) -> dict[str, float]:
    return {n: float(np.linalg.norm(kp.pixels[JOINT_INDEX[n]] - p)) for n, p in joints.items()}


def _assert_near(kp: Keypoints2D, joints: dict[str, np.ndarray], factor: float = 1.0) -> None:
    errors = _errors(kp, joints)
    for name, err in errors.items():
        tol = TOLERANCE_PX[name.split("_")[1]] * factor
        assert err < tol, f"{name}: {err:.1f} px from the drawn joint (tolerance {tol:.1f}); all: {errors}"


# ---------------------------------------------------------------------------- decoding pieces


def test_anchor_layout_matches_the_detector_output():
    anchors = ssd_anchors()
    assert anchors.shape == (2254, 2) == (model_card(BLAZEPOSE_DETECTOR).outputs[0].shape[1], 2)
    # 28 x 28 cells x 2 anchors, then 14 x 14 x 2, then 7 x 7 x 6 (three stride-32 layers merged).
    np.testing.assert_allclose(anchors[0], anchors[1])
    np.testing.assert_allclose(anchors[0], [0.5 / 28, 0.5 / 28])
    np.testing.assert_allclose(anchors[2], [1.5 / 28, 0.5 / 28])  # row-major: x moves first
    np.testing.assert_allclose(anchors[2 * 28], [0.5 / 28, 1.5 / 28])
    np.testing.assert_allclose(anchors[1568], [0.5 / 14, 0.5 / 14])
    np.testing.assert_allclose(anchors[1568 + 392 : 1568 + 392 + 6], np.tile([0.5 / 7, 0.5 / 7], (6, 1)))
    np.testing.assert_allclose(anchors[-1], [6.5 / 7, 6.5 / 7])


def test_decode_detections_hand_made():
    anchors = np.array([[0.25, 0.5], [0.75, 0.5]])
    raw = np.zeros((2, 12))
    # anchor 1: box centre moved by (+22.4, -11.2) px, size 44.8 x 22.4; keypoints relative to anchor.
    raw[1, :4] = [22.4, -11.2, 44.8, 22.4]
    raw[1, 4:] = [0, 56, 0, -56, 11.2, 0, -11.2, 0]
    scores = np.array([-3.0, 2.0])  # sigmoid: 0.047, 0.881
    dets = decode_detections(raw, scores, anchors, input_size=224, min_score=0.5)
    assert len(dets) == 1
    d = dets[0]
    assert d.score == pytest.approx(1 / (1 + np.exp(-2.0)))
    cx, cy = 0.75 * 224 + 22.4, 0.5 * 224 - 11.2
    np.testing.assert_allclose(d.ssd_box, [cx - 22.4 - 0.5, cy - 11.2 - 0.5, cx + 22.4 - 0.5, cy + 11.2 - 0.5])
    ax, ay = 0.75 * 224 - 0.5, 0.5 * 224 - 0.5
    np.testing.assert_allclose(d.keypoints, [[ax, ay + 56], [ax, ay - 56], [ax + 11.2, ay], [ax - 11.2, ay]])
    assert d.radius == pytest.approx(112.0)
    assert d.rotation == pytest.approx(0.0)  # full-body point straight above the hips
    np.testing.assert_allclose(d.box, [ax - 112, ay + 56 - 112, ax + 112, ay + 56 + 112])
    assert decode_detections(raw, np.array([-3.0, -2.0]), anchors) == []


def test_weighted_nms_merges_overlaps_and_keeps_separate_people():
    boxes = np.array([[0, 0, 10, 10], [1, 0, 11, 10], [50, 50, 60, 60], [0.5, 0, 10.5, 10]], float)
    kps = np.zeros((4, 4, 2))
    kps[:, 0, 0] = [0.0, 10.0, 100.0, 5.0]
    scores = np.array([0.9, 0.6, 0.7, 0.3])
    out = weighted_nms(scores, boxes, kps, iou_threshold=0.3)
    assert [s for s, _, _ in out] == [0.9, 0.7]
    w = np.array([0.9, 0.6, 0.3]) / 1.8
    np.testing.assert_allclose(out[0][1], w @ boxes[[0, 1, 3]])
    assert out[0][2][0, 0] == pytest.approx(w @ np.array([0.0, 10.0, 5.0]))
    np.testing.assert_allclose(out[1][1], boxes[2])


def test_person_rotation_is_clockwise_from_up():
    def det(dx, dy):
        kp = np.array([[100.0, 100.0], [100.0 + dx, 100.0 + dy], [0, 0], [0, 0]])
        return PersonDetection(0.9, kp, np.zeros(4))

    assert det(0, -50).rotation == pytest.approx(0.0)
    assert det(50, 0).rotation == pytest.approx(np.pi / 2)  # axis to the right: turned clockwise
    assert det(-50, 0).rotation == pytest.approx(-np.pi / 2)
    assert det(0, 50).rotation == pytest.approx(np.pi)
    roi = det(30, -40).roi()
    assert roi.side == pytest.approx(2 * 50 * 1.25)
    np.testing.assert_allclose(roi.centre, [100, 100])


def test_roi_maps_the_body_axis_to_up():
    roi = Roi(np.array([120.0, 80.0]), side=100.0, rotation=np.pi / 2)  # body axis pointing right
    m = roi.image_to_crop(256)
    centre = m[:, :2] @ roi.centre + m[:, 2]
    np.testing.assert_allclose(centre, [127.5, 127.5])
    # 40 px along the axis (to the right in the image) is 40 * 2.56 px up in the crop.
    p = m[:, :2] @ np.array([160.0, 80.0]) + m[:, 2]
    np.testing.assert_allclose(p, [127.5, 127.5 - 40 * 2.56])
    back = roi.crop_to_image(256)
    np.testing.assert_allclose(back[:, :2] @ p + back[:, 2], [160.0, 80.0])
    # The crop of an image with one bright pixel shows it where the matrix says.
    image = np.zeros((200, 240, 3), np.uint8)
    image[80, 170] = 255
    crop = roi.crop(image, 256)
    q = m[:, :2] @ np.array([170.0, 80.0]) + m[:, 2]
    peak = np.unravel_index(crop[..., 0].argmax(), crop.shape[:2])
    assert np.hypot(peak[1] - q[0], peak[0] - q[1]) < 1.5


def test_heatmap_refinement_weighted_cell_mean():
    size, hm_size = 256, 64
    logits = np.full((hm_size, hm_size, 3), -20.0)
    # landmark 0: symmetric 3x3 blob around cell (col 20, row 30), peak logit 4
    logits[29:32, 19:22, 0] = 0.0
    logits[30, 20, 0] = 4.0
    # landmark 1: weak blob (peak sigmoid < 0.5) -> not refined
    logits[10, 10, 1] = -1.0
    # landmark 2: blob whose mean is between cells 40 and 41 (col), row 5
    logits[5, 40:42, 2] = 3.0
    xy = np.array([[20 * 4 + 3.0, 30 * 4 + 1.0], [10 * 4 + 2.0, 10 * 4 + 2.0], [40 * 4 + 1.0, 5 * 4 + 2.0]])
    out = refine_with_heatmap(xy, logits, size)
    np.testing.assert_allclose(out[0], [80.0, 120.0], atol=1e-6)
    np.testing.assert_allclose(out[1], xy[1])
    np.testing.assert_allclose(out[2], [40.5 * 4, 5 * 4], atol=1e-6)
    outside = refine_with_heatmap(np.array([[-3.0, 10.0]]), logits[..., :1], size)
    np.testing.assert_allclose(outside, [[-3.0, 10.0]])


def test_preprocessing_follows_the_cards():
    image = np.zeros((1, 2, 2, 3), np.uint8)
    image[..., 0], image[..., 1], image[..., 2] = 0, 51, 255  # B, G, R
    lm = _to_tensor(image, model_card(BLAZEPOSE_LANDMARK_FULL))
    np.testing.assert_allclose(lm[0, 0, 0], [1.0, 0.2, 0.0])  # RGB in [0, 1]
    det = _to_tensor(image, model_card(BLAZEPOSE_DETECTOR))
    np.testing.assert_allclose(det[0, 0, 0], [1.0, 51 / 127.5 - 1, -1.0])  # RGB in [-1, 1]
    assert lm.dtype == det.dtype == np.float32


# ---------------------------------------------------------------------------- the real networks


@pytest.mark.network
def test_landmarks_on_a_drawn_person(landmarker):
    image, joints = mannequin_image()
    kp = landmarker(image)
    assert kp.pixels.shape == (33, 2) and kp.confidence.shape == (33,)
    assert kp.presence > 0.99  # measured 0.9993
    _assert_near(kp, joints)
    # the person faces the viewer: its left side is on the image's right
    assert kp.pixels[JOINT_INDEX["left_shoulder"], 0] > kp.pixels[JOINT_INDEX["right_shoulder"], 0]
    body = [JOINT_INDEX[n] for n in joints]
    assert kp.confidence[body].min() > 0.8 and kp.landmark_presence[body].min() > 0.9
    # world landmarks: metres, origin between the hips, shoulders about 0.4 m above them
    hips = kp.world_m[[JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"]]]
    shoulders = kp.world_m[[JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"]]]
    assert np.linalg.norm(hips.mean(axis=0)) < 0.05
    assert 0.3 < -shoulders[:, 1].mean() < 0.6 and 0.25 < shoulders[0, 0] - shoulders[1, 0] < 0.5


@pytest.mark.network
def test_landmarks_follow_the_person_when_it_moves(landmarker):
    """Shifting and shrinking the drawing moves the answer with it (decoding scale and offset)."""
    image, joints = mannequin_image(scale=0.8, offset=(30.0, 20.0))
    kp = landmarker(image)
    assert kp.presence > 0.9
    _assert_near(kp, joints)


@pytest.mark.network
def test_alignment_points_give_the_hips_and_the_body_axis(landmarker):
    """The landmark network's two alignment points on an upright drawn person: the first on the
    hip centre, the second along the body axis (hips -> shoulders) beyond the head; they follow
    an affine map. (On a person turned in the crop they do not follow the turn fully: measured
    with the mannequin turned 30 / 60 / 90 degrees, their axis turned 12 / 8 / 5 degrees.)"""
    image, joints = mannequin_image(scale=0.8, offset=(26.0, 30.0))
    kp = landmarker(image)
    assert kp.alignment is not None and kp.alignment.shape == (2, 2)
    hip = (joints["left_hip"] + joints["right_hip"]) / 2
    shoulder = (joints["left_shoulder"] + joints["right_shoulder"]) / 2
    torso = np.linalg.norm(shoulder - hip)
    assert np.linalg.norm(kp.alignment[0] - hip) < 0.1 * torso  # measured 0.02
    axis = kp.alignment[1] - kp.alignment[0]
    assert axis @ (shoulder - hip) / (np.linalg.norm(axis) * torso) > np.cos(np.radians(5.0))
    assert np.linalg.norm(axis) > 1.5 * torso  # the body circle holds the head
    m = np.array([[0.5, 0.0, 10.0], [0.0, 0.5, -4.0]])
    assert np.allclose(kp.transformed(m).alignment, kp.alignment * 0.5 + [10.0, -4.0])


@pytest.mark.network
def test_no_person_no_presence(landmarker):
    grey = np.full((256, 256, 3), 128, np.uint8)
    noise = np.random.default_rng(7).integers(0, 256, (256, 256, 3), dtype=np.uint8)
    assert landmarker(grey).presence < 0.05  # measured 0.0005
    assert landmarker(noise).presence < 0.05


@pytest.mark.network
def test_heatmap_refinement_stays_close_to_the_regression(fetched_model_dir, landmarker):
    raw = BlazePoseLandmarker(model_dir=fetched_model_dir[0], refine=False)
    image, joints = mannequin_image()
    a, b = landmarker(image), raw(image)
    body = [JOINT_INDEX[n] for n in joints]
    shift = np.linalg.norm(a.pixels[body] - b.pixels[body], axis=1)
    assert shift.max() < 4.0 and shift.mean() > 0.1  # refinement ran, and moved points by little
    _assert_near(b, joints)
    assert b.world_m is None and a.world_m is not None
    batch = landmarker.run_batch([image, image[:, ::-1].copy()])
    np.testing.assert_array_equal(batch[0].pixels, a.pixels)


@pytest.mark.network
def test_detector_finds_the_drawn_person(detector):
    image = np.full((224, 224, 3), 200, np.uint8)
    joints = draw_mannequin(image, scale=0.6, offset=(40.0, 30.0))
    dets = detector(image)
    assert len(dets) == 1
    d = dets[0]
    hips = (joints["left_hip"] + joints["right_hip"]) / 2
    assert d.score > 0.9  # measured 0.970
    assert np.linalg.norm(d.hip_centre - hips) < 6.0  # measured 2.5
    # the circle around the body: hips to head top is 116 px x 0.6 in the drawing
    assert 0.8 * 116 * 0.6 < d.radius < 1.3 * 116 * 0.6
    assert abs(d.rotation) < 0.15
    assert detector(np.full((224, 224, 3), 200, np.uint8)) == []


@pytest.mark.network
def test_detector_finds_three_people(detector):
    image = np.full((224, 224, 3), 200, np.uint8)
    hips = []
    for offset in [(-20.0, 10.0), (60.0, 100.0), (130.0, 20.0)]:
        j = draw_mannequin(image, scale=0.35, offset=offset)
        hips.append((j["left_hip"] + j["right_hip"]) / 2)
    dets = detector(image)
    assert len(dets) == 3
    found = np.array([d.hip_centre for d in dets])
    dist = np.linalg.norm(found[:, None] - np.array(hips)[None], axis=2)
    assert sorted(dist.argmin(axis=1)) == [0, 1, 2]  # one detection per person
    assert dist.min(axis=1).max() < 12.0  # measured 3.6, 9.3 and 10.0 for 80 px tall people


@pytest.mark.network
@pytest.mark.parametrize("turned", [False, True])
def test_detector_crop_landmarks_back_in_the_image(detector, landmarker, turned):
    """Detector -> rotated crop -> landmarks -> mapped back: lands on the drawn joints, also when
    the image is turned by 90 degrees clockwise (the crop turns the person upright)."""
    image = np.full((224, 224, 3), 200, np.uint8)
    joints = draw_mannequin(image, scale=0.6, offset=(40.0, 30.0))
    if turned:
        image = np.ascontiguousarray(np.rot90(image, -1))
        joints = {n: np.array([223 - p[1], p[0]]) for n, p in joints.items()}
    (d,) = detector(image)
    assert d.rotation == pytest.approx(np.pi / 2 if turned else 0.0, abs=0.15)
    roi = d.roi()
    kp = landmarker(roi.crop(image, 256)).transformed(roi.crop_to_image(256))
    assert kp.presence > 0.9
    _assert_near(kp, joints, factor=0.8)


# ---------------------------------------------------------------------------- bad input


@pytest.mark.network
def test_wrong_images_are_refused(landmarker, detector):
    with pytest.raises(InputError, match=r"\(256, 256, 3\)"):
        landmarker(np.zeros((224, 224, 3), np.uint8))
    with pytest.raises(InputError, match="float32"):
        landmarker(np.zeros((256, 256, 3), np.float32))
    with pytest.raises(InputError, match=r"\(224, 224, 3\)"):
        detector(np.zeros((224, 224), np.uint8))


@pytest.mark.network
def test_corrupt_or_wrong_model_files_are_refused(tmp_path, fetched_model_dir):
    junk = tmp_path / "junk.tflite"
    junk.write_bytes(b"\x00garbage" * 1000)
    with pytest.raises(ModelError, match="not a loadable LiteRT model"):
        BlazePoseLandmarker(junk)
    with pytest.raises(ModelError, match="not found"):
        BlazePoseDetector(tmp_path / "missing.tflite")
    # the landmark network given to the detector: input shape differs from the card
    with pytest.raises(ModelError, match=r"\(1, 224, 224, 3\)"):
        BlazePoseDetector(fetched_model_dir[0] / "pose_landmark_full.tflite")


# ---------------------------------------------------------------------------- model cards lite, full, heavy


@pytest.mark.network
@pytest.mark.parametrize("model, factor", [("lite", 2.0), ("heavy", 1.0)])
def test_lite_and_heavy_find_the_drawn_person_like_full(fetched_model_dir, landmarker, model, factor):
    """Same input, same outputs, same decoding: each card's network on the drawn person lands
    its joints near the drawn ones and near full's. Measured: lite's largest error 9.6 px (right
    wrist; full's tolerances doubled), heavy's 4.4 px (full's tolerances)."""
    other = BlazePoseLandmarker(model=model, model_dir=fetched_model_dir[0], num_threads=1)
    assert other.card.name == f"blazepose_landmark_{model}" and other.model_path.name == f"pose_landmark_{model}.tflite"
    image, joints = mannequin_image()
    kp, ref = other(image), landmarker(image)
    assert kp.pixels.shape == (33, 2) and kp.alignment is not None
    assert kp.presence >= other.card.gates.min_presence
    _assert_near(kp, joints, factor=factor)
    body = [JOINT_INDEX[n] for n in joints]
    assert np.median(np.linalg.norm(kp.pixels[body] - ref.pixels[body], axis=1)) < 6.0
    grey = np.full((256, 256, 3), 128, np.uint8)
    assert other(grey).presence < other.card.gates.min_presence


def test_an_unknown_model_is_refused_before_anything_loads(tmp_path):
    with pytest.raises(ModelError, match="choose one of lite, full, heavy"):
        BlazePoseLandmarker(model="giant", model_dir=tmp_path)
    assert not any(tmp_path.iterdir())


def test_each_card_gives_its_gates_to_the_stage():
    from ergopose.pose.settings import PoseSettings
    from ergopose.pose.models import LANDMARK_MODELS, landmark_card

    base = PoseSettings(max_people=3)
    for name in LANDMARK_MODELS:
        gates = landmark_card(name).gates
        s = base.with_gates(gates)
        assert (s.min_presence, s.min_keypoint_confidence) == (gates.min_presence, gates.min_keypoint_confidence)
        assert s.max_people == 3
    assert base.with_gates(None) is base
    # full's gates are the stage's defaults: results stored before the cards had gates stay valid.
    full = landmark_card("full").gates
    assert (PoseSettings().min_presence, PoseSettings().min_keypoint_confidence) == (
        full.min_presence,
        full.min_keypoint_confidence,
    )
    from ergopose.recon.settings import ReconSettings

    assert ReconSettings().min_confidence == full.min_triangulation_confidence
    # heavy's confidences run lower (docs/models.md): its keypoint gates sit below full's.
    heavy = landmark_card("heavy").gates
    assert heavy.min_keypoint_confidence < full.min_keypoint_confidence
    assert heavy.min_triangulation_confidence < full.min_triangulation_confidence
