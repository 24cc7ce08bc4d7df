"""Where the shipped models live: package data under ``learning/data``, found from any install and directory.

``learning/data/README.md`` says how each file was made and how to reproduce it.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

_DATA = Path(str(files("learning").joinpath("data")))
#: The shipped sampler policy: an SB3 zip carrying its SamplerGym config (``PolicySampler.load()``).
SHIPPED_POLICY = _DATA / "guided.zip"
#: The shipped route encoder (``load_route_net``; ``RouteSampler.load()``).
SHIPPED_ROUTE = _DATA / "route.pt"
#: The encoder the shipped one is distilled from (``scripts/distill_route.py``'s default teacher).
SHIPPED_ROUTE_TEACHER = _DATA / "route_teacher.pt"
#: The shipped 6-DoF orientation model (``load_orientation_net``; ``make_sampler("rigid_route")``).
SHIPPED_RIGID_ORIENTATION = _DATA / "rigid_route.pt"
#: Samples per forward pass the shipped policy was validated at: chosen on the generated families' tuning
#: maps by ``scripts/evaluate.py`` (its training batch is 8).
SHIPPED_POLICY_BATCH = 2
