"""``learning.device.move_to``: a network moves where any of its tensors is elsewhere, and is left alone otherwise."""

from __future__ import annotations

import torch

from learning.device import move_to


def _counting_to(monkeypatch) -> list:
    calls, real = [], torch.nn.Module.to

    def counted(self, *args, **kwargs):
        calls.append(args)
        return real(self, *args, **kwargs)

    monkeypatch.setattr(torch.nn.Module, "to", counted)
    return calls


def test_a_network_already_there_is_not_walked_again(monkeypatch):
    calls = _counting_to(monkeypatch)
    net = torch.nn.Sequential(torch.nn.Conv2d(2, 3, 3), torch.nn.BatchNorm2d(3))
    weights = [p for p in net.parameters()]
    assert move_to(net, torch.device("cpu")) is net and calls == []
    assert all(a is b for a, b in zip(net.parameters(), weights, strict=True))


def test_a_network_elsewhere_moves_whole(monkeypatch):
    calls = _counting_to(monkeypatch)
    net = torch.nn.Sequential(torch.nn.Conv2d(2, 3, 3), torch.nn.BatchNorm2d(3))
    out = move_to(net, torch.device("meta"))
    assert len(calls) == 1
    assert all(t.device.type == "meta" for t in (*out.parameters(), *out.buffers()))
    # one buffer left elsewhere (the batch norm's running mean) is enough to move the whole network
    net = torch.nn.Sequential(torch.nn.Conv2d(2, 3, 3), torch.nn.BatchNorm2d(3)).to("meta")
    net[1].running_mean = torch.zeros(3)
    out = move_to(net, torch.device("meta"))
    assert len(calls) == 3  # the .to above, and move_to's
    assert all(t.device.type == "meta" for t in (*out.parameters(), *out.buffers()))
