"""Reading Stable-Baselines3 checkpoint zips without running anything in them.

An SB3 ``.zip`` holds ``data`` (JSON, in which values that JSON cannot express are pickled under a
``":serialized:"`` key), ``policy.pth`` and ``policy.optimizer.pth`` (``torch.save`` files) and
version notes. ``stable_baselines3`` loads ``data`` by unpickling those values, so a file from
someone else can run code on load. This reader takes ``data`` as plain JSON, never looks inside a
``":serialized:"`` value, and reads tensors with ``torch.load(weights_only=True)``, which refuses
anything but tensors and plain containers. Every failure is an ``InputError`` naming the file.
"""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path

import torch

from planners.base.fileio import InputError, loads_json, short_repr

#: Largest entry the reader decompresses: a policy of a few MB is the norm; this stops zip bombs.
MAX_ENTRY_BYTES = 256 * 1024 * 1024
#: Largest ratio of unpacked to packed size accepted for an entry over 1 MiB: tensors and JSON compress
#: by a few times at most, while a zip bomb's entries claim hundreds or a thousand times their size.
MAX_RATIO = 50
#: Largest ``data`` entry (JSON): Stable-Baselines3 writes tens of KB; parsed JSON takes several times its size.
MAX_DATA_BYTES = 16 * 1024 * 1024


def read_sb3_zip(path: str | os.PathLike, *, weights: str = "policy.pth") -> tuple[dict, dict]:
    """The ``data`` entry (JSON, ``":serialized:"`` values left unread) and the ``weights`` state dict.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        InputError: anything else that makes the file unreadable as a checkpoint.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"policy checkpoint {path} does not exist")
    try:
        with zipfile.ZipFile(path) as zf:
            data_blob = _entry(zf, path, "data", MAX_DATA_BYTES)
            weights_blob = _entry(zf, path, weights, MAX_ENTRY_BYTES)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - zipfile, zlib and OSError all signal a damaged archive
        raise InputError(f"{path} is not a readable checkpoint zip: {type(exc).__name__}: {exc}") from None
    data = loads_json(data_blob, f"{path}: its 'data' entry")
    if not isinstance(data, dict):
        raise InputError(f"{path}: its 'data' entry is a {type(data).__name__}, expected a JSON object")
    try:
        state = torch.load(io.BytesIO(weights_blob), map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - untrusted bytes: whatever torch's reader raises, the file is bad
        raise InputError(f"{path}: its '{weights}' entry is not a readable tensor file "
                         f"({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})") from None
    if not isinstance(state, dict) or not all(isinstance(k, str) and isinstance(v, torch.Tensor)
                                              for k, v in state.items()):
        raise InputError(f"{path}: its '{weights}' entry is not a state dict of named tensors")
    return data, state


def _entry(zf: zipfile.ZipFile, path: Path, name: str, limit: int) -> bytes:
    try:
        info = zf.getinfo(name)
    except KeyError:
        raise InputError(f"{path} has no '{name}' entry: not a Stable-Baselines3 checkpoint") from None
    # every check on the declared sizes comes before anything is decompressed
    if info.file_size > limit:
        raise InputError(f"{path}: entry '{name}' unpacks to {info.file_size} bytes, more than the "
                         f"{limit} a policy checkpoint needs")
    if info.file_size > 1 << 20 and info.file_size > MAX_RATIO * max(info.compress_size, 1):
        raise InputError(f"{path}: entry '{name}' claims to unpack {info.compress_size} bytes to {info.file_size} "
                         f"(more than {MAX_RATIO} times): not a checkpoint (a zip bomb?)")
    with zf.open(info) as f:
        blob = f.read(info.file_size + 1)  # never more than the declared size, however the data lies
    if len(blob) != info.file_size:
        raise InputError(f"{path}: entry '{name}' unpacks to another size than its header's {info.file_size} bytes")
    return blob


def read_config_state(path: str | os.PathLike, what: str, writer: str) -> tuple[Path, dict, dict]:
    """``(path, config, state)`` of a ``{"config": {...}, "state": {...}}`` model file, nothing in it run.

    Read with ``torch.load(weights_only=True)``. ``what`` names the kind of file in messages ("route encoder"),
    ``writer`` the function that writes it. A missing file is a ``FileNotFoundError``; every other problem an
    ``InputError`` naming the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{what} {path} does not exist")
    try:
        blob = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - whatever torch raises on a bad file, name the file
        raise InputError(f"{path} is not a{'n' if what[0] in 'aeiou' else ''} {what} file: {type(exc).__name__}: "
                         f"{short_repr(str(exc), 300)}") from None
    if not (isinstance(blob, dict) and isinstance(blob.get("config"), dict) and isinstance(blob.get("state"), dict)):
        raise InputError(f"{path}: expected {{'config': {{...}}, 'state': {{...}}}} as {writer} writes")
    return path, dict(blob["config"]), blob["state"]


def load_finite_state(net: torch.nn.Module, state: dict, path: Path, fits: str) -> torch.nn.Module:
    """``net`` with ``state`` loaded, in evaluation mode.

    NaN or infinite weights, or weights that do not fit (``fits`` names what they should fit), are an ``InputError``
    naming ``path``.
    """
    for name, tensor in state.items():
        if isinstance(tensor, torch.Tensor) and tensor.is_floating_point() and not torch.isfinite(tensor).all():
            raise InputError(f"{path}: tensor {short_repr(name)} holds NaN or infinite weights")
    try:
        net.load_state_dict(state)
    except (RuntimeError, TypeError, ValueError) as exc:
        raise InputError(f"{path}: the weights do not fit {fits}: {short_repr(str(exc), 300)}") from None
    return net.eval()
