"""The comparison: the learned sampler against uniform and goal-biased sampling, on maps it never saw.

    python scripts/evaluate.py                       # default map set, shipped models: 13.5 min on 2 cores
    python scripts/evaluate.py --quick               # fewer test queries, same tuning: 4 min on 2 cores
    python scripts/evaluate.py --policy runs/guided/final.zip --processes 2
    python scripts/evaluate.py --backend ray --address auto                        # on your Ray cluster
    python scripts/evaluate.py --sampler mine=user_ppo.zip@SamplerGym/RRT-Forest-v2   # your SB3 model too
    python scripts/evaluate.py --sampler mine=my_module:make_sampler               # any Sampler factory
    python scripts/evaluate.py --map-set my_maps/ --step 0.2                       # your own maps (world units)
    python scripts/evaluate.py --route mine=runs/route/route.pt                    # your encoder beside the shipped one
    python scripts/evaluate.py --quick --other-planners                            # every planner and sampler: 12 min
    python scripts/evaluate.py --other-planners none                               # the full run without RRT* and PRM
    python scripts/evaluate.py --quick --convergence                               # and RRT*'s cost convergence
    python scripts/evaluate.py --quick --other-planners PRM --later-queries        # and later queries on PRM's roadmaps
    python scripts/evaluate.py --resume              # continue an interrupted run with the same arguments

A thin command line over ``learning.evaluation.compare`` (one call a notebook makes as well: see
learning/evaluation/comparison.py).

Default map set: the five generated families at 128x128 on test seeds (never trained on), each family's
shifted variant (other generators, sides 64 to 256, never used for training, validation or tuning) and the
MovingAI maps in ../shared/maps/movingai (or --movingai / SAMPLERGYM_MOVINGAI_DIR), and three unseen families
(planners/maps/unseen.py: generators used for nothing but testing, tested with the settings tuned on the generated
families' tuning maps pooled; --no-unseen leaves them out). Goal bias, the
ablation's frontier probability and the policy's batch (samples per decision, 8, 2 or 1) are tuned on a
tuning split first; the test runs use what was chosen there. With --map-set, a map set of your own
(a folder or manifest of maps, see docs/map-sets.md) replaces the default ones: tuned on its tuning part,
tested on its test part, its split printed and recorded.

Writes summary.md (one short table and a sentence per finding, made from the numbers), details.md (every wide
table), runs.csv (every run), medians.png (a grid: iterations and time per group of sets), ecdf.png,
ecdf-time.png, map-sets.json and OMPL benchmark
logs (ompl/<map set>.log; open them with OMPL's ompl_benchmark_statistics.py and Planner Arena) as one set:
--out is replaced as a whole when every run is done (MANIFEST.json lists its files), and is locked while a run
writes it. Finished runs go to a journal in <out>.partial/ as they arrive: Ctrl-C or SIGTERM stops every worker
and keeps them, and --resume continues from there (refused where the policy, the route encoder, a --sampler
model or a map changed since). A rerun that finds such a journal asks for --resume or --fresh (discard it);
nothing but the journal is ever deleted from <out>.partial/.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
from pathlib import Path

sys.path.append(os.getcwd())  # --sampler NAME=module:callable finds modules in the working directory

from learning import PolicySampler
from learning import evaluation as E
from learning.evaluation.convergence import BUDGET as CONVERGENCE_BUDGET
from learning.evaluation.journal import (
    JOURNAL,
    Interrupted,
    check_work_folder,
    file_digests,
    stop_on_sigterm,
    work_folder,
)
from learning.evaluation.later_queries import LATER
from learning.evaluation.mapsets import map_set_queries
from learning.evaluation.protocol import MOVINGAI_MAPS, QUICK
from learning.evaluation.rigid import PLANNERS as RIGID_PLANNERS
from learning.evaluation.rigid import RIGID_FIGURES, RigidPart
from learning.evaluation.rigid import SAMPLERS as RIGID_SAMPLERS
from learning.models.shipped import SHIPPED_POLICY
from learning.samplers import registry
from learning.samplers.route import SHIPPED
from planners import movingai_dir, planner_names
from planners.algorithms.rrt import MAX_STEPS_ENV, max_steps_limit
from planners.base.fileio import (
    MANIFEST,
    InputError,
    LockedError,
    check_flags,
    check_int_flags,
    check_number,
    check_output_place,
)
from planners.base.registry import planner_name_arg
from planners.maps.generators import FAMILIES, SHIFTED_SIZES, check_size
from planners.maps.mapset import GeneratedMapSet, ShiftedMapSet
from planners.maps.unseen import UNSEEN_MIN_SIZE
from planners.tools.parallel import add_backend_arguments, check_backend_arguments
from planners.worlds.rigid_scenes import TEST_ONLY_FAMILIES, RigidSceneSet

DEFAULT_POLICY = SHIPPED_POLICY
#: The comparison's protocol at its defaults: every default below is taken from it.
DEFAULT = E.Protocol()
#: The other planners of the full comparison when --other-planners is not given.
OTHER_PLANNERS = ["RRTstar", "PRM"]
#: --other-planners' own words beside the planners' names: every planner but RRT, or none.
EVERY, NONE = "all", "none"


def _fail(message: str):
    """One ``error:`` line and exit 2: a bad argument is refused before any run."""
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


def _other_planner(value: str) -> str:
    """A planner name for --other-planners (aliases as planner_name_arg reads them), "all" or "none"."""
    return value if value in (EVERY, NONE) else planner_name_arg(value)


def other_planners(given: list[str] | None, quick: bool = False) -> list[str]:
    """The planners besides RRT that --other-planners asks for, each once, in the order given.

    ``given`` as argparse leaves it: None when the flag is absent (the full run's :data:`OTHER_PLANNERS`, none with
    --quick); the flag bare, or with "all" among its names, every planner but RRT; "none" alone, none.
    """
    if given is None:
        return [] if quick else list(OTHER_PLANNERS)
    if NONE in given:
        if len(given) > 1:
            raise InputError(f"--other-planners: {NONE} takes no planner beside it (given {' '.join(given)})")
        return []
    if not given or EVERY in given:
        return [p for p in planner_names() if p != "RRT"]
    return list(dict.fromkeys(given))


def parse_args(argv=None) -> argparse.Namespace:
    """The command line, with --quick's settings applied and every value checked (exit 2 naming a bad one)."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--policy", type=Path, default=DEFAULT_POLICY)
    ap.add_argument("--families", nargs="+", default=list(FAMILIES))
    ap.add_argument("--size", type=int, default=DEFAULT.size)
    ap.add_argument("--maps", type=int, default=DEFAULT.maps, help="test maps per family")
    ap.add_argument("--tuning-maps", type=int, default=DEFAULT.tuning_maps,
                    help="maps per family for choosing the best goal bias")
    ap.add_argument("--shifted-maps", type=int, default=DEFAULT.shifted_maps,
                    help="test maps per family from its shifted generator, sides 64 to 256 (0: none)")
    ap.add_argument("--unseen-maps", type=int, default=None,
                    help="test maps per unseen family (generators used only for testing; default: --maps, at most "
                         f"{DEFAULT.unseen_maps}; 0: none)")
    ap.add_argument("--no-unseen", action="store_true", help="leave the unseen families out (--unseen-maps 0)")
    ap.add_argument("--map-set", default=None, metavar="DIR_OR_SPEC",
                    help="evaluate on this map set instead of the default ones: a folder or manifest .json of maps "
                         "(docs/map-sets.md); tuned on its tuning part, tested on its test part. --step and "
                         "--tolerance are in its world units")
    ap.add_argument("--split-seed", type=int, default=0, help="--map-set: the seed of its split into parts")
    ap.add_argument("--route", action="append", default=[], metavar="FILE or NAME=FILE",
                    help="a route encoder checkpoint (scripts/train_route.py). NAME=FILE (repeatable) runs yours "
                         "beside the shipped one, labelled NAME, and the summary says whether it beats the shipped "
                         "one; a bare FILE replaces the shipped one as the 'route encoder'")
    ap.add_argument("--device", default="auto", choices=("auto", "cpu", "cuda"),
                    help="where the route encoder runs at planning time: auto (CUDA when torch sees it, else the "
                         "CPU), cpu or cuda")
    ap.add_argument("--seeds", type=int, default=DEFAULT.seeds, help="planner seeds per query")
    ap.add_argument("--movingai", type=Path, default=None)
    ap.add_argument("--movingai-maps", nargs="*", default=list(MOVINGAI_MAPS))
    ap.add_argument("--scenarios", type=int, default=DEFAULT.scenarios, help="test scenarios per MovingAI map")
    ap.add_argument("--tuning-scenarios", type=int, default=DEFAULT.tuning_scenarios,
                    help="scenarios per MovingAI map for choosing the best goal bias")
    ap.add_argument("--other-planners", nargs="*", default=None, type=_other_planner,
                    choices=(*planner_names(), EVERY, NONE), metavar="PLANNER",
                    help="also run these planners on every test set (given bare or with all: every planner but RRT; "
                         f"none: none; not given: {' and '.join(OTHER_PLANNERS)}, none with --quick), "
                         "each with uniform sampling, its classical option (the tuned goal bias for a tree, "
                         "obstacle-based sampling for a roadmap), the policy, the route encoder, its ablation and the "
                         "exact reference (OB-PRM: its own obstacle-based sampling only); choose from "
                         f"{', '.join(planner_names())}")
    ap.add_argument("--convergence", type=int, nargs="?", const=CONVERGENCE_BUDGET, default=0, metavar="ITERATIONS",
                    help="also run RRT* and Informed RRT* to this many iterations (default "
                         f"{CONVERGENCE_BUDGET}) on every test query and report the iterations to come within 5%% "
                         "and 1%% of the best known cost: uniform, the tuned goal bias, Informed RRT*, the route "
                         "encoder, its ablation and the exact reference")
    ap.add_argument("--later-queries", type=int, nargs="?", const=LATER, default=0, metavar="K",
                    help=f"also ask each roadmap (the roadmap planners among --other-planners, PRM where none is) K "
                         f"more queries (default {LATER}) after the test query it was built for, and report the "
                         "samples each adds and the share answered with no new sample")
    ap.add_argument("--step", type=float, default=DEFAULT.step)
    ap.add_argument("--tolerance", type=float, default=DEFAULT.tolerance)
    ap.add_argument("--max-iterations", type=int, default=DEFAULT.max_iterations)
    add_backend_arguments(ap, processes=os.cpu_count() or 1,
                          processes_help="local workers (local backend, or a local Ray instance)",
                          backend_help="where runs execute: a local process pool (default) or Ray "
                                       "(pip install -e '.[distributed]')")
    ap.add_argument("--no-expert", action="store_true",
                    help="skip the privileged references (the expert and the exact route reference)")
    ap.add_argument("--quick", action="store_true",
                    help="25 test and 25 shifted maps, 8 unseen maps per family, 4 test scenarios, 2 seeds, no other "
                         "planners; tuning as in the full run")
    ap.add_argument("--sampler", action="append", default=[], metavar="NAME=SPEC",
                    help="also compare this sampler (repeatable): NAME=MODEL.zip@ENV_ID[@stochastic][@key=value...] "
                         "for a Stable-Baselines3 model trained on that SamplerGym id (SB3Sampler's default: the "
                         "policy's mode, draws for guided actions; @stochastic or @deterministic to choose; "
                         "key=value: the env kwargs it was trained with), or NAME=module:callable "
                         "for a factory returning a Sampler")
    ap.add_argument("--rigid", choices=("validation", "tuning", "test", "mesh"), default=None, metavar="PART",
                    help="also run the 6-DoF scene sets' PART (validation, tuning or test; docs/rigid-scenes.md): the "
                         "seed project's planners with every 6-DoF sampler, in the same journal and output set; "
                         "mesh: the test-only mesh set (the test-only families written as meshes, and OMPL.app's "
                         "problems from --rigid-omplapp; the mesh extra)")
    ap.add_argument("--rigid-omplapp", metavar="DIR",
                    help="--rigid mesh: the folder of OMPL.app's problems (its root or resources/3D; default "
                         "$SAMPLERGYM_OMPLAPP_DIR, else the mesh scenes alone)")
    ap.add_argument("--rigid-problems", nargs="+", metavar="NAME",
                    help="--rigid mesh: OMPL.app problems to take, by file stem (default every .cfg there)")
    ap.add_argument("--rigid-scenes", type=int,
                    help="--rigid: scenes per family (default 10, the research report's test part: 70 runs a row; "
                         "2 with --quick)")
    ap.add_argument("--rigid-seeds", type=int, default=1, help="--rigid: planner seeds per scene (default 1)")
    ap.add_argument("--rigid-planners", nargs="+", default=list(RIGID_PLANNERS), choices=RIGID_PLANNERS,
                    help="--rigid: planners (default all)")
    ap.add_argument("--rigid-samplers", nargs="+", default=None, metavar="NAME",
                    help="--rigid: registry samplers (default: every 6-DoF reference and learned sampler)")
    ap.add_argument("--rigid-sampler", action="append", default=[], metavar="NAME=SPEC",
                    help="--rigid: also compare a sampler of yours (repeatable), as --sampler takes it; e.g. "
                         "NAME=MODEL.zip@SamplerGym/RRT-RigidScenes-v1 for an SB3 model trained on the scenes")
    ap.add_argument("--rigid-max-iterations", type=int, default=None,
                    help="--rigid: lower every planner's cap to this (quick looks; default the set-ups' own caps)")
    ap.add_argument("--rigid-only", action="store_true", help="--rigid without the 2D map sets")
    ap.add_argument("--out", type=Path, default=Path("results/evaluation"),
                    help="output folder, replaced as a whole when the run is done")
    ap.add_argument("--resume", action="store_true",
                    help="continue an interrupted run (same arguments, same files) from its journal in <out>.partial/")
    ap.add_argument("--fresh", action="store_true",
                    help="discard the journal of an interrupted run in <out>.partial/ and start over (without it, a "
                         "rerun that finds one is refused)")
    args = ap.parse_args(argv)
    if args.quick:  # Protocol.quick's fewer test queries and seeds (the tuning split unchanged)
        for k, v in QUICK.items():
            setattr(args, k, v)
    args.rigid_scenes_given = args.rigid_scenes is not None
    if args.rigid_scenes is None:  # not on the command line: the report's 10 scenes a family, 2 with --quick
        args.rigid_scenes = 2 if args.quick else 10
    if args.unseen_maps is None:
        args.unseen_maps = min(args.maps, DEFAULT.unseen_maps) if isinstance(args.maps, int) else 0
    if args.no_unseen:
        args.unseen_maps = 0
    check_flags(lambda: setattr(args, "other_planners", other_planners(args.other_planners, args.quick)))
    check_backend_arguments(ap, args)
    check_flags(lambda: _check_values(args))
    check_flags(lambda: _check_rigid(args))
    _check_models(args)
    return args


def _check_values(args) -> None:
    """Counts, sizes, step and tolerance, families and the output place: an ``InputError`` naming the flag."""
    check_int_flags(args, ("maps", "tuning_maps", "seeds", "scenarios", "tuning_scenarios", "max_iterations",
                           "processes"))
    check_int_flags(args, ("shifted_maps", "unseen_maps", "split_seed", "convergence", "later_queries"), low=0)
    check_size(args.size, "--size")
    if args.unseen_maps and args.size < UNSEEN_MIN_SIZE and args.map_set is None:
        raise InputError(f"--size = {args.size}: the unseen families need at least {UNSEEN_MIN_SIZE} cells a side "
                         "(or pass --no-unseen)")
    check_number("--step", "step", args.step, low=0, low_open=True)
    check_number("--tolerance", "tolerance", args.tolerance, low=0, low_open=True)
    if args.map_set is None:  # the largest default map: a MovingAI 512x512 map, or a generated or shifted one
        side = max(args.size, max(SHIFTED_SIZES) if args.shifted_maps else 0, 512 if args.movingai_maps else 0)
        diag = side * 2 ** 0.5
        if diag / args.step > max_steps_limit():
            raise InputError(f"--step = {args.step:g} is {diag / args.step:.3g} steps across the diagonal of a "
                             f"{side}x{side} map; at most {max_steps_limit()} are accepted "
                             f"(a step of at least {diag / max_steps_limit():.3g}, or set {MAX_STEPS_ENV})")
        if args.tolerance >= side:
            raise InputError(f"--tolerance = {args.tolerance:g} covers the whole of a {side}x{side} map")
    unknown = sorted(set(args.families) - set(FAMILIES))
    if unknown:
        raise InputError(f"--families: unknown {unknown}; choose from {', '.join(FAMILIES)}")
    check_output_place(args.out, "--out", need_bytes=OUTPUT_BYTES)
    check_output_place(work_folder(args.out), "--out's work folder", need_bytes=OUTPUT_BYTES)
    if args.resume and args.fresh:
        raise InputError("--resume and --fresh: choose one (continue the journal, or discard it)")
    check_work_folder(work_folder(args.out), resume=args.resume, fresh=args.fresh)
    foreign = sorted(p.name for p in args.out.iterdir() if p.name not in OUTPUT_NAMES) if args.out.is_dir() else []
    if foreign:
        raise InputError(f"--out {args.out}: the folder holds {', '.join(foreign[:3])}"
                         f"{' and more' if len(foreign) > 3 else ''}, which this command does not write, and the "
                         "outputs replace the folder as a whole; choose an empty or new folder")


def _check_rigid(args) -> None:
    """``--rigid``'s flags, and its part of the comparison (``args.parts``): an ``InputError`` naming the flag."""
    args.parts = []
    given = [f for f in ("rigid_only", "rigid_max_iterations", "rigid_samplers", "rigid_sampler", "rigid_omplapp",
                         "rigid_problems") if getattr(args, f)]
    given += ["rigid_scenes"] if args.rigid_scenes_given else []
    if args.rigid is None:
        if given:
            raise InputError(f"--{given[0].replace('_', '-')} needs --rigid PART")
        return
    check_int_flags(args, ("rigid_scenes", "rigid_seeds"))
    if args.rigid_max_iterations is not None:
        check_int_flags(args, ("rigid_max_iterations",))
    samplers = args.rigid_samplers or list(RIGID_SAMPLERS)
    users = registry.checked_user_samplers(args.rigid_sampler, "--rigid-sampler", tuple(samplers))
    if args.rigid != "mesh" and (args.rigid_omplapp or args.rigid_problems):
        raise InputError("--rigid-omplapp and --rigid-problems go with --rigid mesh")
    if args.rigid == "mesh":
        from planners.worlds.omplapp import omplapp_dir
        from planners.worlds.rigid_scenes import MeshSceneSet

        folder = omplapp_dir(args.rigid_omplapp, flag="--rigid-omplapp")  # a bad folder named by this flag
        scenes, part = MeshSceneSet(TEST_ONLY_FAMILIES, args.rigid_scenes, folder, args.rigid_problems), "test"
    else:
        scenes, part = RigidSceneSet(counts={args.rigid: args.rigid_scenes}), args.rigid
    try:
        args.parts = [RigidPart(scenes, part, planners=args.rigid_planners, samplers=samplers,
                                seeds=args.rigid_seeds, max_iterations=args.rigid_max_iterations, users=users,
                                name="6-DoF mesh scenes (test)" if args.rigid == "mesh" else "")]
    except InputError as exc:
        raise InputError(f"--rigid-samplers: {exc}") from exc


def _check_models(args) -> None:
    """The policy, the route encoder, the user samplers and the map set, each loaded once here (exit 2 naming it).

    The route encoder is kept in ``args.models``, the map set in ``args.loaded``: the runs take them from there.
    """
    if not args.policy.is_file():
        _fail(f"--policy {args.policy}: not found (train one with scripts/train.py --export ...)")
    try:  # refused here, by name, rather than as a traceback in every worker
        PolicySampler.load(args.policy)
    except (ValueError, OSError) as exc:
        _fail(f"--policy {args.policy}: {exc}")
    args.models, args.loaded = E.ModelCache(), {}
    _check_routes(args)
    if args.device == "cuda":
        import torch

        if not torch.cuda.is_available():
            _fail("--device cuda: torch sees no CUDA device here (use auto or cpu)")
    try:  # each built once here, so a bad file or spec is refused before any run
        args.user_samplers = registry.checked_user_samplers(args.sampler, "--sampler", E.BUILTIN_SAMPLERS)
    except InputError as exc:
        _fail(str(exc))
    for name in args.user_samplers:
        if name in args.extra_routes:
            _fail(f"--sampler name {name!r} is given twice (or names a --route encoder)")
    args.map_set_queries, args.map_set_obj = [], None
    if args.map_set is not None:
        try:
            args.map_set_queries, args.map_set_obj = map_set_queries(args.map_set, args.split_seed, args.loaded)
        except InputError as exc:
            _fail(f"--map-set {args.map_set}: {exc}")
        _check_step_on_map_set(args)
    args.inputs = file_digests(_input_files(args))


def _check_routes(args) -> None:
    """``--route``: at most one bare FILE (it replaces the shipped encoder), any NAME=FILE beside it; each loaded once.

    Sets ``args.route`` (the encoder run as the "route encoder") and ``args.extra_routes`` (name -> path).
    """
    main, args.extra_routes = None, {}
    for arg in args.route if isinstance(args.route, list) else [str(args.route)]:
        name, sep, path = arg.partition("=")
        if sep and name and not any(c in name for c in "/\\") and not Path(arg).exists():
            if not path:
                _fail(f"--route {arg!r}: NAME=FILE names no file")
            try:
                E.parse_user_sampler(f"{name}=x")  # the same rule as a --sampler name: not one of ours
            except InputError:
                _fail(f"--route {arg!r}: the name {name!r} is taken or has a comma; choose another")
            if name in args.extra_routes or name == E.ROUTE:
                _fail(f"--route name {name!r} is given twice")
            args.extra_routes[name] = Path(path)
        elif main is not None:
            _fail(f"--route {arg}: a second bare FILE; one replaces the shipped encoder, the others take NAME=FILE")
        else:
            main = Path(arg)
    args.route = SHIPPED if main is None else main
    for label, path in [("", args.route), *((f"{n}=", p) for n, p in args.extra_routes.items())]:
        try:
            args.models.route_net(str(path))
        except (InputError, OSError) as exc:
            _fail(f"--route {label}{path}: {exc}" if str(path) not in str(exc) else f"--route: {exc}")


def _check_step_on_map_set(args) -> None:
    """Refuse a --step too small for the largest map of --map-set (the planners' limit), naming the flag."""
    diag, where = 0.0, ""
    seen = set()
    for q in args.map_set_queries:
        if q.query.map in seen:
            continue
        seen.add(q.query.map)
        if isinstance(args.map_set_obj, GeneratedMapSet | ShiftedMapSet):  # its side is in the name: not generated
            d = int(q.query.map.rsplit("-", 2)[1]) * 2**0.5
        else:
            low, high = args.map_set_obj.problem(q.query).world.bounds
            d = sum((float(h) - float(lo)) ** 2 for lo, h in zip(low, high, strict=True)) ** 0.5
        if d > diag:
            diag, where = d, q.query.map
    if diag / args.step > max_steps_limit():
        _fail(f"--step = {args.step:g} is {diag / args.step:.3g} steps across the diagonal of map {where!r} of map "
              f"set {args.map_set_obj.name} ({diag:g} world units); at most {max_steps_limit()} are accepted (a step "
              f"of at least {diag / max_steps_limit():.3g}, or set {MAX_STEPS_ENV})")


def _input_files(args) -> dict[str, Path]:
    """The files the runs read, by what names them: the journal records their hashes (``file_digests``)."""
    files = {f"--policy {args.policy}": args.policy}
    for label, path in [("", args.route), *((f"{n}=", p) for n, p in args.extra_routes.items())]:
        files[f"--route {label}{path}"] = path
        if path.with_suffix(".json").is_file():
            files[f"--route {label}{path.with_suffix('.json')}"] = path.with_suffix(".json")
    for name, spec in args.user_samplers.items():
        if "@" in spec:  # MODEL.zip@ENV_ID: the model file; module:callable: the module's source
            path = Path(spec.split("@")[0])
        else:
            path = getattr(sys.modules.get(spec.partition(":")[0]), "__file__", None)
        if path is not None and Path(path).is_file():
            files[f"--sampler {name} {path}"] = Path(path)
    if args.map_set_obj is not None:
        for path in args.map_set_obj.files():
            files[f"--map-set {path}"] = path
    elif args.movingai_maps:
        try:
            mdir = movingai_dir(args.movingai, required=False)
        except InputError:
            mdir = None  # refused by name in main
        for name in args.movingai_maps if mdir is not None else ():
            for path in sorted(mdir.glob(f"{name}*.scen")) + [mdir / f"{name}.map"]:
                if path.is_file() and path.name.split(".")[0].replace("-random-1", "") == name:
                    files[f"--movingai {path}"] = path
    return files


#: What the outputs may hold (``means.png``: the figure's name in earlier versions); --out holding more is refused.
OUTPUT_NAMES = frozenset({MANIFEST, "summary.md", "details.md", "runs.csv", "ecdf.png", "ecdf-time.png", "medians.png",
                          "means.png", "map-sets.json", "ompl", *RIGID_FIGURES})
#: Free disk space the outputs need (tables, a few plots, one OMPL log per map set), with room to spare.
OUTPUT_BYTES = 64 * 2**20


def _settings(args) -> dict:
    """What decides the runs (for the journal: --resume refuses a journal of other settings)."""
    skip = {"out", "resume", "fresh", "processes", "backend", "address", "quick", "no_unseen", "map_set_queries",
            "map_set_obj", "sampler", "models", "loaded", "rigid_scenes_given"}
    if not args.extra_routes:  # so a run without NAME=FILE encoders keeps the journal settings it always had
        skip.add("extra_routes")
    if not args.rigid_sampler:  # likewise without a user's 6-DoF sampler
        skip.add("rigid_sampler")
    skip.add("parts")
    skip.update(k for k in ("convergence", "later_queries") if not getattr(args, k))  # likewise without them
    if args.rigid is None:  # likewise without --rigid
        skip.update(k for k in vars(args) if k.startswith("rigid"))
    return {k: v for k, v in vars(args).items() if k not in skip}


def comparison_of(args) -> E.Comparison:
    """The library's ``Comparison`` of the command line's (checked) arguments; the queries of its map sets."""
    if args.map_set is not None:
        queries = list(args.map_set_queries)
        print(args.map_set_obj.describe(), flush=True)
        mdir = None
    else:
        try:  # a folder the user named must exist; the default one may be absent
            mdir = movingai_dir(args.movingai, required=False) if args.movingai_maps else None
        except InputError as exc:
            _fail(f"--movingai: {exc}")
        if mdir is None and args.movingai_maps:
            print(f"MovingAI maps not found, so their {len(args.movingai_maps)} rows and the pooled row are left out: "
                  "the maps are published with the MovingAI grid benchmarks (movingai.com/benchmarks, 'dao', "
                  "'street', 'maze', 'random', 'room' and 'mapf' sets; the names are in --movingai-maps); put the "
                  ".map and .scen files in one folder and pass --movingai DIR or set SAMPLERGYM_MOVINGAI_DIR",
                  file=sys.stderr)
        queries = E.default_queries(args.families, args.size, args.maps, args.tuning_maps, args.shifted_maps,
                                    args.unseen_maps, mdir, args.movingai_maps, args.scenarios,
                                    args.tuning_scenarios, args.tolerance, args.loaded)
    protocol = E.Protocol(step=args.step, tolerance=args.tolerance, max_iterations=args.max_iterations,
                          seeds=args.seeds, size=args.size, maps=args.maps, tuning_maps=args.tuning_maps,
                          shifted_maps=args.shifted_maps, unseen_maps=args.unseen_maps, scenarios=args.scenarios,
                          tuning_scenarios=args.tuning_scenarios, movingai_dir="" if mdir is None else str(mdir))
    if args.rigid_only:
        queries = []
    return E.Comparison(queries, protocol, policy=str(args.policy), route=str(args.route),
                        routes={n: str(p) for n, p in args.extra_routes.items()}, samplers=args.user_samplers,
                        families=args.families, other_planners=args.other_planners, references=not args.no_expert,
                        device=args.device, map_set=args.map_set_obj, models=args.models, cache=args.loaded,
                        parts=args.parts, convergence=args.convergence, later_queries=args.later_queries)


def _say(line: str) -> None:
    print(line, flush=True)


def main(argv=None) -> int:
    """Run the comparison (``learning.evaluation.compare``) and write its results; returns the exit status."""
    args = parse_args(argv)
    comparison = comparison_of(args)
    stop_on_sigterm()
    try:
        results = E.compare(comparison, args.out, backend=args.backend, processes=args.processes,
                            address=args.address, resume=args.resume, fresh=args.fresh, settings=_settings(args),
                            log=_say)
    except LockedError as exc:
        _fail(f"--out: {exc}")
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(f"error: --backend {args.backend}: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, Interrupted) as exc:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C does not cut the message short
        status = exc.status if isinstance(exc, Interrupted) else 130
        kept = getattr(exc, "kept", 0)
        print(f"\ninterrupted: {kept} of {getattr(exc, 'planned', 0) or kept} runs planned so far are kept in "
              f"{work_folder(args.out) / JOURNAL}; {args.out} is unchanged; rerun with the same arguments and "
              f"--resume to continue", file=sys.stderr, flush=True)
        return status
    print(results.printed(args.out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
