"""Checkpoints from other people: loading reads JSON and tensors only, and every bad value is named."""

from __future__ import annotations

import base64
import io
import json
import os
import pickle
import zipfile
from pathlib import Path

import pytest
import torch

from learning import PolicySampler
from learning.models.shipped import SHIPPED_POLICY
from planners.base.fileio import InputError

SHIPPED = SHIPPED_POLICY


class _Mkdir:
    """Unpickles into a call of ``os.mkdir(target)``: what a hostile checkpoint would carry."""

    def __init__(self, target: str) -> None:
        self.target = target

    def __reduce__(self):
        return os.mkdir, (self.target,)


def _rewrite(dst: Path, **entries: bytes) -> Path:
    """The shipped checkpoint with some entries replaced."""
    with zipfile.ZipFile(SHIPPED) as src, zipfile.ZipFile(dst, "w") as out:
        for name in src.namelist():
            out.writestr(name, entries.pop(name, None) or src.read(name))
        for name, blob in entries.items():
            out.writestr(name, blob)
    return dst


def _data(**changes) -> bytes:
    with zipfile.ZipFile(SHIPPED) as zf:
        data = json.loads(zf.read("data"))
    for key, value in changes.items():
        data[key] = value
    return json.dumps(data).encode()


def _config(**changes) -> bytes:
    with zipfile.ZipFile(SHIPPED) as zf:
        config = json.loads(zf.read("data"))["samplergym_config"]
    return _data(samplergym_config={**config, **changes})


def test_a_pickled_call_in_data_does_not_run(tmp_path):
    target = tmp_path / "pwned"
    payload = base64.b64encode(pickle.dumps(_Mkdir(str(target)))).decode()
    hostile = _rewrite(tmp_path / "guided.zip",
                       data=_data(policy_kwargs={":type:": "<class 'dict'>", ":serialized:": payload}))
    # Stable-Baselines3's own loader runs it: the file really is hostile
    from stable_baselines3.common.save_util import load_from_zip_file

    load_from_zip_file(hostile, device="cpu", print_system_info=False)
    assert target.is_dir()
    target.rmdir()
    sampler = PolicySampler.load(hostile)  # the sampler needs none of those entries
    assert isinstance(sampler, PolicySampler)
    assert not target.exists()


def test_a_pickled_call_in_the_weights_does_not_run(tmp_path):
    target = tmp_path / "pwned"
    buf = io.BytesIO()
    torch.save({"w": _Mkdir(str(target))}, buf)  # torch.save pickles anything
    hostile = _rewrite(tmp_path / "guided.zip", **{"policy.pth": buf.getvalue()})
    with pytest.raises(InputError, match="guided.zip.*policy.pth"):
        PolicySampler.load(hostile)
    assert not target.exists()


@pytest.mark.parametrize("key, value", [
    ("uniform_floor", float("nan")), ("uniform_floor", -1), ("uniform_floor", 5), ("uniform_floor", "0.05"),
    ("max_iterations", -5), ("max_iterations", 1.5), ("batch", 0), ("batch", True), ("step_size", 0),
    ("step_size", float("inf")), ("obs_version", 99),
])
def test_bad_config_values_are_refused_by_name(tmp_path, key, value):
    bad = _rewrite(tmp_path / "bad.zip", data=_config(**{key: value}))
    with pytest.raises(InputError, match=rf"bad.zip.*{key}") as exc:
        PolicySampler.load(bad)
    assert repr(value)[:3] in str(exc.value) or key == "obs_version"


def test_garbage_weights_are_named(tmp_path):
    bad = _rewrite(tmp_path / "garbage.zip", **{"policy.pth": b"\x80\x04garbage" * 10})
    with pytest.raises(InputError, match="garbage.zip.*policy.pth.*not a readable tensor file"):
        PolicySampler.load(bad)


def test_weights_of_the_wrong_shape_are_refused(tmp_path):
    with zipfile.ZipFile(SHIPPED) as zf:
        state = torch.load(io.BytesIO(zf.read("policy.pth")), weights_only=True)
    state["action_net.weight"] = state["action_net.weight"][:5]
    state["action_net.bias"] = state["action_net.bias"][:5]
    buf = io.BytesIO()
    torch.save(state, buf)
    with pytest.raises(InputError, match="shape.zip.*actions 5"):
        PolicySampler.load(_rewrite(tmp_path / "shape.zip", **{"policy.pth": buf.getvalue()}))
    state = torch.load(io.BytesIO(zipfile.ZipFile(SHIPPED).read("policy.pth")), weights_only=True)
    state["mlp_extractor.policy_net.0.weight"][0, 0] = float("nan")
    buf = io.BytesIO()
    torch.save(state, buf)
    with pytest.raises(InputError, match="nan.zip.*NaN"):
        PolicySampler.load(_rewrite(tmp_path / "nan.zip", **{"policy.pth": buf.getvalue()}))


def test_a_zip_bomb_is_refused_from_its_header(tmp_path, monkeypatch):
    import learning.models.checkpoint

    monkeypatch.setattr(learning.models.checkpoint, "MAX_ENTRY_BYTES", 1000)
    with pytest.raises(InputError, match="guided.zip.*unpacks to"):
        PolicySampler.load(SHIPPED)


def test_the_shipped_route_teacher_matches_its_recipe():
    # the recipe in route_teacher.json is what learning/data/README.md says reproduces the file: the file must agree
    # (the shipped encoder is its student: tests/test_distill.py)
    import json

    from learning.models.route_net import load_route_net
    from learning.models.shipped import SHIPPED_ROUTE_TEACHER

    recipe = json.loads(SHIPPED_ROUTE_TEACHER.with_suffix(".json").read_text())["recipe"]
    net = load_route_net(SHIPPED_ROUTE_TEACHER)
    assert (net.channels, net.depth, net.attention_layers, net.step) == (
        recipe["channels"], recipe["depth"], recipe["attention"], recipe["step"])
    assert net.block * recipe.get("blocks_per_step", 1) == recipe["step"]
    # a U-Net's fields on larger maps are scaled from its largest training side; value iteration's need no scaling
    assert net.trained_side == (max(recipe["size"]) if recipe.get("kind", "unet") == "unet" else 0)
    assert type(net).__name__ == {"unet": "RouteNet", "vin": "RouteVIN"}[recipe.get("kind", "unet")]
