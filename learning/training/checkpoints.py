"""A policy training run's checkpoints: SB3 zips that also carry the sampler config and the run state.

``<run>/checkpoint.zip`` is the commit point a resumed run starts from (``read_state``);
``imitation.zip`` and ``final.zip`` are written the same way, and ``final.zip`` is what
``learning.PolicySampler.load`` reads (its config under :data:`CONFIG_KEY`).
"""

from __future__ import annotations

import io
import json
import os
import time
import zipfile
from pathlib import Path

from learning.models.checkpoint import read_sb3_zip
from learning.training.config import TrainConfig
from learning.training.imitation import Dataset
from learning.training.logs import ResumableCSV
from planners.base.fileio import InputError, atomic_path, atomic_write_text, check_number, short_repr

#: Key of the run state inside a checkpoint's ``data`` entry.
STATE_KEY = "samplergym_state"
#: Key of the sampler config inside a checkpoint's ``data`` entry (read by ``PolicySampler.load``).
CONFIG_KEY = "samplergym_config"


def save_model(model, cfg: TrainConfig, path: Path, state: dict) -> None:
    """Write ``model`` as an SB3 zip whose ``data`` also carries the sampler config and the run state.

    The two entries are added to the zip SB3 writes rather than set on the model, so nothing of
    ours lives in SB3's object; the file appears whole or not at all.
    """
    buf = io.BytesIO()
    model.save(buf)
    buf.seek(0)
    with atomic_path(path) as tmp, zipfile.ZipFile(buf) as src, zipfile.ZipFile(tmp, "w") as dst:
        for item in src.infolist():
            blob = src.read(item.filename)
            if item.filename == "data":
                data = json.loads(blob)
                data[CONFIG_KEY], data[STATE_KEY] = cfg.sampler_config(), state
                blob = json.dumps(data, indent=4).encode()
            dst.writestr(item, blob)


def commit_checkpoint(model, cfg: TrainConfig, run: Path, state: dict, log: ResumableCSV,
                      data: Dataset | None = None) -> None:
    """One checkpoint, written so that a kill at any instant leaves the previous one or this one.

    ``checkpoint.zip`` is the commit point: it holds the weights, the optimiser and the run state.
    The DAgger data is written before it and only grows, so the state's row count tells how much of
    it belongs to the checkpoint; log rows after ``log_rows`` are dropped on resume the same way.
    ``state.json`` is a copy for people, written last and never read back.
    """
    state = {**state, "log_rows": log.rows, "log_time": time.time()}
    if data is not None:
        with atomic_path(run / "dagger_data.npz") as tmp:
            data.save(tmp)
        state["dagger_rows"] = len(data)
    save_model(model, cfg, run / "checkpoint.zip", state)
    atomic_write_text(run / "state.json", json.dumps(state, indent=2) + "\n")


def read_state(run: str | os.PathLike) -> dict | None:
    """The run state committed in ``<run>/checkpoint.zip``, or None if the run has no checkpoint yet."""
    ckpt = Path(run) / "checkpoint.zip"
    if not ckpt.is_file():
        return None
    data, _ = read_sb3_zip(ckpt)
    state = data.get(STATE_KEY)
    if not isinstance(state, dict) or not {"phase", "round", "ppo_steps", "log_rows"} <= state.keys():
        raise InputError(f"{ckpt} carries no training state: it was not written by this version of "
                         "scripts/train.py; start the run again without --resume")
    if state["phase"] not in ("bc", "ppo"):
        raise InputError(f"{ckpt}: training state phase = {short_repr(state['phase'])}, expected 'bc' or 'ppo'")
    for key, low in (("round", -1), ("ppo_steps", 0), ("log_rows", 0), ("dagger_rows", 0)):
        if key in state:
            check_number(f"{ckpt}: training state", key, state[key], integer=True, low=low)
    if "log_time" in state:
        check_number(f"{ckpt}: training state", "log_time", state["log_time"])
    if state["phase"] == "bc" and state["round"] >= 0 and "dagger_rows" not in state:
        raise InputError(f"{ckpt}: training state in DAgger round {state['round']} has no dagger_rows")
    return state
