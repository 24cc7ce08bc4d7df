"""The compiled clearance test between triangle sets, against FCL's distance (the reference)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planners.kernels.rigid import rotation_matrix
from planners.kernels.triangles import (
    LEAF_SIZE,
    STACK_ROWS,
    build_tree,
    sets_apart,
    sets_clearance,
    sphere_nodes,
    triangles_within,
)

fcl = pytest.importorskip("fcl", reason="the reference distance is FCL's (pip install samplergym[mesh])")


def _object(vertices, faces):
    m = fcl.BVHModel()
    m.beginModel(len(vertices), len(faces))
    m.addSubModel(np.asarray(vertices, float), np.asarray(faces, np.int64))
    m.endModel()
    return fcl.CollisionObject(m, fcl.Transform())


def fcl_distance(a_vertices, a_faces, b_vertices, b_faces) -> float:
    """FCL's distance between two triangle sets, 0 where they meet."""
    a, b = _object(a_vertices, a_faces), _object(b_vertices, b_faces)
    if fcl.collide(a, b, fcl.CollisionRequest(), fcl.CollisionResult()):
        return 0.0
    return float(fcl.distance(a, b, fcl.DistanceRequest(), fcl.DistanceResult()))


ONE = np.array([[0, 1, 2]])


@settings(max_examples=400, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), spread=st.sampled_from([0.1, 1.0, 3.0]),
       shape=st.sampled_from(["general", "coplanar", "thin", "point-like"]))
def test_two_triangles_are_within_a_margin_exactly_when_fcl_says_so(seed, spread, shape):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(3, 3))
    Q = rng.normal(size=(3, 3)) + spread * rng.normal(size=3)
    if shape == "coplanar":
        P[:, 2] = Q[:, 2] = 0.3
    elif shape == "thin":
        Q[2] = Q[1] + 1e-4 * rng.normal(size=3)
    elif shape == "point-like":
        Q[1:] = Q[0] + 1e-9 * rng.normal(size=(2, 3))
    d = fcl_distance(P, ONE, Q, ONE)
    for m in (0.0, 0.5 * d, 0.99 * d, 1.01 * d, d + 0.2):
        if abs(m - d) > 1e-7 * max(1.0, d):
            assert triangles_within(P, 0, Q, 0, m) == (d <= m), (d, m)
            assert triangles_within(Q, 0, P, 0, m) == (d <= m), (d, m)


def test_linked_triangles_meet_though_no_vertex_or_edge_comes_near():
    """An edge through the middle of the other face (a chain link): only the crossing test sees it."""
    P = np.array([[-1.0, 0, -5], [1.0, 0, -5], [0, 0, 5]])  # upright, in the plane y = 0
    Q = np.array([[0, -5.0, 0.5], [-0.3, 5.0, 0.5], [0.3, 5.0, 0.5]])  # flat at z = 0.5, its long edges through P
    assert fcl_distance(P, ONE, Q, ONE) == 0.0
    assert triangles_within(P, 0, Q, 0, 0.0)


def test_the_tree_holds_every_triangle_once_inside_its_boxes():
    rng = np.random.default_rng(3)
    tris = rng.normal(size=(157, 3, 3)) * 5 + rng.normal(size=(157, 1, 3)) * 20
    nodes, ordered = build_tree(tris)
    ordered = ordered.reshape(-1, 3, 3)
    assert sorted(map(tuple, ordered.reshape(len(ordered), -1))) == sorted(map(tuple, tris.reshape(len(tris), -1)))
    seen = np.zeros(len(tris), int)
    stack = [(0, None)]
    while stack:
        k, parent = stack.pop()
        lo, hi, link = nodes[3 * k], nodes[3 * k + 1], nodes[3 * k + 2]
        if parent is not None:  # a child's box lies in its parent's
            assert np.all(lo >= nodes[3 * parent]) and np.all(hi <= nodes[3 * parent + 1])
        if link[0] < 0:
            first, count = int(link[1]), int(link[2])
            assert 1 <= count <= LEAF_SIZE
            seen[first:first + count] += 1
            inside = ordered[first:first + count]
            assert np.all(inside >= lo) and np.all(inside <= hi)
        else:
            stack += [(int(link[0]), k), (int(link[1]), k)]
    assert np.all(seen == 1)
    spheres = sphere_nodes(nodes, ordered.reshape(-1, 3))
    assert np.all(spheres[1::4, 0] > 0) and np.all(spheres[3::4] >= 0)


def _depth(nodes) -> int:
    """Levels of ``build_tree``'s tree below its root (0 for a lone leaf)."""
    deepest, stack = 0, [(0, 0)]
    while stack:
        k, level = stack.pop()
        deepest = max(deepest, level)
        link = nodes[3 * k + 2]
        if link[0] >= 0:
            stack += [(int(link[0]), level + 1), (int(link[1]), level + 1)]
    return deepest


@pytest.mark.parametrize("count", [1, 4, 5, 157, 4097, 20000])
def test_the_walks_fixed_stack_holds_two_trees_of_any_loadable_size(count):
    """``sets_clearance``'s stack never holds more than the two trees' depths and one pairs; the median split keeps a
    tree over T triangles within ceil(log2(T / LEAF_SIZE)) levels, so STACK_ROWS covers trees of up to 2**31 each."""
    rng = np.random.default_rng(count)
    # clustered triangles, as a mesh's are: the split is by count, whatever the coordinates
    tris = rng.normal(size=(count, 3, 3)) + np.repeat(rng.normal(size=(-(-count // 50), 1, 3)) * 30, 50, 0)[:count]
    levels = _depth(build_tree(tris)[0])
    assert levels <= max(0, math.ceil(math.log2(count / LEAF_SIZE)))
    worst = math.ceil(math.log2(2**31 / LEAF_SIZE))
    assert 2 * worst + 1 <= STACK_ROWS


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.floats(-3.2, 3.2), st.floats(-3.2, 3.2), st.floats(-3.2, 3.2),
       st.floats(-1e3, 1e3))
def test_a_body_nodes_turned_box_holds_its_turned_triangles(seed, a, b, c, shift):
    """The world box ``sets_apart`` puts about a body node's turned box holds the node's triangles as posed."""
    rng = np.random.default_rng(seed)
    tris = rng.normal(size=(40, 3, 3)) * rng.uniform(0.01, 5, 3) + rng.normal(size=(40, 1, 3))
    nodes, ordered = build_tree(tris)
    spheres = sphere_nodes(nodes, ordered)
    R = np.asarray(rotation_matrix(a, b, c))
    t = np.full(3, shift)
    placed = (ordered @ R.T + t).reshape(-1, 3, 3)
    for k in range(len(spheres) // 4):
        centre, link, half = spheres[4 * k], spheres[4 * k + 2], spheres[4 * k + 3]
        # the node's triangles: its leaves' ranges
        ranges, stack = [], [k]
        while stack:
            n = stack.pop()
            if spheres[4 * n + 2, 0] < 0:
                ranges.append((int(spheres[4 * n + 2, 1]), int(spheres[4 * n + 2, 2])))
            else:
                stack += [int(spheres[4 * n + 2, 0]), int(spheres[4 * n + 2, 1])]
        corners = np.concatenate([placed[first:first + count].reshape(-1, 3) for first, count in ranges])
        # as sets_apart computes them: the turned centre and the world box's half sides
        cw = np.array([R[d, 0] * centre[0] + R[d, 1] * centre[1] + R[d, 2] * centre[2] + t[d] for d in range(3)])
        w = np.array([abs(R[d, 0]) * half[0] + abs(R[d, 1]) * half[1] + abs(R[d, 2]) * half[2] for d in range(3)])
        assert np.all(corners >= cw - w) and np.all(corners <= cw + w), (k, link)
        assert np.all(np.linalg.norm(corners - cw, axis=1) <= spheres[4 * k + 1, 0])


def pose(R):
    """The rotation ``R`` as the exact test takes it: its nine entries, row by row, as a tuple."""
    return tuple(float(x) for x in np.asarray(R).ravel())


def _boxy(rng, n, scale):
    """``n`` random small boxes (12 triangles each) in a cube of side ``scale``."""
    import trimesh

    parts = [trimesh.creation.box(extents=rng.uniform(0.2, 2.0, 3),
                                  transform=trimesh.transformations.translation_matrix(rng.uniform(0, scale, 3)))
             for _ in range(n)]
    mesh = trimesh.util.concatenate(parts)
    return np.asarray(mesh.vertices, float), np.asarray(mesh.faces, np.int64)


def _scene(rng, capsule: bool):
    """60 random boxes and a body (a capsule or a box), with the trees the exact test walks."""
    pytest.importorskip("trimesh", reason="the test scene is made with trimesh (pip install samplergym[mesh])")
    import trimesh

    env_v, env_f = _boxy(rng, 60, 12.0)
    body = trimesh.creation.capsule(height=2.0, radius=0.4) if capsule else trimesh.creation.box(extents=(3, 1, 0.5))
    body_v, body_f = np.asarray(body.vertices, float), np.asarray(body.faces, np.int64)
    nodes, tris = build_tree(env_v[env_f])
    body_nodes, body_tris = build_tree(body_v[body_f])
    return env_v, env_f, body_v, body_f, nodes, tris, body_tris, sphere_nodes(body_nodes, body_tris)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_body_is_more_than_a_margin_away_exactly_when_fcl_says_so(seed):
    rng = np.random.default_rng(seed)
    env_v, env_f, body_v, body_f, nodes, tris, body_tris, spheres = _scene(rng, capsule=bool(seed))
    checked = {True: 0, False: 0}
    for _ in range(150):
        q = np.r_[rng.uniform(0, 12, 3), rng.uniform(-np.pi, np.pi, 3)]
        R = np.asarray(rotation_matrix(q[3], q[4], q[5]))
        placed = body_v @ R.T + q[:3]
        d = fcl_distance(placed, body_f, env_v, env_f)
        for m in (0.0, 0.05, 0.3, 1.0):
            if abs(m - d) > 1e-7:
                got = sets_apart(spheres, np.ascontiguousarray(body_tris @ R.T + q[:3]), pose(R), tuple(q[:3]), nodes,
                                 tris, m, np.full(2, -1, dtype=np.int64))
                assert got == (d > m), (q, d, m)
                checked[got] += 1
    assert checked[True] > 50 and checked[False] > 50


@pytest.mark.parametrize("seed", [0, 1])
def test_one_walk_finds_the_largest_margin_a_pose_clears(seed):
    """``sets_clearance`` answers, in one walk, what testing its margins one at a time answers, with any hint; FCL
    agrees."""
    rng = np.random.default_rng(seed + 10)
    env_v, env_f, body_v, body_f, nodes, tris, body_tris, spheres = _scene(rng, capsule=bool(seed))
    margins = np.array([2.0, 0.8, 0.3, 0.05, 0.0])
    seen = set()
    for _ in range(150):
        q = np.r_[rng.uniform(0, 12, 3), rng.uniform(-np.pi, np.pi, 3)]
        R = np.asarray(rotation_matrix(q[3], q[4], q[5]))
        placed = np.ascontiguousarray(body_tris @ R.T + q[:3])
        hint = np.full(2, -1, dtype=np.int64)
        k = sets_clearance(spheres, placed, pose(R), tuple(q[:3]), nodes, tris, margins, hint)
        # any pair as the hint (the last pose's, or one far off): the same answer
        for b, e in ((hint[0], hint[1]), (rng.integers(len(body_tris) // 3), rng.integers(len(tris) // 3))):
            if b >= 0:
                pair = np.array([b, e], dtype=np.int64)
                assert sets_clearance(spheres, placed, pose(R), tuple(q[:3]), nodes, tris, margins, pair) == k
        one_by_one = next((j for j, m in enumerate(margins)
                           if sets_apart(spheres, placed, pose(R), tuple(q[:3]), nodes, tris, m, np.full(2, -1))),
                          len(margins))
        assert k == one_by_one, (q, k, one_by_one)
        d = fcl_distance(body_v @ R.T + q[:3], body_f, env_v, env_f)
        if all(abs(m - d) > 1e-7 for m in margins):
            assert k == next((j for j, m in enumerate(margins) if d > m), len(margins)), (q, d, k)
        seen.add(k)
    assert len(seen) >= 4  # poses at several rungs, in contact among them
