"""Gating and assignment: the clustered solution is the dense Hungarian one, and classes never mix."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from agentic_core.perception.association import _components, associate, candidate_pairs
from agentic_core.perception.kalman import mahalanobis_sq

GATE = 13.8


def dense_reference(tp, P, tc, z, R, dc):
    """linear_sum_assignment on the full T×M matrix (gated-out pairs unmatchable): the answer to agree with."""
    big = 1e9
    cost = np.full((len(tp), len(z)), big)
    for i in range(len(tp)):
        for j in range(len(z)):
            if tc[i] == dc[j]:
                d2, logdet = mahalanobis_sq((z[j] - tp[i])[None], (P[i] + R[j])[None])
                if d2[0] <= GATE:
                    cost[i, j] = d2[0] + logdet[0]
    if not (len(tp) and len(z)):
        return set(), cost
    rows, cols = linear_sum_assignment(cost)
    return {(int(r), int(c)) for r, c in zip(rows, cols, strict=True) if cost[r, c] < big}, cost


def test_clustered_assignment_equals_the_dense_hungarian() -> None:
    rng = np.random.default_rng(0)
    for _ in range(300):
        n_t, n_d = int(rng.integers(0, 30)), int(rng.integers(0, 30))
        tp, z = rng.uniform(0, 5, (n_t, 2)), rng.uniform(0, 5, (n_d, 2))
        P = np.array([np.eye(2) * rng.uniform(0.005, 0.05) for _ in range(n_t)]).reshape(n_t, 2, 2)
        R = np.array([np.eye(2) * rng.uniform(0.005, 0.05) for _ in range(n_d)]).reshape(n_d, 2, 2)
        tc, dc = rng.integers(0, 2, n_t), rng.integers(0, 2, n_d)
        got = associate(tp, P, tc, z, R, dc, gate=GATE, max_radius_m=5.0)
        pairs = set(zip(got.tracks.tolist(), got.detections.tolist(), strict=True))
        ref, cost = dense_reference(tp, P, tc, z, R, dc)
        assert len(pairs) == len(ref)
        assert np.isclose(sum(cost[i, j] for i, j in pairs), sum(cost[i, j] for i, j in ref))
        assert set(got.missed_tracks.tolist()) == set(range(n_t)) - {i for i, _ in pairs}
        assert set(got.new_detections.tolist()) == set(range(n_d)) - {j for _, j in pairs}


def test_candidate_pairs_are_every_pair_within_the_tracks_radius() -> None:
    """Against brute force, dense scenes included: there most tracks have more detections in their radius than
    the first query asks for, and ask again."""
    rng = np.random.default_rng(1)
    for case in range(200):
        n_t, n_d = int(rng.integers(0, 40)), int(rng.integers(0, 40))
        side = 3.0 if case % 2 else 30.0
        tp, z = rng.uniform(0, side, (n_t, 2)), rng.uniform(0, side, (n_d, 2))
        radius = rng.uniform(0.1, 5.0, n_t)
        ti, dj = candidate_pairs(tp, radius, cKDTree(z.reshape(n_d, 2)))
        assert ti.dtype == dj.dtype == np.intp
        got = sorted(zip(ti.tolist(), dj.tolist(), strict=True))
        dist = np.hypot(*(tp[:, None, :] - z[None, :, :]).transpose(2, 0, 1)).reshape(n_t, n_d)
        assert got == sorted(zip(*np.nonzero(dist <= radius[:, None]), strict=True))


def test_components_are_the_connected_components() -> None:
    rng = np.random.default_rng(2)
    for _ in range(200):
        n, m = int(rng.integers(1, 30)), int(rng.integers(1, 40))
        a, b = rng.integers(0, n, m), rng.integers(0, n, m)
        comp = _components(a.tolist(), b.tolist())
        _, label = connected_components(coo_matrix((np.ones(m), (a, b)), shape=(n, n)), directed=False)
        pairs = set(zip(comp.tolist(), label[a].tolist(), strict=True))
        assert len(pairs) == len(set(comp.tolist())) == len(set(label[a].tolist()))  # the same partition of edges
        first_seen = list(dict.fromkeys(comp.tolist()))
        assert first_seen == list(range(len(first_seen)))  # numbered in order of first edge


def test_classes_never_mix_and_far_detections_start_tracks() -> None:
    tp = np.array([[0.0, 0.0]])
    P = np.array([np.eye(2) * 0.01])
    z = np.array([[0.01, 0.0], [0.02, 0.01], [30.0, 0.0]])
    R = np.array([np.eye(2) * 0.01] * 3)
    got = associate(tp, P, np.array([1]), z, R, np.array([0, 1, 1]), gate=GATE, max_radius_m=5.0)
    assert got.tracks.tolist() == [0] and got.detections.tolist() == [1]  # the person took the person
    assert got.new_detections.tolist() == [0, 2]


def test_an_uncertain_track_does_not_steal_a_certain_tracks_detection() -> None:
    """Both tracks could take the detection; the likelihood (d² + ln det S) prefers the sharp one."""
    tp = np.array([[0.0, 0.0], [0.3, 0.0]])
    P = np.array([np.eye(2) * 0.0025, np.eye(2) * 1.0])  # 5 cm vs 1 m
    z = np.array([[0.05, 0.0]])
    R = np.array([np.eye(2) * 0.0025])
    got = associate(tp, P, np.zeros(2, int), z, R, np.zeros(1, int), gate=GATE, max_radius_m=5.0)
    assert got.tracks.tolist() == [0]


def test_tracking_score_counts() -> None:
    from agentic_core.perception.metrics import TrackingScore

    score = TrackingScore(max_distance_m=1.0)
    score.add({"a": (0.0, 0.0)}, {"T1": (0.0, 0.0)})
    score.add({"b": (0.0, 0.0)}, {"T1": (0.0, 0.0)})  # T1 now on b
    score.add({"a": (0.0, 0.0), "b": (0.2, 0.0)}, {"T1": (0.1, 0.0)})  # both last had T1: only one keeps it
    assert score.matches == 3 and score.precision <= 1.0
    assert score.id_switches == 0
    score.add({"a": (0.0, 0.0)}, {"T2": (0.0, 0.3)})
    assert score.id_switches == 1 and score.truth_count == 5 and score.hypothesis_count == 4
    assert 0.0 < score.recall < 1.0 and score.rmse_m == pytest.approx(((0.01 + 0.09) / 4) ** 0.5)
