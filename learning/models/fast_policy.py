"""The trained actor re-implemented in numba, for inference inside planners.

A torch forward pass of even a tiny network costs tens of microseconds of framework overhead, which
is more than the planner spends on dozens of iterations. The actor (extractor, policy MLP, action
logits) is a fixed stack of convolutions and linear layers, so its weights are copied out of the SB3
state dict and evaluated here; ``tests/test_learning.py`` checks the logits match torch's.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: Kernel sizes (= strides) of the extractor's two convolutions (``learning.models.extractor``).
KERNELS = (4, 2)

#: State-dict keys of the actor, in evaluation order (SB3 ActorCriticPolicy with EgocentricExtractor).
ACTOR_KEYS = (
    "pi_features_extractor.cnn.0.weight", "pi_features_extractor.cnn.0.bias",
    "pi_features_extractor.cnn.2.weight", "pi_features_extractor.cnn.2.bias",
    "pi_features_extractor.vec.0.weight", "pi_features_extractor.vec.0.bias",
    "pi_features_extractor.head.0.weight", "pi_features_extractor.head.0.bias",
    "mlp_extractor.policy_net.0.weight", "mlp_extractor.policy_net.0.bias",
    "action_net.weight", "action_net.bias",
)


@nb.njit(cache=True, fastmath=True)
def _patch_conv_relu(x, w, b, k, patch, out):
    """Convolution with kernel == stride k as patches (im2col) times a (out, in * k * k) matrix, ReLU, into ``out``.

    Each output is then one contiguous dot product, which LLVM vectorises.
    """
    ci, hi, wi = x.shape
    ho, wo = hi // k, wi // k
    n = ci * k * k
    for i in range(ho):
        for j in range(wo):
            t = 0
            for c in range(ci):
                for di in range(k):
                    for dj in range(k):
                        patch[t] = x[c, i * k + di, j * k + dj]
                        t += 1
            for o in range(w.shape[0]):
                s = b[o]
                for q in range(n):
                    s += w[o, q] * patch[q]
                out[o, i, j] = s if s > 0.0 else 0.0


@nb.njit(cache=True, fastmath=True)
def _linear(x, w, b, relu, out):
    for o in range(w.shape[0]):
        s = b[o]
        for i in range(w.shape[1]):
            s += w[o, i] * x[i]
        out[o] = s if (s > 0.0 or not relu) else 0.0


@nb.njit(cache=True)
def _take(buf, at, n):
    return buf[at:at + n], at + n


@nb.njit(cache=True)
def _activations(scratch, ci, size, c1w, c2w, hw, pw):
    """Views of ``scratch`` for one pass's activations, and the float32s they need in all.

    The one statement of the scratch layout: with an empty ``scratch`` it only measures it.
    """
    s1 = size // KERNELS[0]
    x, at = _take(scratch, 0, ci * size * size)
    patch1, at = _take(scratch, at, c1w.shape[1])
    h1, at = _take(scratch, at, c1w.shape[0] * s1 * s1)
    patch2, at = _take(scratch, at, c2w.shape[1])
    z, at = _take(scratch, at, hw.shape[1])  # conv features, then the vector branch
    f, at = _take(scratch, at, hw.shape[0])
    p, at = _take(scratch, at, pw.shape[0])
    return x, patch1, h1, patch2, z, f, p, at


@nb.njit(cache=True, fastmath=True)
def actor_logits(local, vector, c1w, c1b, c2w, c2b, vw, vb, hw, hb, pw, pb, aw, ab, scratch, logits):
    """Action logits into ``logits`` for one observation (``local`` uint8 (C, S, S), ``vector`` float32).

    ``c1w``/``c2w`` are the convolution kernels flattened to (out, in * k * k); ``scratch`` holds
    ``FastActor.scratch_size`` float32s for the activations, so a pass allocates nothing. The kernel
    sizes are the extractor's constants, so the patch loops compile to fixed trip counts (a quarter
    off a pass with the sizes as arguments).
    """
    k1, k2 = KERNELS
    ci, size = local.shape[0], local.shape[1]
    s1 = size // k1
    s2 = s1 // k2
    x, patch1, h1, patch2, z, f, p, _ = _activations(scratch, ci, size, c1w, c2w, hw, pw)
    flat = local.reshape(-1)
    for i in range(flat.shape[0]):
        x[i] = flat[i] * np.float32(1.0 / 255.0)
    _patch_conv_relu(x.reshape((ci, size, size)), c1w, c1b, k1, patch1, h1.reshape((c1w.shape[0], s1, s1)))
    nf = c2w.shape[0] * s2 * s2
    _patch_conv_relu(h1.reshape((c1w.shape[0], s1, s1)), c2w, c2b, k2, patch2, z[:nf].reshape((c2w.shape[0], s2, s2)))
    _linear(vector, vw, vb, True, z[nf:])
    _linear(z, hw, hb, True, f)
    _linear(f, pw, pb, True, p)
    _linear(p, aw, ab, False, logits)
    return logits


@nb.njit(cache=True, inline="always")
def softmax_cdf(logits, temperature, cdf):
    """Fill ``cdf`` with the running sum of exp((logits - max) / temperature); return the total.

    The exponentials are single precision (float32 logits; a third cheaper than double) and the
    running sum double, so no class's share is lost to rounding.
    """
    m = logits.max()
    inv = np.float32(1.0 / temperature)
    acc = 0.0
    for i in range(logits.shape[0]):
        acc += math.exp(np.float32((logits[i] - m) * inv))
        cdf[i] = acc
    return acc


_NDIMS = (4, 1, 4, 1, 2, 1, 2, 1, 2, 1, 2, 1)  # dimensions of each ACTOR_KEYS tensor


class FastActor:
    """Numba actor built from an SB3 policy state dict (tensors or arrays)."""

    def __init__(self, state_dict) -> None:
        missing = [k for k in ACTOR_KEYS if k not in state_dict]
        if missing:
            raise ValueError(f"policy weights lack {missing[:3]}{'...' if len(missing) > 3 else ''}: "
                             "not an egocentric SamplerGym policy")
        w = [np.ascontiguousarray(_to_numpy(state_dict[k]), dtype=np.float32) for k in ACTOR_KEYS]
        ndims = tuple(a.ndim for a in w)
        if ndims != _NDIMS:
            raise ValueError(f"policy weights have {ndims} dimensions, an egocentric actor has {_NDIMS}")
        kernels = (int(w[0].shape[2]), int(w[2].shape[2]))
        if kernels != KERNELS or w[0].shape[2] != w[0].shape[3] or w[2].shape[2] != w[2].shape[3]:
            raise ValueError(f"policy convolutions have kernels {w[0].shape[2:]} and {w[2].shape[2:]}, "
                             f"the compiled actor computes {KERNELS}")
        bad = [k for k, a in zip(ACTOR_KEYS, w, strict=True) if not np.isfinite(a).all()]
        if bad:
            raise ValueError(f"policy weights {bad[:3]} hold NaN or infinite values")
        self._conv_shapes = (tuple(w[0].shape), tuple(w[2].shape))
        w[0] = np.ascontiguousarray(w[0].reshape(w[0].shape[0], -1))
        w[2] = np.ascontiguousarray(w[2].reshape(w[2].shape[0], -1))
        self.weights = tuple(w)
        self.num_actions = self.weights[-1].shape[0]

    def check_input(self, channels: int, size: int, vector: int, actions: int) -> str | None:
        """Why these weights cannot run on ``(channels, size, size)`` windows and ``vector`` features, or None.

        The compiled passes index without bounds checks, so every shape must chain exactly.
        """
        (o1, ci, _, _), (o2, c2, _, _) = self._conv_shapes
        _, b1, _, b2, vw, vb, hw, hb, pw, pb, aw, ab = self.weights
        s2 = size // KERNELS[0] // KERNELS[1]
        expected = {
            "first convolution input channels": (ci, channels),
            "second convolution input channels": (c2, o1),
            "first convolution bias": (b1.shape[0], o1),
            "second convolution bias": (b2.shape[0], o2),
            "vector layer input": (vw.shape[1], vector),
            "vector layer bias": (vb.shape[0], vw.shape[0]),
            "head input": (hw.shape[1], o2 * s2 * s2 + vw.shape[0]),
            "head bias": (hb.shape[0], hw.shape[0]),
            "policy layer input": (pw.shape[1], hw.shape[0]),
            "policy layer bias": (pb.shape[0], pw.shape[0]),
            "action layer input": (aw.shape[1], pw.shape[0]),
            "action layer bias": (ab.shape[0], aw.shape[0]),
            "actions": (aw.shape[0], actions),
        }
        wrong = [f"{name} {got} (expected {want})" for name, (got, want) in expected.items() if got != want]
        return f"policy weights do not fit the guided actor: {', '.join(wrong)}" if wrong else None

    def scratch_size(self, channels: int, size: int) -> int:
        """float32s of scratch ``actor_logits`` needs for a ``(channels, size, size)`` window."""
        c1w, _, c2w, _, _, _, hw, _, pw, *_ = self.weights
        return int(_activations(np.empty(0, dtype=np.float32), channels, size, c1w, c2w, hw, pw)[-1])

    def logits(self, local: np.ndarray, vector: np.ndarray) -> np.ndarray:
        local = np.ascontiguousarray(local)
        scratch = np.empty(self.scratch_size(local.shape[0], local.shape[1]), dtype=np.float32)
        return actor_logits(local, np.ascontiguousarray(vector, dtype=np.float32), *self.weights,
                            scratch, np.empty(self.num_actions, dtype=np.float32))


def _to_numpy(t) -> np.ndarray:
    return t.detach().cpu().numpy() if hasattr(t, "detach") else np.asarray(t)
