"""Compiled draws along a 6-DoF workspace route: the route samples that follow the trees, and the trees' reach.

``learning.samplers.rigid_route.RigidRouteSampler`` with ``follow`` draws at most 64 samples at a time, so that its
windows move with the trees; drawn with numpy, each such draw costs 0.2 to 0.3 ms, most of it per-call work, more
than a box world's whole iteration. ``follow_draw`` makes the same samples from the same rows of uniforms in one call:
every value as the numpy draw computes it (the same operations in the same order), the logarithm, arcsine and
arctangent aside, which the C library computes here and numpy's own vector code there, so the two agree to the
last bit or two of those (``tests/test_rigid_route.py`` checks them against each other). ``route_reach`` is the
trees' reach along the route (``RigidRouteSampler``'s watch), value for value the numpy computation it replaces.

Rows of uniforms, one per sample (``d`` the state's dimension, 6): a coin (the goal, a route sample or a uniform
state), the arc length, ``d`` uniforms of a uniform state, two Box-Muller pairs for the position's noise, a coin for
uniform angles, the class, the symmetry, two Box-Muller pairs for the rotation's noise.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

TWO_PI = 2.0 * np.pi  # as numpy's box_muller forms it: 2.0 * np.pi * u


@nb.njit(cache=True)
def _normals(u, r, c0):
    """The first three of the two Box-Muller pairs in columns ``c0 .. c0 + 3`` of row ``r`` (radii, then angles)."""
    r0 = math.sqrt(-2.0 * math.log(1.0 - u[r, c0]))
    r1 = math.sqrt(-2.0 * math.log(1.0 - u[r, c0 + 1]))
    t0 = TWO_PI * u[r, c0 + 2]
    t1 = TWO_PI * u[r, c0 + 3]
    return r0 * math.cos(t0), r1 * math.cos(t1), r0 * math.sin(t0)


@nb.njit(cache=True)
def _turned_euler(w0, w1, w2, base, out, r, c):
    """``out[r, c:c + 3]``: the angles of ``exp([w]x) @ base`` (Rodrigues, then the planner's Euler angles)."""
    theta = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    safe = max(theta, 1e-12)
    k0, k1, k2 = w0 / safe, w1 / safe, w2 / safe
    K = np.zeros((3, 3))
    K[0, 1], K[0, 2], K[1, 2] = -k2, k1, -k0
    K[1, 0], K[2, 0], K[2, 1] = k2, -k1, k0
    s, cc = math.sin(theta), 1.0 - math.cos(theta)
    T = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            kk = K[i, 0] * K[0, j] + K[i, 1] * K[1, j] + K[i, 2] * K[2, j]
            T[i, j] = (1.0 if i == j else 0.0) + s * K[i, j] + cc * kk
    R = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            R[i, j] = T[i, 0] * base[0, j] + T[i, 1] * base[1, j] + T[i, 2] * base[2, j]
    out[r, c] = math.asin(min(max(-R[1, 2], -1.0), 1.0))
    if math.sqrt(R[1, 0] ** 2 + R[1, 1] ** 2) < 1e-9:  # gimbal lock, as euler_from_matrices has it
        out[r, c + 1] = math.atan2((1.0 if R[1, 2] < 0 else -1.0) * R[0, 1], R[0, 0])
        out[r, c + 2] = 0.0
    else:
        out[r, c + 1] = math.atan2(R[0, 2], R[2, 2])
        out[r, c + 2] = math.atan2(R[1, 0], R[1, 1])


@nb.njit(cache=True)
def follow_draw(u, out, low, high, top, goal, goal_share, route_fraction, route, warc, windows, two, follow_share,
                sd, share0, ramp, k0, k_step, sure, cdf, rotations, refs, use_ref, angle_noise):
    """Fill ``out`` (n, d) with the samples of the rows ``u`` (n, 13 + d): ``RigidRouteSampler``'s draw with ``follow``.

    ``windows`` (2, 2): the weighted arc positions (``warc``) bounding the start tree's window and the goal tree's;
    ``two``: whether the goal tree's window takes half the windowed samples; ``follow_share``: the share of route
    samples drawn in the windows (the rest along the whole route). ``top``: the position's upper clip (just below
    ``high``). The uniform angles' share of a route sample is ``share0``, rising to 1 over ``ramp`` samples (0: it
    stays) from ``k0``, plus the row's index where ``k_step``. ``sure`` (m,): the route points whose class a sample
    may take; ``cdf`` (m, classes): the classes' cumulative probabilities there; ``refs`` (m, 3, 3): the rotation a
    sample's symmetry comes nearest at each route point (``use_ref``; else the symmetry is drawn).
    """
    n, d = out.shape
    m = route.shape[0]
    total = warc[m - 1]
    whole_scale = max(1.0 - follow_share, 1e-300)
    part_scale = max(follow_share, 1e-300)
    for r in range(n):
        for j in range(d):
            out[r, j] = low[j] + (high[j] - low[j]) * u[r, 2 + j]
        c = u[r, 0]
        if c < goal_share:
            for j in range(d):
                out[r, j] = goal[j]
            continue
        if total <= 0.0 or c >= goal_share + (1.0 - goal_share) * route_fraction:
            continue
        v = u[r, 1]
        if v >= follow_share:
            s = (v - follow_share) / whole_scale * total
        else:
            v = v / part_scale
            w = 0
            if two:
                if v >= 0.5:
                    w = 1
                    v = 2.0 * v - 1.0
                else:
                    v = 2.0 * v
            a, b = windows[w, 0], windows[w, 1]
            s = a + v * (b - a)
        i = np.searchsorted(warc, s, side="right") - 1
        i = min(max(i, 0), m - 2)
        t = (s - warc[i]) / max(warc[i + 1] - warc[i], 1e-300)
        z0, z1, z2 = _normals(u, r, 2 + d)
        zs = (z0, z1, z2)
        for j in range(3):
            p = route[i, j] + t * (route[i + 1, j] - route[i, j]) + sd * zs[j]
            out[r, j] = min(max(p, low[j]), top[j])
        near = i + 1 if t >= 0.5 else i
        share = share0
        if ramp > 0:
            k = k0 + (r if k_step else 0)
            share = share + (1.0 - share) * min(1.0, k / ramp)
        if not (u[r, 6 + d] >= share and sure[near]):
            continue
        cu = u[r, 7 + d]
        cls = 0
        for q in range(cdf.shape[1]):
            if cdf[near, q] < cu:
                cls += 1
        cls = min(cls, cdf.shape[1] - 1)
        sym = min(int(u[r, 8 + d] * 4), 3)
        if use_ref:
            best, sym = -np.inf, 0
            for q in range(rotations.shape[1]):
                tr = 0.0
                for a_ in range(3):
                    for b_ in range(3):
                        tr += rotations[cls, q, a_, b_] * refs[near, a_, b_]
                if tr > best:
                    best, sym = tr, q
        w0, w1, w2 = _normals(u, r, 9 + d)
        _turned_euler(angle_noise * w0, angle_noise * w1, angle_noise * w2, rotations[cls, sym], out, r, 3)


@nb.njit(cache=True)
def route_reach(states, seen, route, arc, reach, side, span, follow):
    """A tree's reach along the route after its vertices ``states[seen:]`` (``RigidRouteSampler``'s watch).

    Each vertex's arc position is its nearest route point's (``side`` 0: the start tree, whose reach is the
    greatest; 1: the goal tree's, the least); with ``follow``, among the route points within ``span`` of arc length
    beyond the reach (the start tree) or before it (the goal tree's), and only where that point lies within
    ``span`` of it. Taken 256 vertices at a time, each group's window from the reach before it.
    """
    m = route.shape[0]
    span2 = span * span
    for lo in range(seen, states.shape[0], 256):
        hi = min(lo + 256, states.shape[0])
        first, last = 0, m
        if follow:
            if side == 0:
                last = max(1, np.searchsorted(arc, reach + span, side="right"))
            else:
                first = min(last - 1, np.searchsorted(arc, reach - span, side="left"))
        found = False
        best = 0.0
        for v in range(lo, hi):
            dmin, jmin = np.inf, first
            for j in range(first, last):
                e0 = states[v, 0] - route[j, 0]
                e1 = states[v, 1] - route[j, 1]
                e2 = states[v, 2] - route[j, 2]
                d2 = e0 * e0 + e1 * e1 + e2 * e2
                if d2 < dmin:
                    dmin, jmin = d2, j
            if follow and not dmin <= span2:
                continue
            a = arc[jmin]
            if not found or (a > best if side == 0 else a < best):
                best, found = a, True
        if found:
            reach = max(reach, best) if side == 0 else min(reach, best)
    return reach


def watch_reach(view, route, arc, reach: list, seen: list, span: float, follow: bool) -> bool:
    """Bring the trees' reach along ``route`` up to the planner's ``view``; whether it has a goal tree.

    ``reach`` and ``seen`` hold the start tree's and the goal tree's values (their reach, their vertices counted so
    far) and are updated in place with ``route_reach`` over each tree's new vertices.
    """
    for side, states in ((0, view.vertices), (1, view.goal_tree)):
        if states is not None and len(states) > seen[side]:
            reach[side] = float(route_reach(states, seen[side], route, arc, float(reach[side]), side, float(span),
                                            follow))
            seen[side] = len(states)
    return view.goal_tree is not None
