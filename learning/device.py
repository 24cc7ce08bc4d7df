"""Where training runs: ``--device auto|cpu|cuda`` (Stable-Baselines3's convention) turned into a torch device.

``auto`` takes CUDA when torch sees a GPU and the CPU otherwise; ``cuda`` on a machine without one is
refused by name before any work. The CPU is the default of every training command and gives the same
weights as before the option existed. ``full_float32`` holds a GPU's convolutions to full float32 where a
result must be the CPU's (the route encoder's field at planning time).
"""

from __future__ import annotations

import contextlib
import itertools
import os
from collections.abc import Iterator

import torch

from planners.base.fileio import InputError

#: What ``--device`` accepts.
DEVICES = ("auto", "cpu", "cuda")

#: The instruction set that torch's own CPU kernels (ATen), oneDNN's convolutions and MKL's matrix products are held
#: to when a recipe trains (``pin_cpu_arithmetic``). Each library otherwise takes the widest set the CPU has (AVX2,
#: AVX-512, ...), and each set rounds differently: on one machine, any one of the three taken down to another set
#: changed 14 of the 15 tensors of a one-epoch route encoder. Held to AVX2, as the shipped encoders were trained, any
#: x86 CPU with AVX2 runs the same arithmetic.
CPU_ARITHMETIC = {"ATEN_CPU_CAPABILITY": "avx2", "ONEDNN_MAX_CPU_ISA": "AVX2", "MKL_CBWR": "AVX2"}


def resolve_device(name: str, flag: str = "--device") -> torch.device:
    """The torch device ``name`` (``"auto"``, ``"cpu"``, ``"cuda"`` or ``"cuda:N"``) stands for here.

    Raises:
        InputError: An unknown name, or CUDA asked for where torch sees no GPU (or not GPU ``N``);
            the message names ``flag`` and the value.
    """
    if not isinstance(name, str) or not (name in DEVICES or (name.startswith("cuda:") and name[5:].isdigit())):
        raise InputError(f"{flag} {name!r}: expected one of {', '.join(DEVICES)} (or cuda:N)")
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name.startswith("cuda"):
        if not torch.cuda.is_available():
            raise InputError(f"{flag} {name}: torch sees no CUDA GPU on this machine (torch {torch.__version__}, "
                             f"built for CUDA {torch.version.cuda}); use --device cpu or auto")
        index = int(name[5:]) if ":" in name else 0
        if index >= torch.cuda.device_count():
            raise InputError(f"{flag} {name}: torch sees {torch.cuda.device_count()} CUDA GPU(s)")
    return torch.device(name)


@contextlib.contextmanager
def full_float32(device: torch.device) -> Iterator[None]:
    """Full float32 for cuDNN's float32 convolutions in the span, where ``device`` is a CUDA GPU; elsewhere nothing.

    torch lets cuDNN round a float32 convolution's inputs to TF32 (10 bits of mantissa) by default. The route
    encoder's field is a shortest path over the move costs its convolutions give, so that rounding moves every value
    away from the field the CPU computes, the one the validation chose. The setting is torch's process-wide switch;
    the one before is restored on the way out.
    """
    if device.type != "cuda":
        yield
        return
    conv = getattr(torch.backends.cudnn, "conv", None)
    if conv is not None and hasattr(conv, "fp32_precision"):  # torch 2.9 on
        owner, name, value = conv, "fp32_precision", "ieee"
    else:
        owner, name, value = torch.backends.cudnn, "allow_tf32", False
    before = getattr(owner, name)
    setattr(owner, name, value)
    try:
        yield
    finally:
        setattr(owner, name, before)


def move_to(module: torch.nn.Module, device: torch.device) -> torch.nn.Module:
    """``module.to(device)``, skipped where every parameter and buffer of ``module`` is there already.

    A sampler is made around a kept network for each query (the comparison's runs, a ``ModelCache``); ``Module.to``
    walks every submodule even where nothing moves (about 0.2 ms for the route encoder, most of making its sampler).
    ``cuda`` without an index stands for the current GPU, as in ``Module.to``.
    """
    want = device
    if device.type == "cuda" and device.index is None:
        want = torch.device("cuda", torch.cuda.current_device())
    if all(t.device == want for t in itertools.chain(module.parameters(), module.buffers())):
        return module
    return module.to(device)


def deterministic(device: torch.device) -> None:
    """Ask torch for deterministic kernels on ``device`` (cuDNN's autotuner off, deterministic convolutions).

    On the CPU this changes nothing; on a GPU the same seed then gives the same weights on the same
    machine, as on the CPU (a few GPU operations have no deterministic kernel and stay as they are).
    """
    if device.type == "cuda":
        torch.backends.cudnn.deterministic = True
        torch.backends.cudnn.benchmark = False


def pin_cpu_arithmetic() -> dict[str, str]:
    """Hold torch, oneDNN and MKL to ``CPU_ARITHMETIC`` (a variable the user set stays as set); what now holds.

    Call it before the process's first CPU tensor operation: torch settles its kernels' instruction set then,
    once. The answer (the three variables and the set torch reports using) goes into a training record, so
    two machines' records say whether they ran the same arithmetic.
    """
    for name, value in CPU_ARITHMETIC.items():
        os.environ.setdefault(name, value)
    return {**{name: os.environ[name] for name in CPU_ARITHMETIC},
            "torch_cpu_capability": torch.backends.cpu.get_cpu_capability()}
