"""The packages' layering: ``planners`` never imports torch, gymnasium, ``envs`` or ``learning``; nothing outside
``planners`` imports its internal ``planners.kernels`` (compiled samplers go through ``planners.fused``)."""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
FORBIDDEN = ("torch", "gymnasium", "stable_baselines3", "envs", "learning")


def _modules(path: Path) -> set[str]:
    """Full names of the modules a file imports, anywhere in it (lazy imports inside functions too)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
            names |= {f"{node.module}.{a.name}" for a in node.names}  # `from planners import kernels`
    return names


def _imports(path: Path) -> set[str]:
    """Top-level module names a file imports."""
    return {name.split(".")[0] for name in _modules(path)}


def test_no_planners_module_imports_the_learning_stack():
    bad = {str(p.relative_to(REPO)): sorted(_imports(p) & set(FORBIDDEN))
           for p in sorted((REPO / "planners").rglob("*.py"))}
    assert {k: v for k, v in bad.items() if v} == {}


def test_importing_planners_loads_none_of_it():
    code = ("import json, sys; import planners, planners.tools.workflow, planners.guidance.frontier; "
            f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {FORBIDDEN!r})))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True,
                         env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert json.loads(out.stdout) == []


def test_learning_and_envs_never_reach_into_the_planning_cores_kernels():
    bad = {str(p.relative_to(REPO)): sorted(m for m in _modules(p) if m.startswith("planners.kernels"))
           for package in ("learning", "envs") for p in sorted((REPO / package).rglob("*.py"))}
    assert {k: v for k, v in bad.items() if v} == {}
