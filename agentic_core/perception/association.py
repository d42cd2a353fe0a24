"""Which detection belongs to which track: Mahalanobis gating, then the Hungarian method per cluster.

A dense T×M cost matrix for a thousand people costs tens of milliseconds to solve, and almost all of it is
"impossible". So candidate pairs come from a KD-tree (within each track's gate radius, same class) and are gated
on the squared Mahalanobis distance of the residual (chi-square with 2 degrees of freedom). A cluster with one
track or one detection (a star, usually 1×1) is solved outright by its cheapest pair; the tangled rest is split
into connected components, each solved exactly with ``scipy.optimize.linear_sum_assignment`` (the Hungarian
method). The cost of a pair is ``d² + ln det S``, the negative log-likelihood up
to a constant, so an uncertain (coasting or lost) track does not win a detection merely because its gate is wide.

>>> tracks = np.array([[0.0, 0.0], [1.0, 0.0]])
>>> P = np.array([np.eye(2) * 0.01] * 2)
>>> z = np.array([[1.02, 0.01], [0.01, -0.02], [9.0, 9.0]])
>>> R = np.array([np.eye(2) * 0.01] * 3)
>>> a = associate(tracks, P, np.zeros(2, int), z, R, np.zeros(3, int), gate=13.8, max_radius_m=5.0)
>>> sorted(zip(a.tracks.tolist(), a.detections.tolist())), a.new_detections.tolist()
([(0, 1), (1, 0)], [2])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .kalman import mahalanobis_sq

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

_SMALLEST_RADIUS_M = 0.5  # gate radii are grouped by doublings from this
_UNMATCHABLE = 1e9


@dataclass(frozen=True)
class Assignment:
    """Matched pairs (``tracks[k]`` took ``detections[k]``), the tracks left without one, the detections left over."""

    tracks: IntArray
    detections: IntArray
    missed_tracks: IntArray
    new_detections: IntArray


def _largest_eigenvalue(M: FloatArray) -> FloatArray:
    a, b, d = M[:, 0, 0], M[:, 0, 1], M[:, 1, 1]
    out: FloatArray = (a + d) / 2.0 + np.sqrt(((a - d) / 2.0) ** 2 + b * b)
    return out


def _rank_within(label: IntArray) -> IntArray:
    """Each item's index among the items with the same label (0, 1, … per label, in the items' order)."""
    rank = np.empty(len(label), np.intp)
    order = np.argsort(label, kind="stable")
    sorted_label = label[order]
    starts = np.r_[0, np.flatnonzero(np.diff(sorted_label)) + 1]
    run_start = np.repeat(starts, np.diff(np.r_[starts, len(order)]))
    rank[order] = np.arange(len(order)) - run_start
    return rank


def candidate_pairs(track_pos: FloatArray, radius: FloatArray, det_tree: cKDTree) -> tuple[IntArray, IntArray]:
    """(track, detection) index pairs closer than the track's radius. Tracks are queried in groups of similar
    radius (doubling from 0.5 m), so one uncertain track does not widen every other track's search."""
    tier = np.ceil(np.log2(np.maximum(radius, 1e-9) / _SMALLEST_RADIUS_M)).clip(0, None).astype(np.intp)
    ti: list[IntArray] = []
    dj: list[IntArray] = []
    for level in np.unique(tier):
        rows = np.flatnonzero(tier == level)
        pairs = cKDTree(track_pos[rows]).sparse_distance_matrix(
            det_tree, float(radius[rows].max()), output_type="ndarray"
        )
        if len(pairs):
            i = rows[pairs["i"]]
            within = pairs["v"] <= radius[i]
            ti.append(i[within])
            dj.append(pairs["j"][within].astype(np.intp))
    if not ti:
        return np.empty(0, np.intp), np.empty(0, np.intp)
    return np.concatenate(ti), np.concatenate(dj)


def associate(
    track_pos: FloatArray,
    track_cov: FloatArray,
    track_class: IntArray,
    z: FloatArray,
    R: FloatArray,
    det_class: IntArray,
    *,
    gate: float,
    max_radius_m: float,
) -> Assignment:
    """Match T predicted tracks (positions T×2, covariances T×2×2) to M measurements (M×2, M×2×2), same class only.

    ``gate`` is the squared-Mahalanobis bound (13.8: 99.9 % of a true match's residuals); ``max_radius_m`` caps
    any gate in metres, however uncertain the track.
    """
    n_t, n_d = len(track_pos), len(z)
    empty = np.empty(0, np.intp)
    if n_t == 0 or n_d == 0:
        return Assignment(empty, empty, np.arange(n_t), np.arange(n_d))
    r_max = float(_largest_eigenvalue(R).max())
    radius = np.minimum(np.sqrt(gate * (_largest_eigenvalue(track_cov) + r_max)), max_radius_m)
    ti, dj = candidate_pairs(track_pos, radius, cKDTree(z))
    same = track_class[ti] == det_class[dj]
    ti, dj = ti[same], dj[same]
    d2, logdet = mahalanobis_sq(z[dj] - track_pos[ti], track_cov[ti] + R[dj])
    inside = d2 <= gate
    ti, dj, cost = ti[inside], dj[inside], (d2 + logdet)[inside]
    if len(ti) == 0:
        return Assignment(empty, empty, np.arange(n_t), np.arange(n_d))

    # Most detections gate to one track and most tracks to one detection. A track whose detections gate to it
    # alone (a 1×k star, 1×1 included) takes its cheapest; likewise a detection whose tracks have no other. What
    # is left, the tangled clusters, is split into connected components, each solved exactly.
    deg_t = np.bincount(ti, minlength=n_t)
    deg_d = np.bincount(dj, minlength=n_d)
    track_star = np.bincount(ti, weights=(deg_d[dj] == 1), minlength=n_t) == deg_t  # all its detections exclusive
    det_star = np.bincount(dj, weights=(deg_t[ti] == 1), minlength=n_d) == deg_d
    match_t: list[IntArray] = []
    match_d: list[IntArray] = []
    for star, key in ((track_star[ti], ti), (det_star[dj] & ~track_star[ti], dj)):
        rows = np.flatnonzero(star)
        order = rows[np.lexsort((cost[rows], key[rows]))]
        first = order[np.r_[True, np.diff(key[order]) != 0]] if len(order) else order
        match_t.append(ti[first])
        match_d.append(dj[first])

    rest = np.flatnonzero(~track_star[ti] & ~det_star[dj])
    if len(rest):
        r_t, r_d, r_cost = ti[rest], dj[rest], cost[rest]
        graph = coo_matrix((np.ones(len(rest)), (r_t, r_d + n_t)), shape=(n_t + n_d, n_t + n_d))
        n_comp, label = connected_components(graph, directed=False)
        n_tracks_in = np.bincount(label[:n_t][np.unique(r_t)], minlength=n_comp)
        n_dets_in = np.bincount(label[n_t:][np.unique(r_d)], minlength=n_comp)
        in_rest_t = np.zeros(n_t, bool)
        in_rest_t[r_t] = True
        in_rest_d = np.zeros(n_d, bool)
        in_rest_d[r_d] = True
        rank_t = _rank_within(np.where(in_rest_t, label[:n_t], -1))
        rank_d = _rank_within(np.where(in_rest_d, label[n_t:], -1))
        edge_label = label[r_t]
        order = np.argsort(edge_label, kind="stable")
        bounds = np.flatnonzero(np.diff(edge_label[order])) + 1
        for edges in np.split(order, bounds):
            comp = edge_label[edges[0]]
            block = np.full((n_tracks_in[comp], n_dets_in[comp]), _UNMATCHABLE)
            rows, cols = rank_t[r_t[edges]], rank_d[r_d[edges]]
            block[rows, cols] = r_cost[edges]
            r, c = linear_sum_assignment(block)
            ok = block[r, c] < _UNMATCHABLE
            pick = np.full(block.shape, -1, np.intp)
            pick[rows, cols] = edges
            chosen = pick[r[ok], c[ok]]
            match_t.append(r_t[chosen])
            match_d.append(r_d[chosen])

    tracks = np.concatenate(match_t).astype(np.intp)
    detections = np.concatenate(match_d).astype(np.intp)
    missed = np.setdiff1d(np.arange(n_t), tracks, assume_unique=True)
    new = np.setdiff1d(np.arange(n_d), detections, assume_unique=True)
    return Assignment(tracks, detections, missed, new)
