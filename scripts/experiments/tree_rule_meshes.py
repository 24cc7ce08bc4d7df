"""Which of ``rigid_route``'s rules the trees should take on mesh worlds: the trees' own or the roadmaps'.

    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --part tuning --scenes 4 --seeds 2 \\
        --time-limit 10 --out results/tree_rule_meshes.jsonl
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --omplapp DIR --problems Twistycooler Apartment \\
        --planners RRTConnect --seeds 4 --time-limit 20 --out results/tree_rule_omplapp.jsonl
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --part tuning --scenes 8 --seeds 2 \\
        --rules trees roadmap --rule 'pw0={"passage_weight": 0}' --out results/tree_rule_pw.jsonl
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --families twist --part tuning --scenes 8 \\
        --seeds 2 --rules roadmap --rule 'pw0={"passage_weight": 0}' --out results/tree_rule_twist.jsonl
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --families twist --part tuning --scenes 8 \\
        --seeds 2 --rules roadmap --rule 'r0={"uniform_ramp": 0}' --rule 'r1k={"uniform_ramp": 1000}' --out FILE
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --part tuning --scenes 8 --seeds 2 \\
        --rules roadmap --rule 'u2500={"uniform_first": 2500}' --rule 'u10000={"uniform_first": 10000}' --out FILE
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --families twist --part tuning --scenes 8 \\
        --seeds 2 --rules roadmap --rule 'f4={"follow": 4}' --rule 'g4h={"follow": 4, "follow_share": 0.5}' --out FILE
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --part tuning --scenes 4 --seeds 2 \\
        --rules roadmap shipped --rule 'rf75={"route_fraction": 0.75}' --out FILE   # also --families twist --scenes 8
    PYTHONPATH=$PWD python scripts/experiments/tree_rule_meshes.py --omplapp DIR --problems Apartment \\
        --planners RRTConnect --seeds 8 --rules uniform roadmap shipped --rule 'rf75={"route_fraction": 0.75}' \\
        --time-limit 20 --out FILE

``make_sampler("rigid_route")`` hands RRT and RRT-Connect the trees' rule (``SHIPPED_RIGID_SETTINGS``) on box worlds
and a roadmap the roadmaps' (``SHIPPED_RIGID_ROADMAP``: the chain's rotation from the start, every route sample on the
route, no uniform angles, no angle noise); on mesh worlds the trees take the roadmaps' rule too, as this script's runs
chose, and turn their route samples to uniform angles over their first 4,000 samples (``uniform_ramp``, which a
roadmap drops; chosen on the twisted slot and the families here), over which their share of uniform states comes from
none to their own quarter (``TREES_KEEP``; chosen on Apartment, the slot and the families at a mesh world's step).
This runs the trees with each rule (``--rules``; ``uniform``: the planner's own sampling; ``shipped``:
``make_sampler("rigid_route")`` as it ships, whose mesh trees come to their own share of uniform states over the ramp;
``--rule NAME=JSON``: the roadmaps' rule with some settings changed) under a
time limit, on a part of the training box-scene families written as mesh worlds (``mesh_scene`` at the
default motion resolution; a scene whose box witness meets its meshes is left out, as the mesh scene set leaves it
out; ``--families twist``: the twisted slot below, a passage only a roll about the body's long axis passes), or
with ``--omplapp DIR`` on OMPL.app's ``.cfg`` problems named by ``--problems``. It prints per planner and
rule the runs solved, the median time (the sampler's set-up included; an unsolved run at the limit) and the median
iterations (``--setup seed``: at the seed project's set-ups, whose small step takes a query thousands of iterations),
and writes every run to ``--out`` (JSON lines). Choose on the tuning part and OMPL.app's tuning problems only.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from learning.samplers.rigid_route import ROADMAP_SETTINGS, SHIPPED_RIGID_ROADMAP, SHIPPED_RIGID_SETTINGS
from planners.maps.generators import TUNING_SEED0, VALIDATION_SEED0

#: The rules compared: sampler settings handed to ``make_sampler("rigid_route", ...)`` (None: no sampler). The trees'
#: rule is given whole: settings a user gives hold on every world, where ``make_sampler("rigid_route")`` alone gives
#: a tree on a mesh world the roadmaps' rule. It draws along the whole route (``follow`` 0), as the runs the docs quote
#: did, whatever a box world's trees take (``--rule`` asks ``follow`` of meshes).
RULES = {"uniform": None, "trees": {**{k: SHIPPED_RIGID_SETTINGS[k] for k in ROADMAP_SETTINGS}, "follow": 0.0},
         "roadmap": dict(SHIPPED_RIGID_ROADMAP), "shipped": {}}
_PROBLEMS: dict = {}


#: The twisted slot (``--families twist``; this script's own tuning material, never a test): a compact body (6 x 5 x 3,
#: Twistycool's robot is compact too) in a 34 x 30 x 30 workspace, a wall across x, 1.5 to 2.2 thick (thinner than the
#: body's short side, so the body cannot lie inside it), with a slot 7.0 to 7.4 by 4.9 to 5.1 rolled 42 to 48 degrees
#: either way about x; the start and the goal stand 0.8 to 2 body lengths before and after the wall, within 5 of the
#: slot's axis, at random angles, as Twistycool's face its hole. The body passes with its 5 x 3 face rolled with the
#: slot within about 30 degrees: no axis-aligned orientation fits, as none fits Twistycool's passage. Written as meshes
#: directly (a box scene has no rolled wall): the slab with a square hole around the slot, and four boxes in the slot's
#: own frame that fill the hole but for the slot. Every scene has a witness path (``verify_scene``) through the slot.
TWIST_SEED0 = {"tuning": TUNING_SEED0, "validation": VALIDATION_SEED0}
TWIST_DRAWS = 8
#: The twisted slot's workspace and body (the box scenes' are 100 x 60 x 40 and 10 x 5 x 2.5).
TWIST_SPACE = (34.0, 30.0, 30.0)
TWIST_BODY = (6.0, 5.0, 3.0)
#: Half the side of the square hole around the slot, which the rolled boxes fill but for the slot.
TWIST_HOLE = 5.0


def _rolled_box(x0: float, x1: float, u: tuple, v: tuple, centre: tuple, phi: float):
    """The box ``[x0, x1] x u x v`` of the slot's frame (rolled ``phi`` about x, origin at ``centre`` in (y, z))."""
    from planners.worlds.rigid_scenes import box_mesh

    verts, faces = box_mesh((x0, u[0], v[0], x1, u[1], v[1]))
    c, s = math.cos(phi), math.sin(phi)
    y = centre[0] + c * verts[:, 1] - s * verts[:, 2]
    z = centre[1] + s * verts[:, 1] + c * verts[:, 2]
    return np.stack([verts[:, 0], y, z], axis=1), faces  # a rotation keeps the faces' winding


def _draw_near(rng: np.random.Generator, world, low: tuple, high: tuple, seed: int) -> np.ndarray:
    """A state between x ``low[0]`` and ``high[0]``, within 5 of the slot's axis, at random angles, well clear."""
    from planners.worlds.rigid_scenes import QUERY_CLEARANCE

    for _ in range(4000):
        q = np.concatenate([rng.uniform((low[0], low[1] - 5.0, low[2] - 5.0), (high[0], high[1] + 5.0, high[2] + 5.0)),
                            rng.uniform(-math.pi, math.pi, 3)])
        if world.is_valid(q) and world.clearance(q) > QUERY_CLEARANCE:
            return q
    raise RuntimeError(f"twist-{seed}: no state with clearance {QUERY_CLEARANCE:g} between x {low[0]} and {high[0]}")


def _twist_reach(phi: float) -> float:
    """How far the rolled boxes reach from the slot's centre along y and z (their half side, in the slot's frame)."""
    return TWIST_HOLE * (abs(math.cos(phi)) + abs(math.sin(phi))) + 0.5


def twist_geometry(rng: np.random.Generator) -> tuple:
    """One twisted slot: the wall's middle and thickness, the slot's sides, its roll and its centre in (y, z)."""
    size = TWIST_SPACE
    c, t = rng.uniform(0.42 * size[0], 0.58 * size[0]), rng.uniform(1.5, 2.2)
    w, h = rng.uniform(7.0, 7.4), rng.uniform(4.9, 5.1)
    phi = math.radians(rng.uniform(42.0, 48.0)) * (1 if rng.random() < 0.5 else -1)
    reach = _twist_reach(phi)
    centre = tuple(float(rng.uniform(3.0 + reach * math.sqrt(2), size[k] - 3.0 - reach * math.sqrt(2))) for k in (1, 2))
    return float(c), float(t), float(w), float(h), phi, centre


def twisted_slot(seed: int):
    """The twisted-slot scene of ``seed`` as a mesh world (a ``Problem``), with a witness path through its slot."""
    from planners.base.problem import Problem
    from planners.worlds.mesh import DEFAULT_DELTA_FRACTION, MeshWorld
    from planners.worlds.rigid_scenes import GOAL_DISTANCE, box_mesh, carve, verify_scene

    rng = np.random.default_rng(seed)
    size = np.array(TWIST_SPACE)
    half = np.array(TWIST_BODY) / 2
    length = TWIST_BODY[0]
    for attempt in range(TWIST_DRAWS):
        c, t, w, h, phi, centre = twist_geometry(rng)
        reach, hole = _twist_reach(phi), TWIST_HOLE
        a, b = c - t / 2, c + t / 2
        square = np.array([a - 1.0, centre[0] - hole, centre[1] - hole, b + 1.0, centre[0] + hole, centre[1] + hole])
        meshes = [box_mesh(box) for box in carve(np.array([a, 0.0, 0.0, b, size[1], size[2]]), [square])]
        meshes += [_rolled_box(a, b, u, v, centre, phi) for u, v in
                   [((-reach, -w / 2), (-reach, reach)), ((w / 2, reach), (-reach, reach)),
                    ((-w / 2, w / 2), (-reach, -h / 2)), ((-w / 2, w / 2), (h / 2, reach))]]
        verts = np.concatenate([v for v, _ in meshes])
        faces = np.concatenate([f + 8 * i for i, (_, f) in enumerate(meshes)])
        world = MeshWorld((verts, faces), box_mesh(np.concatenate([-half, half])), low=(0, 0, 0), high=TWIST_SPACE,
                          delta=DEFAULT_DELTA_FRACTION * float(np.linalg.norm(size)), name=f"twist-{seed}")
        start = _draw_near(rng, world, (a - 2 * length, *centre), (a - 0.8 * length, *centre), seed)
        goal = _draw_near(rng, world, (b + 0.8 * length, *centre), (b + 2 * length, *centre), seed)
        problem = Problem(world, start, goal, goal_tolerance=GOAL_DISTANCE, metric="cossin", name=f"twist-{seed}")
        off = length / 2 + 1.5
        before = np.array([a - off, *centre, phi, 0.0, 0.0])
        after = np.array([b + off, *centre, phi, 0.0, 0.0])
        if verify_scene(problem, [(before, after)], seed + 1000 * attempt) is not None:
            return problem
    raise RuntimeError(f"twist-{seed}: no draw of {TWIST_DRAWS} had a witness path")


def _problem(source: tuple):
    if source not in _PROBLEMS:
        if source[0] == "omplapp":
            from planners.worlds.omplapp import load_omplapp_cfg

            _PROBLEMS[source] = load_omplapp_cfg(Path(source[1]) / f"{source[2]}.cfg")
        elif source[1] == "twist":
            _PROBLEMS[source] = twisted_slot(source[2])
        else:
            from planners.worlds.mesh import DEFAULT_DELTA_FRACTION
            from planners.worlds.rigid_scenes import mesh_scene, rigid_scene

            _, family, scene_seed = source
            world = rigid_scene(family, scene_seed).world
            diagonal = math.dist(world.low3, world.high3)
            try:
                _PROBLEMS[source] = mesh_scene(family, scene_seed, delta=DEFAULT_DELTA_FRACTION * diagonal)
            except RuntimeError as e:  # the box witness meets the meshes: not a mesh scene (as MeshSceneSet)
                _PROBLEMS[source] = str(e)
    return _PROBLEMS[source]


def _run(task: tuple) -> dict:
    source, planner, seed, (rule, settings), limit, setup = task
    from learning.evaluation.rigid import CAPS, planner_setup
    from learning.samplers.registry import make_sampler
    from planners import make_planner
    from planners.base.planner import compile_seconds

    row = {"source": [source[-1]] if source[0] == "omplapp" else list(source[1:]), "planner": planner, "seed": seed,
           "rule": rule}
    problem = _problem(source)
    if isinstance(problem, str):
        return {**row, "refused": problem}

    cap, given = None, {}
    if setup == "seed":  # the seed project's set-ups: their step, goal distance and iteration cap
        problem, given = planner_setup(planner, problem)
        cap = CAPS[planner]

    def kwargs() -> dict:  # a fresh sampler for each run, bound in the timed run
        return given if settings is None else {**given, "sampler": make_sampler("rigid_route", **settings)}

    make_planner(planner, problem, seed=0, **kwargs()).solve(max_iterations=2)  # compile outside the timing
    t, c = time.perf_counter(), compile_seconds()
    r = make_planner(planner, problem, seed=seed, **kwargs()).solve(max_iterations=cap, time_limit=limit)
    seconds = time.perf_counter() - t - (compile_seconds() - c)
    return {**row, "solved": bool(r.solved), "iterations": int(r.iterations), "seconds": float(seconds),
            "limit": limit}


def main(argv=None) -> int:
    from planners.base.fileio import atomic_write_text
    from planners.worlds.rigid_scenes import TRAINING_FAMILIES, scene_seeds

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--part", default="tuning", choices=["tuning", "validation"])
    ap.add_argument("--scenes", type=int, default=4, help="scenes per family")
    ap.add_argument("--families", nargs="+", default=[f for f in TRAINING_FAMILIES if f != "clutter"],
                    choices=[*TRAINING_FAMILIES, "twist"], help="default: every training family but clutter, whose "
                    "box witnesses meet their meshes; 'twist': the twisted slot, this script's own mesh family")
    ap.add_argument("--omplapp", type=Path, help="OMPL.app's resources/3D folder: run --problems there instead")
    ap.add_argument("--problems", nargs="+", default=["Twistycooler", "Apartment"],
                    help="OMPL.app problems (with --omplapp; default its tuning problems)")
    ap.add_argument("--planners", nargs="+", default=["RRTConnect", "RRT"], choices=["RRTConnect", "RRT"])
    ap.add_argument("--rules", nargs="+", default=["trees", "roadmap"], choices=list(RULES))
    ap.add_argument("--rule", action="append", default=[], metavar="NAME=JSON",
                    help="one more rule: the roadmaps' rule with these settings changed, e.g. "
                    "'pw16={\"passage_weight\": 16}' (repeatable)")
    ap.add_argument("--seeds", type=int, default=2, help="planner seeds per scene (0, 1, ...)")
    ap.add_argument("--time-limit", type=float, default=10.0)
    ap.add_argument("--setup", default="default", choices=["default", "seed"],
                    help="the planners' defaults, or the seed project's set-ups (step 0.01 of the workspace, goal "
                    "distance 1.0, at most 20,000 iterations; learning.evaluation.rigid.planner_setup)")
    ap.add_argument("--processes", type=int, default=2)
    ap.add_argument("--out", type=Path, required=True, help="a JSON-lines file of every run (written at the end)")
    args = ap.parse_args(argv)
    if args.out.is_dir():
        ap.error(f"--out {args.out} is a folder; give a file name")
    if args.omplapp is not None:
        missing = [p for p in args.problems if not (args.omplapp / f"{p}.cfg").is_file()]
        if missing:
            ap.error(f"--omplapp {args.omplapp}: no {', '.join(p + '.cfg' for p in missing)} there")
        sources = [("omplapp", str(args.omplapp), p) for p in args.problems]
    else:
        sources = [("scene", f, s) for f in args.families if f != "twist"
                   for s in scene_seeds(f, args.part, args.scenes)]
        if "twist" in args.families:
            sources += [("scene", "twist", TWIST_SEED0[args.part] + i) for i in range(args.scenes)]
    rules = {name: RULES[name] for name in args.rules}
    for spec in args.rule:
        name, sep, text = spec.partition("=")
        try:
            changes = json.loads(text) if sep else None
        except json.JSONDecodeError as e:
            ap.error(f"--rule {spec!r}: the settings are not JSON ({e})")
        if not name or name in rules or not isinstance(changes, dict):
            ap.error(f"--rule {spec!r}: expected NAME=JSON with a new name and a JSON object of settings")
        unknown = sorted(set(changes) - set(ROADMAP_SETTINGS))
        if unknown:
            ap.error(f"--rule {spec!r}: unknown settings {unknown}; expected some of {list(ROADMAP_SETTINGS)}")
        rules[name] = {**SHIPPED_RIGID_ROADMAP, **changes}
    if not (args.time_limit > 0 and args.seeds > 0 and args.processes > 0):
        ap.error("--time-limit, --seeds and --processes must be positive")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tasks = [(src, planner, seed, item, args.time_limit, args.setup) for src in sources for planner in args.planners
             for seed in range(args.seeds) for item in rules.items()]
    rows = []
    from learning.evaluation.runner import worker_init

    # rules interleaved, so every rule sees the same load; one torch thread per worker, as the evaluation's workers
    with ProcessPoolExecutor(args.processes, initializer=worker_init) as pool:
        for row in pool.map(_run, tasks):
            rows.append(row)
            print(json.dumps(row), flush=True)
    atomic_write_text(args.out, "".join(json.dumps(r) + "\n" for r in rows))
    refused = sorted({"-".join(map(str, r["source"])) for r in rows if "refused" in r})
    if refused:
        print(f"\nleft out (the box scene's witness meets its meshes): {', '.join(refused)}")
    rows = [r for r in rows if "refused" not in r]
    print("\n| scenes | planner | rule | solved | median time (s), unsolved at the limit | median iterations |\n"
          "|---|---|---|---|---|---|")
    groups = sorted({r["source"][0] for r in rows}) if args.omplapp is not None else []
    for group in [*groups, None]:  # each OMPL.app problem, then every run; scenes: every run
        for planner in args.planners:
            for rule in rules:
                rs = [r for r in rows if r["planner"] == planner and r["rule"] == rule
                      and group in (None, r["source"][0])]
                if rs:
                    t = statistics.median(r["seconds"] if r["solved"] else r["limit"] for r in rs)
                    print(f"| {group or 'all'} | {planner} | {rule} | {sum(r['solved'] for r in rs)}/{len(rs)} | "
                          f"{t:.3f} | {statistics.median(r['iterations'] for r in rs):,.0f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
