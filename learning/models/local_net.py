"""The route encoder's local network at inference on small maps, compiled: its 3x3 layers and its two 1x1 heads.

On a map of a few hundred blocks the local network's arithmetic is small (about 2 million multiply-adds over
16 x 16 blocks) and torch's cost is in its calls: a dozen operations a pass, each through the dispatcher and
oneDNN, and more where the query runs between planners (its code and data out of the CPU's caches, as in a
planning loop; ``scripts/experiments/compiled_local.py`` measures both). ``local_features`` runs the 3x3 layers
(zero padding, ReLU) in one compiled call, and ``block_heads`` the cost head (``RouteVIN.prices``) and the cell
head's first layer on the features (``RouteVIN.head_inputs``) in another: float32 throughout, the same
arithmetic in another order of summation (each output's sum runs bias first, then input channel by channel, each
channel's nine taps row by row, and a 1x1 layer's inputs four at a time; multiply-adds may fuse), so the values are
torch's up to rounding. Training and larger maps keep torch (``RouteVIN.numba_local_blocks``).
"""

from __future__ import annotations

import numba as nb
import numpy as np

#: Output channels a pass of ``_conv3x3`` computes at once (the weights are padded to a multiple of it); its loop
#: is written out for four.
GROUP = 4


@nb.njit(cache=True, fastmath={"contract"})
def _conv3x3(plane, w, b, out):
    """``out[k, i]``: output channel ``k`` at the flat position ``i`` (row stride ``plane``'s width) of the valid
    3x3 convolution of ``plane`` (cin, hp, wp; zero padding already in it) with ``w`` (cout, cin, 3, 3), ``b``.
    """
    cin, hp, wp = plane.shape
    cout = w.shape[0]
    n = out.shape[1]
    flat = plane.reshape(cin, hp * wp)
    r1, r2 = wp, 2 * wp
    for co in range(0, cout, GROUP):
        o0, o1, o2, o3 = out[co], out[co + 1], out[co + 2], out[co + 3]
        b0, b1, b2, b3 = b[co], b[co + 1], b[co + 2], b[co + 3]
        for i in range(n):
            o0[i] = b0
            o1[i] = b1
            o2[i] = b2
            o3[i] = b3
        for ci in range(cin):
            # the three input rows a tap reads, as views from their first element: their indices are never negative,
            # so the loop below loads contiguous vectors (an offset index would compile to gathers)
            src, mid, low = flat[ci], flat[ci, r1:], flat[ci, r2:]
            p, q, r, s = w[co, ci], w[co + 1, ci], w[co + 2, ci], w[co + 3, ci]
            p0, p1, p2, p3, p4, p5, p6, p7, p8 = (p[0, 0], p[0, 1], p[0, 2], p[1, 0], p[1, 1], p[1, 2],
                                                  p[2, 0], p[2, 1], p[2, 2])
            q0, q1, q2, q3, q4, q5, q6, q7, q8 = (q[0, 0], q[0, 1], q[0, 2], q[1, 0], q[1, 1], q[1, 2],
                                                  q[2, 0], q[2, 1], q[2, 2])
            r0, r1_, r2_, r3, r4, r5, r6, r7, r8 = (r[0, 0], r[0, 1], r[0, 2], r[1, 0], r[1, 1], r[1, 2],
                                                    r[2, 0], r[2, 1], r[2, 2])
            s0, s1, s2, s3, s4, s5, s6, s7, s8 = (s[0, 0], s[0, 1], s[0, 2], s[1, 0], s[1, 1], s[1, 2],
                                                  s[2, 0], s[2, 1], s[2, 2])
            for i in range(n):
                x0, x1, x2 = src[i], src[i + 1], src[i + 2]
                x3, x4, x5 = mid[i], mid[i + 1], mid[i + 2]
                x6, x7, x8 = low[i], low[i + 1], low[i + 2]
                o0[i] += p0 * x0 + p1 * x1 + p2 * x2 + p3 * x3 + p4 * x4 + p5 * x5 + p6 * x6 + p7 * x7 + p8 * x8
                o1[i] += q0 * x0 + q1 * x1 + q2 * x2 + q3 * x3 + q4 * x4 + q5 * x5 + q6 * x6 + q7 * x7 + q8 * x8
                o2[i] += r0 * x0 + r1_ * x1 + r2_ * x2 + r3 * x3 + r4 * x4 + r5 * x5 + r6 * x6 + r7 * x7 + r8 * x8
                o3[i] += s0 * x0 + s1 * x1 + s2 * x2 + s3 * x3 + s4 * x4 + s5 * x5 + s6 * x6 + s7 * x7 + s8 * x8


@nb.njit(cache=True)
def local_layers(x, w_first, b_first, w_rest, b_rest, top, bottom, left, right):
    """Compiled (for compiled callers): ``local_features`` of ``x`` (cin, h, w; float32, any strides), its ``pads``
    as four ints, the weights as it takes them, unchecked.
    """
    zero = np.float32(0.0)
    layers = 1 + w_rest.shape[0]
    c, h, wd = x.shape
    plane = np.zeros((c, h + top + bottom, wd + left + right), dtype=np.float32)
    plane[:, top:top + h, left:left + wd] = x
    for layer in range(layers):
        w = w_first if layer == 0 else w_rest[layer - 1]
        b = b_first if layer == 0 else b_rest[layer - 1]
        wp = plane.shape[2]
        ho, wo = plane.shape[1] - 2, wp - 2
        out = np.empty((w.shape[0], (ho - 1) * wp + wo), dtype=np.float32)  # row stride wp, the last row's tail cut
        _conv3x3(plane, w, b, out)
        last = layer == layers - 1
        # rectified into the next layer's input, with its zero padding (or, after the last layer, the features)
        r0, c0 = (0, 0) if last else (top, left)
        if last:
            plane = np.empty((w.shape[0], ho, wo), dtype=np.float32)
        else:
            plane = np.zeros((w.shape[0], ho + top + bottom, wo + left + right), dtype=np.float32)
        for k in range(w.shape[0]):
            for r in range(ho):
                src = out[k, r * wp:r * wp + wo]  # row views: contiguous loads, never an offset index
                dst = plane[k, r0 + r, c0:c0 + wo]
                for col in range(wo):
                    v = src[col]
                    dst[col] = v if v > zero else zero
    return plane


def grouped(weights: np.ndarray, bias: np.ndarray, inputs: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """A 3x3 layer's ``weights`` (cout, cin, 3, 3) and ``bias`` as ``local_features`` takes them: float32, C-ordered,
    the output channels padded with zeros to a multiple of ``GROUP`` (and the input channels to ``inputs``): a padded
    channel stays zero through the ReLU, and the next layer's padded inputs weigh it by zero.
    """
    cout, cin = weights.shape[:2]
    outs = -(-cout // GROUP) * GROUP
    w = np.zeros((outs, cin if inputs is None else inputs, 3, 3), dtype=np.float32)
    w[:cout, :cin] = weights
    b = np.zeros(outs, dtype=np.float32)
    b[:cout] = bias
    return w, b


def local_features(x: np.ndarray, w_first: np.ndarray, b_first: np.ndarray, w_rest: np.ndarray, b_rest: np.ndarray,
                   pads: tuple[int, int, int, int] = (1, 1, 1, 1)) -> np.ndarray:
    """The local network's features (C', h', w') of the input region ``x`` (cin, h, w, float32).

    ``w_first``, ``b_first``: the first 3x3 layer, ``w_rest``, ``b_rest`` the others stacked (layers, C', C', 3, 3),
    each as ``grouped`` gives it (C' channels: the network's, padded). ``pads`` (top, bottom, left, right): 1 where a
    side of the region is the map's edge, so each layer pads it with zeros as a pass over the whole map does; 0 where
    it is not, so each layer reads the region's own blocks there and the output shrinks by one block a layer on that
    side (``RouteVIN.local_window``).
    """
    top, bottom, left, right = (int(p) for p in pads)
    return local_layers(np.ascontiguousarray(x, dtype=np.float32), w_first, b_first, w_rest, b_rest, top, bottom, left,
                  right)


#: ``_exp``'s reduction and polynomial (Cephes' ``expf``: relative error about one float32 rounding): ``exp(t) = 2**n *
#: exp(r)``, ``n`` the nearest integer to ``t / ln 2``, ``r = t - n ln 2`` with ``ln 2`` in two parts.
_LOG2E, _LN2_HI, _LN2_LO = 1.44269504088896341, 0.693359375, -2.12194440e-4
_EXP_POLY = (1.9875691500e-4, 1.3981999507e-3, 8.3334519073e-3, 4.1665795894e-2, 1.6666665459e-1, 5.0000001201e-1)
#: Below this ``0.5 + exp(t)`` is 0.5 in float32 whatever ``exp`` gives (``exp(-30)`` is far below half of 0.5's last
#: place), so the costs clamp their logits there and ``2**n`` stays a normal number.
_LEAST_LOG = -30.0


@nb.njit(cache=True, fastmath={"contract"})
def _exp_costs(row, length, wall_log, bits):
    """``row[i] = length * (0.5 + exp(min(row[i], wall_log)))`` in float32, ``exp`` computed in loops that vectorize
    (``_EXP_POLY``; ``bits``: int32 scratch of ``row``'s length, where ``2**n`` is built from its exponent bits).
    """
    f32 = np.float32
    log2e, hi, lo = f32(_LOG2E), f32(_LN2_HI), f32(_LN2_LO)
    c0, c1, c2 = f32(_EXP_POLY[0]), f32(_EXP_POLY[1]), f32(_EXP_POLY[2])
    c3, c4, c5 = f32(_EXP_POLY[3]), f32(_EXP_POLY[4]), f32(_EXP_POLY[5])
    least, half, one = f32(_LEAST_LOG), f32(0.5), f32(1.0)
    for i in range(len(row)):
        t = min(max(row[i], least), wall_log)
        n = np.floor(t * log2e + half)
        r = t - n * hi - n * lo
        z = r * r
        row[i] = ((((((c0 * r + c1) * r + c2) * r + c3) * r + c4) * r + c5) * z + r) + one
        bits[i] = np.int32(n) + np.int32(127) << np.int32(23)
    scale = bits.view(np.float32)
    for i in range(len(row)):
        row[i] = length * (half + row[i] * scale[i])


#: Positions a pass of ``_one_by_one`` covers at once, so that its input rows stay in the CPU's first cache.
_CHUNK = 512


@nb.njit(cache=True, fastmath={"contract"})
def _one_by_one(features, channels, w, b, out):
    """``out[k] = b[k] + sum over j < channels of w[k, j] * features[j]``: a 1x1 layer over flat rows, the inputs
    summed in that order, four at a time (one load and store of an output for four of its terms).
    """
    m = out.shape[1]
    for start in range(0, m, _CHUNK):
        stop = min(m, start + _CHUNK)
        for k in range(out.shape[0]):
            row = out[k, start:stop]
            for i in range(len(row)):
                row[i] = b[k]
            j = 0
            while j + 4 <= channels:
                w0, w1, w2, w3 = w[k, j], w[k, j + 1], w[k, j + 2], w[k, j + 3]
                s0, s1 = features[j, start:stop], features[j + 1, start:stop]
                s2, s3 = features[j + 2, start:stop], features[j + 3, start:stop]
                for i in range(len(row)):
                    row[i] = row[i] + w0 * s0[i] + w1 * s1[i] + w2 * s2[i] + w3 * s3[i]
                j += 4
            while j < channels:
                wv = w[k, j]
                src = features[j, start:stop]
                for i in range(len(row)):
                    row[i] += wv * src[i]
                j += 1


@nb.njit(cache=True)
def heads_into(f, channels, w_cost, b_cost, lengths, wall_log, w_pre, b_pre, costs, pre):
    """Compiled (for compiled callers): ``block_heads`` of the C-contiguous features ``f``, written into ``costs``
    (8, h, w) and ``pre`` (C, h, w), C-contiguous float32; ``wall_log`` float32; unchecked.
    """
    m = f.shape[1] * f.shape[2]
    ff = f.reshape(f.shape[0], m)
    cf = costs.reshape(costs.shape[0], m)
    _one_by_one(ff, channels, w_cost, b_cost, cf)
    bits = np.empty(m, dtype=np.int32)
    for k in range(cf.shape[0]):
        _exp_costs(cf[k], lengths[k], wall_log, bits)
    _one_by_one(ff, channels, w_pre, b_pre, pre.reshape(pre.shape[0], m))


def block_heads(f: np.ndarray, channels: int, w_cost: np.ndarray, b_cost: np.ndarray, lengths: np.ndarray,
                wall_log: float, w_pre: np.ndarray, b_pre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The move costs (8, h, w) and the cell head's first layer on the features (C, h, w) of the features ``f``
    (``local_features``; its first ``channels`` are the network's), float32: the costs ``lengths * (0.5 +
    exp(min(cost, wall_log)))`` of the cost head's ``cost = w_cost @ f + b_cost`` (``w_cost`` 8 x C), and
    ``w_pre @ f + b_pre`` (``w_pre`` C x C).
    """
    f = np.ascontiguousarray(f)
    h, w = f.shape[1:]
    costs = np.empty((len(w_cost), h, w), dtype=np.float32)
    pre = np.empty((len(w_pre), h, w), dtype=np.float32)
    heads_into(f, channels, w_cost, b_cost, lengths, np.float32(wall_log), w_pre, b_pre, costs, pre)
    return costs, pre
