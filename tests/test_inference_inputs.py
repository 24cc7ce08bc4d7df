"""Issue 18.4: at inference the learned samplers see only what a planner has (map, tree, start, goal).

No grid search, distance field or shortest path: those are the privileged expert's (training only).
Checked twice: statically, no module on the inference path imports the grid search or the expert; and
at run time, with every grid-search entry point and the expert made to raise, the policy plans the
same runs as before, fused into RRT's loop and not.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from learning import PolicySampler
from learning.models.shipped import SHIPPED_POLICY
from planners import RRT
from planners.maps.generators import TEST_SEED0, generate

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = SHIPPED_POLICY
INFERENCE = ["learning/samplers/policy.py", "learning/samplers/route.py", "learning/samplers/ablation.py",
             "learning/models/fast_policy.py", "learning/models/checkpoint.py", "learning/models/route_net.py",
             "learning/models/threads.py", "planners/fused.py",
             *(str(p.relative_to(ROOT)) for p in sorted((ROOT / "planners" / "guidance").glob("*.py"))),
             *(str(p.relative_to(ROOT)) for p in sorted((ROOT / "planners" / "kernels").glob("*.py")))]
PRIVILEGED = ("planners.maps.gridsearch", "planners.maps.generators", "learning.references.expert")


def _imports(path: Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{a.name}" for a in node.names)
    return names


@pytest.mark.parametrize("module", INFERENCE)
def test_no_inference_module_imports_a_privileged_one(module):
    bad = {n for n in _imports(ROOT / module) if n.startswith(PRIVILEGED)}
    assert not bad, f"{module} imports {sorted(bad)}, which inference must not use"


@pytest.mark.parametrize("learned", ["policy", "route"])
def test_the_learned_samplers_plan_the_same_runs_with_grid_search_and_expert_disabled(monkeypatch, learned):
    from learning.references import expert
    from learning.samplers.route import RouteSampler, shipped_sampler
    from learning.training.route import train_route_net
    from planners.maps import gridsearch

    problems = [generate(f, TEST_SEED0 + 3, 96) for f in ("bugtrap", "maze", "narrow_passage")]
    if learned == "policy":
        samplers = [PolicySampler.load(SHIPPED, fuse=fuse) for fuse in (True, False)]
    else:  # the shipped encoder, and a small one trained (with the grid search's targets) before it is disabled
        net = train_route_net([generate(f, 1, 64) for f in ("bugtrap", "maze")], channels=4, depth=2, epochs=1,
                              log=lambda _: None)
        samplers = [shipped_sampler(), RouteSampler(net), RouteSampler(None)]

    def runs():
        out = []
        for sampler in samplers:
            for p in problems:
                r = RRT(p, step_size=4.0, sampler=sampler, seed=0).solve(max_iterations=3000)
                out.append((r.iterations, r.num_vertices, r.path.tobytes()))
        return out

    before = runs()

    def forbidden(*args, **kwargs):
        raise AssertionError("inference used the privileged grid search or expert")

    for name in ("distance_field", "shortest_path", "shortest_path_length", "connected", "free_components",
                 "_dijkstra", "_search", "_flood", "_components"):
        monkeypatch.setattr(gridsearch, name, forbidden)
    monkeypatch.setattr(expert.GeodesicExpert, "__init__", forbidden)
    after = runs()
    assert after == before
    assert np.mean([b[0] for b in before]) < 3000  # the runs solve, so the policy did its work
