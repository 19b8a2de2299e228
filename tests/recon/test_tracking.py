"""Identities over a shift: occlusions, leaving and re-entering, signatures, chunking."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

from ergopose.keypoints import LIMBS
from ergopose.recon import diagnostics as D
from ergopose.recon.pipeline import ShiftReconstruction, TrackFrames
from ergopose.recon.records import People3D
from ergopose.recon.session import reconstruct_session
from ergopose.recon.settings import ReconSettings
from ergopose.sim.synthetic import WorkerScript, walk_workers
from ergopose.recon.track_signatures import HIST_BIN_M, LimbHistogram, limb_lengths, signature_distance
from ergopose.recon.track_contacts import assign_group
from ergopose.recon.track_colour_relink import note_look, recent_look, recent_min_rows
from ergopose.recon.track_records import Track
from ergopose.recon.tracking import Tracker
from tests.recon.conftest import FPS


def test_limb_histogram_median_and_stature(rng):
    h = LimbHistogram()
    x = rng.normal(0.4, 0.01, (1001, len(LIMBS)))
    h.add(x[:500])
    h.add(x[500:])
    h.add(np.full((3, len(LIMBS)), np.nan))  # ignored
    assert np.allclose(h.medians(), np.median(x, axis=0), atol=HIST_BIN_M)
    assert np.all(h.samples == 1001)
    empty = LimbHistogram()
    assert np.all(np.isnan(empty.medians())) and np.isnan(empty.stature_estimate())
    # Stature from a body built with Winter's proportions comes back.
    from ergopose.ergonomics.body import BodyMeasurements, Posture, pose_skeleton

    X = pose_skeleton(BodyMeasurements.from_stature(1.78), Posture())
    h2 = LimbHistogram()
    h2.add(np.repeat(limb_lengths(X)[None], 10, axis=0))
    assert abs(h2.stature_estimate() - 1.78) < 0.005
    assert np.isnan(signature_distance(np.full(16, np.nan), h2.medians()))
    assert signature_distance(h2.medians(), h2.medians()) == 0.0


def _run(scenario, **kw):
    summary, tf = reconstruct_session(scenario.frames, None, fps=FPS, cameras=scenario.cameras, **kw)
    return summary, tf


@pytest.mark.slow
def test_shift_identities_survive_occlusion_and_leaving(shift):
    summary, tf = _run(shift, chunk_frames=240)
    assert summary.workers == ("worker_1", "worker_2", "worker_3", "worker_4")
    mapping = D.match_workers(tf, shift.truth)
    assert sorted(mapping.values()) == [0, 1, 2, 3]
    assert D.identity_switches(tf, shift.truth) == 0
    by_person = {p: w for w, p in mapping.items()}
    # Person 2 left for 25 s (frames 360-660): one identity before and after, no rows in between.
    rows = tf.worker_rows(by_person[2])
    assert rows.frame.min() == 0 and rows.frame.max() == len(shift.frames) - 1
    assert not np.any((rows.frame > 365) & (rows.frame < 655))
    # Person 0 hidden from camera 1 for 5 s: followed throughout, seen by one camera only.
    rows = tf.worker_rows(by_person[0])
    assert len(rows) == len(shift.frames)
    hidden = (rows.frame >= 125) & (rows.frame < 175)
    assert np.all(rows.views[hidden] <= 1) and np.all(np.isnan(rows.raw_points_world[hidden]))
    # Stature estimates within 2 cm of the truth.
    for w, p in mapping.items():
        assert abs(summary.stature_m[f"worker_{w}"] - shift.statures[p]) < 0.02


def _stored(truth: np.ndarray, visible: np.ndarray, rng, sigma=0.01) -> People3D:
    """Stored triangulations: true joints + Gaussian noise, rows only where visible (F, P)."""
    f, p = np.nonzero(visible)
    X = truth[f, p] + rng.normal(0, sigma, truth[f, p].shape)
    return People3D.from_points(f, f / FPS, X, sigma_m=sigma)


def test_relink_uses_body_measurements_and_refuses_to_guess(rng):
    """Two workers leave for 20 s; only one returns, far from where either left. With different
    statures it gets its old identity back; with identical bodies the tracker cannot tell and
    gives it a new one."""
    n = int(40 * FPS)
    for statures, expect_same in (((1.60, 1.90), True), ((1.75, 1.75), False)):
        scripts = [
            WorkerScript(statures[0], np.array([[-2.0, -2.0], [-1.0, 2.0]]), pause_s=5.0),
            WorkerScript(statures[1], np.array([[2.0, -2.0], [1.0, 2.0]]), pause_s=5.0),
        ]
        truth = walk_workers(scripts, n, FPS)
        vis = np.ones((n, 2), bool)
        vis[int(10 * FPS) : int(30 * FPS), :] = False
        vis[int(30 * FPS) :, 0] = False  # worker 0 never comes back
        people = _stored(truth, vis, rng)
        tr = Tracker(ReconSettings(), FPS)
        res = tr.update(people, 0, n)
        fin = tr.finish()
        resolved = {**res.resolved, **fin.resolved}
        f, p = np.nonzero(vis)
        before = {resolved[t] for t, q, fr in zip(res.track, p, f) if q == 1 and fr < 120}
        after = {resolved[t] for t, q, fr in zip(res.track, p, f) if q == 1 and fr > 400}
        assert len(before) == 1 and len(after) == 1
        assert (before == after) is expect_same
        assert len(tr.identities) == (2 if expect_same else 3)


def test_short_spurious_tracks_are_dropped(rng):
    n = int(10 * FPS)
    truth = walk_workers([WorkerScript(1.7, np.array([[0.0, 0.0], [1.0, 1.0]]), pause_s=2.0)], n, FPS)
    ghost = walk_workers([WorkerScript(1.8, np.array([[-2.0, 2.0]]), pause_s=9.0)], n, FPS)
    vis_ghost = np.zeros(n, bool)
    vis_ghost[30:36] = True  # half a second
    people = People3D.concat([_stored(truth, np.ones((n, 1), bool), rng), _stored(ghost, vis_ghost[:, None], rng)])
    people = people.take(np.argsort(people.frame, kind="stable"))
    sr = ShiftReconstruction(ReconSettings(), FPS)
    tf = TrackFrames.concat([sr.push(people, 0, n), sr.finish()])
    assert tf.workers == [1]
    assert len(tf) == n


@pytest.mark.slow
def test_tracker_state_carries_over_chunks_and_pickles(shift):
    from ergopose.recon.triangulate import reconstruct_frames

    people = reconstruct_frames(shift.frames)
    n = len(shift.frames)
    one = Tracker(ReconSettings(), FPS)
    whole = one.update(people, 0, n).track
    cuts = [0, 1, 100, 101, 480, 700, n]
    tr = Tracker(ReconSettings(), FPS)
    parts = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        rows = (people.frame >= a) & (people.frame < b)
        parts.append(tr.update(people.take(rows), a, b).track)
        tr = pickle.loads(pickle.dumps(tr))
    assert np.array_equal(np.concatenate(parts), whole)


def test_people_meeting_and_turning_back_keep_their_identities(rng):
    """Two workers walk up to each other, stand 10 cm apart for 2.5 s (closer than any geometry
    can separate) and walk back. The contact check splits their tracks and gives the
    identities back by body measurements; without it the tracks cross over."""
    n = int(14 * FPS)
    scripts = [
        WorkerScript(1.60, np.array([[-2.0, 0.0], [-0.05, 0.0], [-2.0, 0.6]]), pause_s=(1.0, 2.5, 8.0)),
        WorkerScript(1.90, np.array([[2.0, 0.0], [0.05, 0.0], [2.0, 0.6]]), pause_s=(1.0, 2.5, 8.0)),
    ]
    truth = walk_workers(scripts, n, FPS)
    people = _stored(truth, np.ones((n, 2), bool), rng, sigma=0.01)
    f, p = np.nonzero(np.ones((n, 2), bool))

    def kept(settings):
        tr = Tracker(settings, FPS)
        res = tr.update(people, 0, n)
        fin = tr.finish()
        resolved = {**res.resolved, **fin.resolved}
        ident = np.array([resolved[t] for t in res.track])
        same = all(
            set(ident[(p == q) & (f > n - 24)]) == set(ident[(p == q) & (f < 12)])
            and len(set(ident[(p == q) & (f > n - 24)])) == 1
            for q in (0, 1)
        )
        return same, len(set(ident)), tr.next_group

    same, identities, groups = kept(ReconSettings())
    assert same and identities == 2 and groups >= 1
    assert not kept(ReconSettings(contact_distance_m=0.0))[0]


def test_a_third_worker_met_before_a_contact_is_decided_joins_the_decision(rng):
    """Workers A and B meet and part (a contact: their identities wait for a decision). Before B
    has been seen apart for relink_window_s, B meets C head-on, they stop 10 cm apart for a
    second and turn back, which crosses the tracks of B and C over. The contact of B and C
    must split them too and decide among all three identities; when it is left out (as it
    was: a continuation waiting for a decision was never split again), C keeps B's identity."""
    n = int(18 * FPS)
    scripts = [
        WorkerScript(1.60, np.array([[-2.0, 0.0], [-0.05, 0.0], [-2.0, -0.6]]), pause_s=(1.0, 2.5, 20.0)),
        WorkerScript(
            1.90, np.array([[2.0, 0.0], [0.05, 0.0], [0.05, 1.25], [0.6, -1.0]]), pause_s=(1.0, 2.5, 1.0, 20.0)
        ),
        WorkerScript(1.75, np.array([[0.05, 3.0], [0.05, 1.35], [0.6, 3.0]]), pause_s=(4.6, 1.0, 20.0)),
    ]
    truth = walk_workers(scripts, n, FPS)
    people = _stored(truth, np.ones((n, 3), bool), rng, sigma=0.01)
    f, p = np.nonzero(np.ones((n, 3), bool))
    tr = Tracker(ReconSettings(), FPS)
    res = tr.update(people, 0, n)
    resolved = {**res.resolved, **tr.finish().resolved}
    ident = np.array([resolved[t] for t in res.track])
    first = [set(ident[(p == q) & (f < 12)]) for q in range(3)]
    last = [set(ident[(p == q) & (f > n - 24)]) for q in range(3)]
    assert all(len(x) == 1 for x in first + last) and len(set(ident)) == 3
    assert last == first
    assert tr.next_group == 2  # A-B, then A-B-C


def test_a_contact_is_decided_by_the_continuations_that_were_seen():
    """assign_group: continuations compared with every identity of their group; one that ended
    unseen (a NaN row) gives up its identity to a continuation whose measurements claim it,
    and takes the one left over; differences within the margin keep the identities."""
    nan = np.nan
    # Continuation 0 ended unseen; 1 and 2 fit identities 7 and 5 (the provisional 7, 5, 9).
    cost = np.array([[nan, nan, nan], [0.004, 0.030, 0.020], [0.030, 0.003, 0.025]])
    assert assign_group(cost, [7, 5, 9], margin=0.005) == [9, 7, 5]
    # The same claims, but within the margin: nobody changes.
    cost = np.array([[nan, nan, nan], [0.008, 0.010, 0.020], [0.030, 0.008, 0.010]])
    assert assign_group(cost, [7, 5, 9], margin=0.005) == [7, 5, 9]
    # Two seen continuations crossed over; the unseen one keeps its identity.
    cost = np.array([[0.030, 0.004, nan], [0.004, 0.030, nan], [nan, nan, nan]])
    cost[:2, 2] = 0.05
    assert assign_group(cost, [1, 2, 3], margin=0.005) == [2, 1, 3]
    # Nothing seen: nothing changes.
    assert assign_group(np.full((2, 2), nan), [4, 6], margin=0.005) == [4, 6]


def test_coasting_prediction_holds_the_height(rng):
    """The body centre's height drops when a worker bends, which is no motion to predict: a
    track coasting after such a drop keeps its last height and moves only horizontally."""
    n = int(8 * FPS)
    truth = walk_workers([WorkerScript(1.75, np.array([[-2.0, 0.0], [2.0, 0.0]]), pause_s=0.0)], n, FPS)
    bend0, gone0 = int(4 * FPS), int(5 * FPS)
    truth[bend0:gone0, 0, :, 2] -= 0.4  # the whole body 0.4 m lower for a second
    vis = np.zeros((n, 1), bool)
    vis[:gone0] = True  # then unseen (coasting) to the end
    tr = Tracker(ReconSettings(max_coast_s=2.0), FPS)
    res = tr.update(_stored(truth, vis, rng, sigma=0.002), 0, n)
    c = res.centres
    coast = c[(c[:, 0] > gone0) & (c[:, 0] < gone0 + 1.5 * FPS)]
    assert len(coast) > 10
    assert np.ptp(coast[:, 4]) < 1e-9  # height held
    assert np.ptp(coast[:, 2]) > 0.1  # still moving along x at its last horizontal speed


def test_a_full_roster_keeps_a_returning_worker_whose_measurements_drifted(rng):
    """One worker stays in view; the other leaves for 20 s and comes back measuring 30 cm taller
    (a signature far beyond relink_max_signature_m, as noisy keypoints give). Without a roster
    (expected_workers 0), or with a roster of 3 of whom only 2 have been seen, the tracker refuses
    to guess and opens a third identity; with expected_workers = 2 both
    workers already have identities and the returning one is the only lost worker who could
    have walked there, so it gets its identity back. A third person entering while both
    workers are followed still gets a new identity."""
    n = int(40 * FPS)
    paths = [np.array([[-2.0, -2.0], [-1.0, 2.0]]), np.array([[2.0, -2.0], [1.0, 2.0]])]
    before = walk_workers(
        [WorkerScript(1.75, paths[0], pause_s=5.0), WorkerScript(1.60, paths[1], pause_s=5.0)], n, FPS
    )
    after = walk_workers([WorkerScript(1.75, paths[0], pause_s=5.0), WorkerScript(1.90, paths[1], pause_s=5.0)], n, FPS)
    truth = np.where((np.arange(n) < 20 * FPS)[:, None, None, None], before, after)
    vis = np.ones((n, 2), bool)
    vis[int(10 * FPS) : int(30 * FPS), 1] = False
    people = _stored(truth, vis, rng)
    for expected, identities in ((0, 3), (3, 3), (2, 2)):
        tr = Tracker(ReconSettings(expected_workers=expected), FPS)
        res = tr.update(people, 0, n)
        fin = tr.finish()
        resolved = {**res.resolved, **fin.resolved}
        f, p = np.nonzero(vis)
        ids = {q: {resolved[t] for t, qq, fr in zip(res.track, p, f) if qq == q and fr > 400} for q in (0, 1)}
        assert len(tr.identities) == identities, expected
        first = {resolved[t] for t, qq, fr in zip(res.track, p, f) if qq == 1 and fr < 100}
        assert (ids[1] == first) is (expected == 2)
    # Three people, two of them followed all along: the third is someone else.
    third = walk_workers([WorkerScript(1.80, np.array([[0.0, -2.5], [0.0, 2.5]]), pause_s=5.0)], n, FPS)
    truth3 = np.concatenate([before, third], axis=1)
    vis3 = np.ones((n, 3), bool)
    vis3[: int(20 * FPS), 2] = False
    tr = Tracker(ReconSettings(expected_workers=2), FPS)
    tr.update(_stored(truth3, vis3, rng), 0, n)
    tr.finish()
    assert len(tr.identities) == 3


def _dressed(people: People3D, person: np.ndarray, colours: np.ndarray, rng, noise: float = 3.0) -> People3D:
    """The rows with clothing colours: colours[person of the row] + Gaussian noise (Lab units)."""
    look = colours[person] + rng.normal(0.0, noise, (len(person), colours.shape[1]))
    return dataclasses.replace(people, appearance=look)


#: Two workers' clothing colours (L*a*b*, OpenCV's 8-bit scale, upper body then thighs): a red and
#: a blue shirt over the same grey trousers.
RED_AND_BLUE = np.array([[136.0, 208.0, 195.0, 120.0, 128.0, 128.0], [82.0, 207.0, 20.0, 120.0, 128.0, 128.0]])


def test_clothes_keep_identities_where_body_measurements_cannot(rng):
    """Two workers of the same build walk up to each other, stand 10 cm apart for 2.5 s and walk
    back. Their limb lengths cannot tell them apart, so without colours the tracks cross over at
    the turn; their shirts (red, blue) keep each worker's identity."""
    n = int(14 * FPS)
    scripts = [
        WorkerScript(1.75, np.array([[-2.0, 0.0], [-0.05, 0.0], [-2.0, 0.6]]), pause_s=(1.0, 2.5, 8.0)),
        WorkerScript(1.75, np.array([[2.0, 0.0], [0.05, 0.0], [2.0, 0.6]]), pause_s=(1.0, 2.5, 8.0)),
    ]
    truth = walk_workers(scripts, n, FPS)
    plain = _stored(truth, np.ones((n, 2), bool), rng, sigma=0.01)
    f, p = np.nonzero(np.ones((n, 2), bool))
    dressed = _dressed(plain, p, RED_AND_BLUE, rng)

    def kept(people):
        tr = Tracker(ReconSettings(), FPS)
        res = tr.update(people, 0, n)
        resolved = {**res.resolved, **tr.finish().resolved}
        ident = np.array([resolved[t] for t in res.track])
        return all(
            set(ident[(p == q) & (f > n - 24)]) == set(ident[(p == q) & (f < 12)])
            and len(set(ident[(p == q) & (f > n - 24)])) == 1
            for q in (0, 1)
        ), len(set(ident))

    assert kept(dressed) == (True, 2)
    assert not kept(plain)[0]


def _two_of_one_build(n: int) -> np.ndarray:
    """(n, 2, 33, 3) two workers of 1.75 m walking apart on two paths, pausing 5 s at each end."""
    scripts = [
        WorkerScript(1.75, np.array([[-2.0, -2.0], [-1.0, 2.0]]), pause_s=5.0),
        WorkerScript(1.75, np.array([[2.0, -2.0], [1.0, 2.0]]), pause_s=5.0),
    ]
    return walk_workers(scripts, n, FPS)


def test_a_returning_worker_is_known_by_the_clothes(rng):
    """Two workers of the same build leave for 20 s; only one returns, far from where either left.
    Limb lengths cannot tell (a new identity, test_relink_uses_body_measurements_and_refuses_to_guess);
    the blue shirt gives the blue worker's identity back. A worker in a green shirt coming back
    instead is someone new."""
    n = int(40 * FPS)
    truth = _two_of_one_build(n)
    vis = np.ones((n, 2), bool)
    vis[int(10 * FPS) : int(30 * FPS), :] = False
    vis[int(30 * FPS) :, 0] = False  # worker 0 never comes back
    f, p = np.nonzero(vis)
    green = np.array([150.0, 80.0, 170.0, 120.0, 128.0, 128.0])
    for returning, expect_same in ((RED_AND_BLUE[1], True), (green, False)):
        colours = np.stack([RED_AND_BLUE[0], RED_AND_BLUE[1], returning])
        person = np.where((p == 1) & (f >= int(30 * FPS)), 2, p)
        people = _dressed(_stored(truth, vis, rng), person, colours, rng)
        tr = Tracker(ReconSettings(), FPS)
        res = tr.update(people, 0, n)
        resolved = {**res.resolved, **tr.finish().resolved}
        before = {resolved[t] for t, q, fr in zip(res.track, p, f) if q == 1 and fr < 120}
        after = {resolved[t] for t, q, fr in zip(res.track, p, f) if q == 1 and fr > 400}
        assert len(before) == 1 and len(after) == 1
        assert (before == after) is expect_same
        assert len(tr.identities) == (2 if expect_same else 3)


def _handover_people(rng, others_seen_s: float, switch_s: float = 13.0) -> tuple[People3D, np.ndarray, np.ndarray]:
    """Worker 0 walks one path for 30 s; worker 1, of the same build, walks another and is seen
    for the first ``others_seen_s`` seconds. From ``switch_s`` on, the person on worker 0's path
    wears worker 1's blue shirt: worker 1 stepped into worker 0's place out of sight (worker 0
    gone), which no geometry can show. Returns (the rows, each row's person, frame)."""
    n = int(30 * FPS)
    truth = _two_of_one_build(n)
    vis = np.ones((n, 2), bool)
    vis[int(others_seen_s * FPS) :, 1] = False
    f, p = np.nonzero(vis)
    wearer = np.where((p == 0) & (f >= int(switch_s * FPS)), 1, p)
    return _dressed(_stored(truth, vis, rng), wearer, RED_AND_BLUE, rng), p, f


def _handover(rng, others_seen_s: float, switch_s: float = 13.0, colour_relink: bool = True):
    """The tracker on :func:`_handover_people`: (rows' identities, person, frame, tracker)."""
    people, p, f = _handover_people(rng, others_seen_s, switch_s)
    tr = Tracker(ReconSettings(colour_relink=colour_relink), FPS)
    res = tr.update(people, 0, int(30 * FPS))
    resolved = {**res.resolved, **tr.finish().resolved}
    ident = np.array([resolved[t] for t in res.track])
    return ident, p, f, tr


def test_a_track_wearing_a_lost_workers_clothes_hands_the_person_on(rng):
    """The blue worker, lost since 8 s (its track ended at 10 s, max_coast_s), turns up on the
    red worker's path at 13 s. Without the colour check the red identity keeps the blue worker
    for the rest of the shift (the rows after 13 s counted as the red worker's); with it, the
    track hands the person on to the blue identity once a relink window of colours says so, and
    the red identity is lost."""
    ident, p, f, tr = _handover(rng, others_seen_s=8.0)
    red = set(ident[(p == 0) & (f < 120)])
    blue = set(ident[(p == 1) & (f < 96)])
    assert len(red) == 1 and len(blue) == 1 and red != blue
    late = (p == 0) & (f >= int(17 * FPS))
    assert set(ident[late]) == blue
    # Until the colours of a window say so, the rows stay with the red identity: the hand-on
    # comes between 1 s (RECENT_MIN_S) and relink_window_s after the change.
    changed = f[(p == 0) & np.isin(ident, list(blue))].min()
    assert int(14 * FPS) <= changed <= int(16 * FPS) + 1
    assert len(tr.identities) == 2
    # Without the check the red identity keeps the blue worker.
    ident_off, *_ = _handover(np.random.default_rng(0), others_seen_s=8.0, colour_relink=False)
    assert set(ident_off[late]) == red


def test_the_recent_colour_needs_a_second_of_rows_at_any_frame_rate(rng):
    """30 rows of colour make a recent mean at 12 fps (2.5 s of frames) but not at 60 fps (0.5 s):
    the mean a hand-on rests on averages as long at any frame rate."""
    t = Track(
        id=0, first_frame=0, first_pos=np.zeros(3), pos=np.zeros(3), vel=np.zeros(3), last_frame=0, last_update_frame=0
    )
    for f in range(30):
        note_look(t, f, RED_AND_BLUE[1] + rng.normal(0.0, 3.0, 6), window_frames=180)
    at12 = recent_look(t, recent_min_rows(12.0))
    assert np.all(np.abs(at12 - RED_AND_BLUE[1]) < 3.0)
    assert np.all(np.isnan(recent_look(t, recent_min_rows(60.0))))
    # The window drops what is older than it.
    note_look(t, 200, RED_AND_BLUE[0], window_frames=180)
    assert t.recent_frames == list(range(21, 30)) + [200]


def test_a_followed_workers_colours_do_not_take_them_from_their_track(rng):
    """The same change of shirt while the blue worker is still seen elsewhere: the blue identity
    is being followed, so the colours alone do not move it; the red identity goes on (the two
    tracks decide nothing about each other's person). And a worker whose shirt never changes
    keeps one identity over the whole walk."""
    ident, p, f, tr = _handover(rng, others_seen_s=30.0)
    assert len(set(ident[p == 0])) == 1 and len(set(ident[p == 1])) == 1
    assert len(tr.identities) == 2
    ident, p, f, tr = _handover(rng, others_seen_s=8.0, switch_s=99.0)
    assert len(set(ident[p == 0])) == 1
    assert len(tr.identities) == 2


def test_a_hand_on_gives_one_row_per_person_and_frame(rng):
    """Through the whole reconstruction (tracking, identities, smoothing): the frame of the hand-on
    has one row for the person on the red worker's path, the red identity's rows end there and the
    blue identity's go on from the next frame, and the table holds no frame twice per identity."""
    n = int(30 * FPS)
    people, _, _ = _handover_people(rng, others_seen_s=8.0)
    settings = ReconSettings(body_model=False)
    shift = ShiftReconstruction(settings, FPS)
    tf = TrackFrames.concat([shift.push(people, 0, n), shift.finish()])
    assert len(np.unique(tf.frame * 10 + tf.worker)) == len(tf.frame)
    # In uneven chunks, pickled between them (the hand-on's window spans a cut): the same table.
    shift, parts = ShiftReconstruction(settings, FPS), []
    cuts = [0, 100, 170, 171, 185, n]
    for a, b in zip(cuts[:-1], cuts[1:]):
        parts.append(shift.push(people.take((people.frame >= a) & (people.frame < b)), a, b))
        shift = pickle.loads(pickle.dumps(shift))
    chunked = TrackFrames.concat(parts + [shift.finish()])
    assert np.array_equal(chunked.worker, tf.worker) and np.array_equal(chunked.frame, tf.frame)
    assert np.array_equal(chunked.points_world, tf.points_world, equal_nan=True)
    first = tf.frame == 0
    x0 = np.nanmean(tf.raw_points_world[first, :, 0], axis=1)  # worker 0 starts at x = -2
    red_w = int(tf.worker[first][np.argmin(x0)])
    blue_w = [w for w in tf.workers if w != red_w]
    assert len(blue_w) == 1
    red, blue = tf.worker_rows(red_w), tf.worker_rows(blue_w[0])
    back = blue.frame[blue.frame > int(11 * FPS)]
    assert len(back) and red.frame.max() + 1 == back.min()
    assert back.max() == n - 1 and np.all(np.diff(back) == 1)
    on_path = np.concatenate([red.frame[red.frame >= int(13 * FPS)], back])
    assert np.array_equal(np.sort(on_path), np.arange(int(13 * FPS), n))
