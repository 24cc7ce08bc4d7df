"""Draw from a numpy ``Generator`` inside compiled code for the cost of passing an integer.

numba accepts a ``np.random.Generator`` argument, but unboxes it on every call (and numpy builds
ctypes wrappers for the bit generator's functions on the first call with a new generator), which
costs more than a learned sampler spends drawing in a short solve. Instead the caller passes
``bitgen_address(rng)``, the address of the generator's C ``bitgen_t`` (numpy's public C API,
``numpy/random/bitgen.h``, taken from the bit generator's capsule), and compiled code calls its
``next_double`` through ``next_double(address)``, which is exactly what ``Generator.random()`` does
per value: the stream is the same, value for value.

The generator must outlive every use of its address; planners own theirs for their lifetime.
"""

from __future__ import annotations

import ctypes

import numba as nb
import numpy as np
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

_get_pointer = ctypes.pythonapi.PyCapsule_GetPointer
_get_pointer.restype = ctypes.c_void_p
_get_pointer.argtypes = [ctypes.py_object, ctypes.c_char_p]

# bitgen_t is {void *state; next_uint64; next_uint32; next_double; next_raw}: all pointer-sized
_NEXT_DOUBLE_SLOT = 3


def bitgen_address(rng: np.random.Generator) -> int:
    """Address of ``rng``'s ``bitgen_t``, for ``next_double`` in compiled code."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"expected a numpy Generator, got {type(rng).__name__}")
    return int(_get_pointer(rng.bit_generator.capsule, b"BitGenerator"))


@intrinsic
def _call_next_double(typingctx, address):
    if not isinstance(address, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        ptr_t = ir.IntType(8).as_pointer()
        fn_t = ir.FunctionType(ir.DoubleType(), [ptr_t])
        slots = builder.inttoptr(args[0], ptr_t.as_pointer())  # bitgen_t viewed as an array of pointers
        state = builder.load(slots)
        fn = builder.bitcast(builder.load(builder.gep(slots, [ir.Constant(ir.IntType(64), _NEXT_DOUBLE_SLOT)])),
                             fn_t.as_pointer())
        return builder.call(fn, [state])

    return types.float64(address), codegen


@nb.njit(cache=True, no_cfunc_wrapper=True, inline="always")
def next_double(address):
    """The next ``Generator.random()`` value of the generator at ``address`` (see ``bitgen_address``)."""
    return _call_next_double(address)
