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
from scipy.spatial import cKDTree

from .kalman import mahalanobis_sq

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

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


_NEIGHBOURS = 4  # detections asked of the KD-tree per track at first; a track with this many in its gate asks again


def candidate_pairs(track_pos: FloatArray, radius: FloatArray, det_tree: cKDTree) -> tuple[IntArray, IntArray]:
    """(track, detection) index pairs closer than the track's radius (within it: ``<=``).

    One vectorised query asks the detections' KD-tree for each track's few nearest detections (within the widest
    radius), which is all of a track's candidates unless the last of them is inside its radius too: those few
    tracks ask again with a ball query of their own radius. So one uncertain track does not widen every other
    track's search, and a crowd costs one query rather than a tree per group of similar radii."""
    n_t, n_d = len(track_pos), det_tree.n
    if n_t == 0 or n_d == 0:
        return np.empty(0, np.intp), np.empty(0, np.intp)
    k = min(_NEIGHBOURS, n_d)
    bound = float(radius.max()) * (1.0 + 1e-9) + 1e-12  # the query's bound is strict; the radius is not
    dist, idx = det_tree.query(track_pos, k=k, distance_upper_bound=bound)
    dist, idx = dist.reshape(n_t, k), idx.reshape(n_t, k)
    within = dist <= radius[:, None]
    again = np.flatnonzero(within[:, -1]) if k < n_d else np.empty(0, np.intp)
    within[again] = False
    ti, slot = np.nonzero(within)
    dj = idx[ti, slot]
    if len(again):
        found = det_tree.query_ball_point(track_pos[again], r=radius[again])
        counts = [len(f) for f in found]
        ti = np.concatenate([ti, np.repeat(again, counts)])
        dj = np.concatenate([dj, np.concatenate(found).astype(np.intp)])
    return ti.astype(np.intp), dj.astype(np.intp)


def _components(a: list[int], b: list[int]) -> IntArray:
    """The connected component of each edge ``a[k]–b[k]`` of a graph (numbered 0, 1, … in order of first edge).

    Union–find with path halving in plain Python: the edges it is given are the tangled rest of an assignment,
    a handful at 200 people and about a hundred at a thousand, for which scipy's sparse-graph machinery costs more
    in building its matrices than the search itself."""
    parent: dict[int, int] = {}

    def root(x: int) -> int:
        while (up := parent.setdefault(x, x)) != x:
            parent[x] = x = parent[up]
        return x

    for u, v in zip(a, b, strict=True):
        ru, rv = root(u), root(v)
        if ru != rv:
            parent[ru] = rv
    numbers: dict[int, int] = {}
    return np.array([numbers.setdefault(root(u), len(numbers)) for u in a], dtype=np.intp)


def _rank_in_component(comp: IntArray, node: IntArray, n_nodes: int) -> tuple[IntArray, IntArray]:
    """For each edge, its node's index among its component's distinct nodes (in node order), and each
    component's number of distinct nodes."""
    key = comp * n_nodes + node
    unique, inverse = np.unique(key, return_inverse=True)
    comp_of = unique // n_nodes
    first = np.searchsorted(comp_of, comp_of, side="left")
    return (inverse - first[inverse]).astype(np.intp), np.bincount(comp_of)


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
        comp = _components(r_t.tolist(), (r_d + n_t).tolist())
        rank_t, size_t = _rank_in_component(comp, r_t, n_t)
        rank_d, size_d = _rank_in_component(comp, r_d, n_d)
        order = np.argsort(comp, kind="stable")
        bounds = np.flatnonzero(np.diff(comp[order])) + 1
        for edges in np.split(order, bounds):
            c = comp[edges[0]]
            block = np.full((size_t[c], size_d[c]), _UNMATCHABLE)
            rows, cols = rank_t[edges], rank_d[edges]
            block[rows, cols] = r_cost[edges]
            r, k = linear_sum_assignment(block)
            ok = block[r, k] < _UNMATCHABLE
            pick = np.full(block.shape, -1, np.intp)
            pick[rows, cols] = edges
            chosen = pick[r[ok], k[ok]]
            match_t.append(r_t[chosen])
            match_d.append(r_d[chosen])

    tracks = np.concatenate(match_t).astype(np.intp)
    detections = np.concatenate(match_d).astype(np.intp)
    taken_t = np.zeros(n_t, bool)
    taken_t[tracks] = True
    taken_d = np.zeros(n_d, bool)
    taken_d[detections] = True
    missed, new = np.flatnonzero(~taken_t), np.flatnonzero(~taken_d)
    return Assignment(tracks, detections, missed, new)
