"""The comparison: the learned sampler against uniform and goal-biased sampling, on maps it never saw.

    python scripts/evaluate.py                       # default map set, shipped checkpoint
    python scripts/evaluate.py --quick               # fewer test queries, same tuning: about a minute
    python scripts/evaluate.py --policy runs/guided/final.zip --processes 2
    python scripts/evaluate.py --backend ray --address auto                        # on your Ray cluster
    python scripts/evaluate.py --sampler mine=user_ppo.zip@SamplerGym/RRT-Forest-v2   # your SB3 model too
    python scripts/evaluate.py --sampler mine=my_module:make_sampler               # any Sampler factory
    python scripts/evaluate.py --map-set my_maps/ --step 0.2                       # your own maps (world units)
    python scripts/evaluate.py --resume              # continue an interrupted run with the same arguments

Default map set: the five generated families at 128x128 on test seeds (never trained on), each family's
shifted variant (other generators, sides 64 to 256, never used for training, validation or tuning) and the
MovingAI maps in ../shared/maps/movingai (or --movingai / SAMPLERGYM_MOVINGAI_DIR), and three unseen families
(planners/maps/unseen.py: generators used for nothing but testing, tested with the settings tuned on the generated
families' tuning maps pooled; --no-unseen leaves them out). Goal bias, the
ablation's frontier probability and the policy's batch (samples per decision, 8, 2 or 1) are tuned on a
tuning split first; the test runs use what was chosen there. With --map-set, a map set of your own
(a folder or manifest of maps, see docs/map-sets.md) replaces the default ones: tuned on its tuning part,
tested on its test part, its split printed and recorded.

Writes runs.csv (every run), summary.md (tables), ecdf.png, medians.png, map-sets.json and OMPL benchmark
logs (ompl/<map set>.log; open them with OMPL's ompl_benchmark_statistics.py and Planner Arena) as one set:
--out is replaced as a whole when every run is done (MANIFEST.json lists its files), and is locked while a run
writes it. Finished runs go to a journal in <out>.partial/ as they arrive: Ctrl-C or SIGTERM stops every worker
and keeps them, and --resume continues from there (refused where the policy, the route encoder, a --sampler
model or a map changed since). A rerun that finds such a journal asks for --resume or --fresh (discard it);
nothing but the journal is ever deleted from <out>.partial/.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path

sys.path.append(os.getcwd())  # --sampler NAME=module:callable finds modules in the working directory

from learning import PolicySampler
from learning import evaluation as E
from learning.evaluation.journal import (
    JOURNAL,
    Interrupted,
    Journal,
    check_work_folder,
    file_digests,
    run_phase,
    stop_on_sigterm,
    work_folder,
)
from learning.evaluation.mapsets import UnseenQuery, map_set_queries, pooled_tuned, unseen_queries
from learning.evaluation.protocol import MOVINGAI_MAPS
from learning.evaluation.protocol import QUICK as PROTOCOL_QUICK
from learning.models.shipped import SHIPPED_POLICY
from learning.samplers.route import SHIPPED
from planners import movingai_dir, planner_names
from planners.algorithms.rrt import MAX_STEPS_ENV, max_steps_limit
from planners.base.fileio import (
    MANIFEST,
    InputError,
    atomic_write_text,
    check_flags,
    check_int_flags,
    check_number,
    check_output_place,
    output_set,
    run_lock,
)
from planners.base.registry import planner_name_arg
from planners.maps.generators import FAMILIES, SHIFTED_SIZES, check_size
from planners.maps.mapset import GeneratedMapSet, ShiftedMapSet
from planners.maps.unseen import UNSEEN_MIN_SIZE, UNSEEN_SEED0
from planners.tools.benchmark import markdown_table, write_runs_csv
from planners.tools.parallel import add_backend_arguments, check_backend_arguments, make_backend

DEFAULT_POLICY = SHIPPED_POLICY
#: The comparison's protocol at its defaults: every default below is taken from it.
DEFAULT = E.Protocol()
#: What --quick changes: ``Protocol.quick`` (fewer test queries and planner seeds, the tuning split
#: unchanged), and no other planners.
QUICK = {**PROTOCOL_QUICK, "other_planners": []}


def _fail(message: str):
    """One ``error:`` line and exit 2: a bad argument is refused before any run."""
    print(f"error: {message}", file=sys.stderr)
    raise SystemExit(2)


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
    ap.add_argument("--route", type=Path, default=SHIPPED,
                    help="route encoder checkpoint (scripts/train_route.py), run as the 'route encoder' sampler")
    ap.add_argument("--device", default="auto", choices=("auto", "cpu", "cuda"),
                    help="where the route encoder runs at planning time: auto (CUDA when torch sees it, else the "
                         "CPU), cpu or cuda")
    ap.add_argument("--seeds", type=int, default=DEFAULT.seeds, help="planner seeds per query")
    ap.add_argument("--movingai", type=Path, default=None)
    ap.add_argument("--movingai-maps", nargs="*", default=list(MOVINGAI_MAPS))
    ap.add_argument("--scenarios", type=int, default=DEFAULT.scenarios, help="test scenarios per MovingAI map")
    ap.add_argument("--tuning-scenarios", type=int, default=DEFAULT.tuning_scenarios,
                    help="scenarios per MovingAI map for choosing the best goal bias")
    ap.add_argument("--other-planners", nargs="*", default=["RRTstar", "PRM"], type=planner_name_arg,
                    choices=planner_names(),
                    help="also run these (uniform, goal bias 0.05 and best, policy) on the generated families")
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
    ap.add_argument("--out", type=Path, default=Path("results/evaluation"),
                    help="output folder, replaced as a whole when the run is done")
    ap.add_argument("--resume", action="store_true",
                    help="continue an interrupted run (same arguments, same files) from its journal in <out>.partial/")
    ap.add_argument("--fresh", action="store_true",
                    help="discard the journal of an interrupted run in <out>.partial/ and start over (without it, a "
                         "rerun that finds one is refused)")
    args = ap.parse_args(argv)
    if args.quick:
        for k, v in QUICK.items():
            setattr(args, k, v)
    if args.unseen_maps is None:
        args.unseen_maps = min(args.maps, DEFAULT.unseen_maps) if isinstance(args.maps, int) else 0
    if args.no_unseen:
        args.unseen_maps = 0
    check_backend_arguments(ap, args)
    check_flags(lambda: _check_values(args))
    _check_models(args)
    return args


def _check_values(args) -> None:
    """Counts, sizes, step and tolerance, families and the output place: an ``InputError`` naming the flag."""
    check_int_flags(args, ("maps", "tuning_maps", "seeds", "scenarios", "tuning_scenarios", "max_iterations",
                           "processes"))
    check_int_flags(args, ("shifted_maps", "unseen_maps", "split_seed"), low=0)
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
    try:
        args.models.route_net(str(args.route))
    except (InputError, OSError) as exc:
        _fail(f"--route: {exc}")
    if args.device == "cuda":
        import torch

        if not torch.cuda.is_available():
            _fail("--device cuda: torch sees no CUDA device here (use auto or cpu)")
    args.user_samplers = {}
    for arg in args.sampler:  # each built once here, so a bad file or spec is refused before any run
        try:
            name, spec = E.parse_user_sampler(arg)
            E.user_sampler(spec)
        except (ValueError, OSError) as exc:
            _fail(f"--sampler {arg!r}: {exc}" if arg not in str(exc) else str(exc))
        except Exception as exc:  # noqa: BLE001 - e.g. an env kwarg the env does not take (TypeError)
            _fail(f"--sampler {arg!r}: {type(exc).__name__}: {exc}")
        if name in args.user_samplers:
            _fail(f"--sampler name {name!r} is given twice")
        args.user_samplers[name] = spec
    args.map_set_queries, args.map_set_obj = [], None
    if args.map_set is not None:
        try:
            args.map_set_queries, args.map_set_obj = map_set_queries(args.map_set, args.split_seed, args.loaded)
        except InputError as exc:
            _fail(f"--map-set {args.map_set}: {exc}")
        _check_step_on_map_set(args)
    args.inputs = file_digests(_input_files(args))


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
    files = {f"--policy {args.policy}": args.policy, f"--route {args.route}": args.route}
    if args.route.with_suffix(".json").is_file():
        files[f"--route {args.route.with_suffix('.json')}"] = args.route.with_suffix(".json")
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
OUTPUT_NAMES = frozenset({MANIFEST, "summary.md", "runs.csv", "ecdf.png", "ecdf-time.png", "medians.png", "means.png",
                          "map-sets.json",
                          "ompl"})
#: Free disk space the outputs need (tables, a few plots, one OMPL log per map set), with room to spare.
OUTPUT_BYTES = 64 * 2**20


def _settings(args) -> dict:
    """What decides the runs (for the journal: --resume refuses a journal of other settings)."""
    skip = {"out", "resume", "fresh", "processes", "backend", "address", "quick", "no_unseen", "map_set_queries",
            "map_set_obj", "sampler", "models", "loaded"}
    return {k: v for k, v in vars(args).items() if k not in skip}


def main(argv=None) -> int:
    """Run the comparison and write its results; returns the exit status."""
    args = parse_args(argv)
    if args.map_set is not None:
        mdir = None
        queries = list(args.map_set_queries)
        print(args.map_set_obj.describe(), flush=True)
    else:
        try:  # a folder the user named must exist; the default one may be absent
            mdir = movingai_dir(args.movingai, required=False) if args.movingai_maps else None
        except InputError as exc:
            _fail(f"--movingai: {exc}")
        queries = E.generated_queries(args.families, args.size, args.maps, args.tuning_maps)
        queries += E.shifted_queries(args.families, args.shifted_maps)
        if mdir is not None:
            queries += E.movingai_queries(str(mdir), args.movingai_maps, args.scenarios, args.tuning_scenarios,
                                          args.tolerance, args.loaded)
        elif args.movingai_maps:
            print(f"MovingAI maps not found, so their {len(args.movingai_maps)} rows and the pooled row are left out: "
                  "the maps are published with the MovingAI grid benchmarks (movingai.com/benchmarks, 'dao', "
                  "'street', 'maze', 'random', 'room' and 'mapf' sets; the names are in --movingai-maps); put the "
                  ".map and .scen files in one folder and pass --movingai DIR or set SAMPLERGYM_MOVINGAI_DIR",
                  file=sys.stderr)
        queries += unseen_queries(args.size, args.unseen_maps)
    protocol = E.Protocol(step=args.step, tolerance=args.tolerance, max_iterations=args.max_iterations,
                          seeds=args.seeds, size=args.size, maps=args.maps, tuning_maps=args.tuning_maps,
                          shifted_maps=args.shifted_maps, unseen_maps=args.unseen_maps, scenarios=args.scenarios,
                          tuning_scenarios=args.tuning_scenarios, movingai_dir="" if mdir is None else str(mdir))
    context = E.RunContext(protocol, args.models, args.loaded)
    try:
        lock = run_lock(args.out)
        lock.__enter__()
    except InputError as exc:
        _fail(f"--out: {exc}")
    stop_on_sigterm()
    backend = journal = None
    try:
        journal = Journal(work_folder(args.out), _settings(args), resume=args.resume, fresh=args.fresh)
        if journal.resumed:
            print(f"resuming: {journal.resumed} finished runs from {journal.path}", flush=True)
        elif args.resume:
            print(f"--resume: no finished runs in {journal.path}; starting from the first run", flush=True)
        if journal.discarded:
            print(f"--fresh: discarded the {journal.discarded} finished runs of {journal.path}", flush=True)
        backend = make_backend(args.backend, processes=args.processes, address=args.address,
                               worker_init=E.worker_init)
        status = _compare(args, queries, context, backend, journal, t0=time.perf_counter())
        journal.remove()
        return status
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(f"error: --backend {args.backend}: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, Interrupted) as exc:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C does not cut the message short
        status = exc.status if isinstance(exc, Interrupted) else 130
        kept = len(journal.done) if journal is not None else 0
        print(f"\ninterrupted: {kept} of {PLANNED[0] or kept} runs planned so far are kept in "
              f"{work_folder(args.out) / JOURNAL}; {args.out} is unchanged; rerun with the same arguments and "
              f"--resume to continue", file=sys.stderr, flush=True)
        return status
    finally:
        if backend is not None:
            backend.close()
        if journal is not None:
            journal.close()
        lock.__exit__(None, None, None)


#: Runs of the phases started so far (for the interrupt message).
PLANNED = [0]


def _phase(tasks, context, backend, journal, name: str):
    """One phase of runs, journaled; announces itself."""
    PLANNED[0] += len(tasks)
    return run_phase(tasks, context, backend, journal, name)


def _compare(args, queries, context, backend, journal, t0: float) -> int:
    """The runs, tables, plots and logs of the comparison, executed on ``backend`` and journaled."""
    protocol, policy = context.protocol, str(args.policy)
    users = list(args.user_samplers)
    user_specs = [E.SamplerSpec.user(n, spec) for n, spec in args.user_samplers.items()]
    learned = [E.ROUTE, E.ROUTE_ABLATION]  # the route encoder, beside its ablation
    fixed = E.fixed_specs(protocol, str(args.route), args.user_samplers, references=not args.no_expert,
                          device=args.device)
    unseen = sorted({q.map_set for q in queries if isinstance(q, UnseenQuery)})
    # first what needs no tuned setting, beside the tuning runs of goal bias and of the policy's batch
    tasks = E.tuning_tasks(queries, "RRT") + E.policy_tuning_tasks(queries, "RRT", policy)
    tasks += E.evaluation_tasks(queries, "RRT", fixed, protocol.seeds)
    print(f"{len(tasks)} RRT runs on {len(queries)} queries ({args.backend} backend, {backend.workers} workers)",
          flush=True)
    runs = _phase(tasks, context, backend, journal, "tuning and fixed samplers")
    batch, batch_scores = E.best_policy_batch(runs)
    # then the policy at its tuned batch, and the ablation's tuning at that batch (it decides as often)
    tasks = E.constant_tuning_tasks(queries, "RRT", protocol, batch)
    tasks += E.evaluation_tasks(queries, "RRT", [E.policy_spec(policy, batch)], protocol.seeds, "policy")
    print(f"policy batch {batch} (tuned); {len(tasks)} RRT runs of the policy and of the ablation's tuning",
          flush=True)
    runs += _phase(tasks, context, backend, journal, "policy and ablation tuning")
    # a shifted map set has no tuning split of its own: it keeps its family's tuned settings; an unseen
    # family takes those tuned on the generated families' tuning maps pooled
    best = E.tuned_for_shifted(E.best_bias(runs), queries)
    constants = E.tuned_for_shifted(E.best_constant(runs), queries)
    constants.update(pooled_tuned(runs, args.families, E.best_constant, unseen))
    # the ablation (the policy's action classes, constant distribution) on the test split, at the frontier
    # probability its tuning runs chose for each map set; labelled as one sampler whatever that probability
    ablation_tasks = E.constant_test_tasks(queries, "RRT", protocol, batch, constants, protocol.seeds)
    print(f"{len(ablation_tasks)} RRT runs of the constant-distribution ablation at its tuned settings", flush=True)
    runs += _phase(ablation_tasks, context, backend, journal, "policy ablation")
    # other planners: uniform, default and best goal bias, policy, on the generated families (not shifted)
    extra = []
    generated = [q for q in queries if isinstance(q, E.Query) and q.size and not q.shifted]
    for planner in args.other_planners:
        extra += E.tuning_tasks(generated, planner)
        extra += E.evaluation_tasks(generated, planner, [E.bias_spec(b) for b in E.TUNING_BIASES], 1)
        extra += E.evaluation_tasks(generated, planner, [E.policy_spec(policy, batch)], 1, "policy")
        extra += E.evaluation_tasks(generated, planner, user_specs, 1)
    if extra:
        print(f"{len(extra)} runs of {', '.join(args.other_planners)}", flush=True)
        runs += _phase(extra, context, backend, journal, "other planners")
        best = E.tuned_for_shifted(E.best_bias(runs), queries)
    mai = sorted({q.family for q in queries if not q.size})
    if len(mai) > 1:  # one pooled row over every MovingAI map, beside the per-map rows
        pool = E.pooled(runs, E.MOVINGAI_POOL, mai)
        best = E.tuned_for_shifted(E.best_bias(runs + pool), queries)
    else:
        pool = []
    best.update(pooled_tuned(runs, args.families, E.best_bias, unseen))
    minutes = (time.perf_counter() - t0) / 60
    rows = E.summarize(runs + pool, best)
    head = E.headline(rows, best, [E.FOLLOWER, *learned, *users], constants)
    targets, met, total = E.target_check(head, mai)
    route_targets, route_met, route_total = E.target_check(head, mai, E.ROUTE, E.ROUTE_ABLATION)
    reach, reach_met, reach_total = E.target_check(head, mai, "expert")
    glance = E.glance_table(rows, best, users, mai)
    clock = E.glance_table(rows, best, users, mai, metric="time")
    loads = "; ".join(f"{what}: {seconds * 1e3:.0f} ms"
                      for what, seconds in sorted(context.models.load_seconds.items()))
    clock_note = ("RRT on the test split: median wall time per query in ms, from the planner's start to its first "
                  "solution, the sampler's own work for the query included (the route encoder's pass, the exact "
                  "reference's and the expert's grid search, the policy's set-up); the fastest sampler of each set in "
                  "bold, the privileged expert aside. An unsolved run counts with the time it ran. Loading a model is "
                  "paid once per process, not per query, and is left out"
                  + (f" ({loads})" if loads else "") + ". All runs share one machine, "
                  f"{args.processes if args.backend == 'local' else 'several'} process(es) of one thread each.")
    room = E.room_table(rows, mai)
    goals = E.carry_targets(rows, mai, runs=runs + pool) + E.carry_targets(rows, mai, "policy", E.CONSTANT, runs + pool)
    hcols = ["family", "best_bias", "uniform_median", "best_bias_median", "policy_median", "policy/best_bias",
             "policy_success", "best_bias_success", "policy_wall_ms", "best_bias_wall_ms", "expert_median",
             "policy/lower_bound", "expert/lower_bound", "expert/best_bias", "expert_success",
             "best_constant", "constant_median", "policy/constant", "expert/constant", "constant_success",
             "constant_wall_ms"]
    for n in (E.FOLLOWER, *learned, *users):
        hcols += [f"{n}_median", f"{n}/best_bias", f"policy/{n}", f"{n}/lower_bound", f"{n}_success", f"{n}_wall_ms"]
    cols = ["family", "planner", "sampler", "runs", "success", "median_iterations", "iqr", "mean_iterations",
            "mean_ci95", "ratio_to_lower_bound", "median_candidates", "median_checks", "median_wall_ms",
            "median_cost", "median_forward_passes"]
    named = "".join(f"`{n}`: `{spec}`; " for n, spec in args.user_samplers.items())
    where = (f"map set {args.map_set_obj.name} ({args.map_set}): tuned on its tuning part, tested on its test part "
             f"({args.map_set_obj.split.describe()})" if args.map_set_obj is not None else
             f"generated maps {args.size}x{args.size} on test seeds, and shifted variants (other generators, sides "
             f"64 to 256) tested with the settings tuned on their family's tuning split"
             + (", and unseen families (generators used only for testing) tested with the settings tuned on the "
                "generated families' tuning maps pooled" if unseen else "")
             + "; best goal bias chosen on a tuning split")
    text = (f"# Sampler comparison\n\npolicy {args.policy}, {len(runs)} runs in {minutes:.1f} min; {where}. "
            f"Iterations to first solution (cap {args.max_iterations}); the expert and the exact route reference are "
            "privileged references.\n\n"
            + (f"User samplers: {named.rstrip('; ')} (the policy's mode, draws for guided actions, unless the spec "
               "says @stochastic or @deterministic).\n\n"
               if users else "") +
            "## Results at a glance\n\nRRT on the test split: median iterations to the first solution (success "
            "rate in brackets). Best goal bias: the bias tuned for the map set. Ablations: the learned sampler "
            "with its learning removed.\n\n" + markdown_table(glance) +
            "\n## Time to solution at a glance\n\n" + clock_note + "\n\n" + markdown_table(clock) +
            "\n## How much of the room learning closes\n\nThe room is what separates a sampler's ablation from "
            "the exact reference (the same sampler on the exact cost-to-go); the share closed is (ablation - learned) "
            "/ (ablation - exact). Below 20% of the ablation's median the room is too small to judge.\n\n"
            + (markdown_table(room) if room else "No exact reference ran, so the room cannot be shown.\n")
            + "\n## Targets for carrying the gain to unlike maps\n\n" + "".join(f"- {g}\n" for g in goals) +
            "\n## RRT: learned policy vs best-tuned goal bias and vs the tuned constant-distribution ablation\n\n"
            "The ablation draws the policy's own action classes (frontier, or the cell straight ahead) with a "
            "constant distribution and no network; its frontier probability is tuned on the tuning split. The "
            f"{E.FOLLOWER} has no learning either: it samples a step ahead of the vertex nearest the goal, "
            "straight at the goal, and turns to the frontier after 4 iterations without progress. The "
            f"{E.ROUTE} ({args.route}) follows its predicted cost-to-go the same way (settings chosen on "
            f"validation maps); the {E.ROUTE_ABLATION} is that sampler with the straight-line distance in place "
            "of the prediction, its target distance ahead and spread tuned for it on the same maps.\n\n"
            + markdown_table(head, hcols) +
            f"\n## The policy's batch, tuned\n\nSamples per decision, chosen on the tuning maps "
            f"({E.POLICY_TUNING_SEEDS} seeds each) by the lowest sum of log median iterations; scores within "
            f"{E.BATCH_TIE:g} of it count as tied and the largest batch among them wins. Chosen: **{batch}**. The "
            "ablation decides as often.\n\n"
            + markdown_table([{"batch": b, "sum of log medians": f"{v:.3f}"}
                              for b, v in sorted(batch_scores.items())]) +
            f"\n## Targets for the learned policy: {met} of {total} met\n\n"
            + markdown_table(targets) +
            f"\n## Targets for the {E.ROUTE}: {route_met} of {route_total} met\n\n"
            f"Its ablation is the {E.ROUTE_ABLATION}: the same sampler without the encoder (tuned for itself).\n\n"
            + markdown_table(route_targets) +
            f"\n## Which targets can be reached: the privileged expert meets {reach_met} of {reach_total}\n\n"
            "The expert knows the shortest path (a grid search the learned sampler may not run); held to the same "
            "iteration and success targets, it shows which of them perfect route knowledge reaches at all.\n\n"
            + markdown_table(reach) +
            "\n## All cells\n\n" + markdown_table([{k: r[k] for k in cols} for r in rows], cols))
    record = {"map sets": sorted({q.map_set for q in queries}), "settings": _settings(args) | {"out": str(args.out)},
              "policy_batch": batch,
              "tuned goal bias": {f"{m} / {p}": v for (m, p), v in sorted(best.items())},
              "tuned ablation frontier": {f"{m} / {p}": v for (m, p), v in sorted(constants.items())}}
    if args.map_set_obj is not None:
        record["map set"] = args.map_set_obj.record()
    if unseen:
        record["unseen"] = {"families": unseen, "size": args.size, "maps per family": args.unseen_maps,
                            "seeds from": UNSEEN_SEED0, "generator": "planners.maps.unseen.generate_unseen",
                            "settings": "tuned on the generated families' tuning maps pooled"}
    with output_set(args.out) as tmp:  # every file of the set, swapped into place together
        write_runs_csv(runs, tmp / "runs.csv")
        plots = E.save_plots([r for r in runs if r.map not in mai] + pool, rows, best, tmp,
                             extra=[E.CONSTANT, E.FOLLOWER, E.ROUTE, E.ROUTE_ABLATION, *users])
        logs = E.write_ompl_logs(runs + pool, best, tmp / "ompl", protocol)
        atomic_write_text(tmp / "map-sets.json", json.dumps(record, indent=1, default=str) + "\n")
        atomic_write_text(tmp / "summary.md", text)
    print("\n" + markdown_table(glance))
    print("Time to solution per query, median ms (the sampler's own work included):\n" + markdown_table(clock))
    if room:
        print("How much of the room between ablation and exact reference learning closes:\n" + markdown_table(room))
    print("\n".join(goals))
    print("\n" + markdown_table(head, hcols))
    print(f"\npolicy batch {batch}, tuned: " + ", ".join(f"{b}: {v:.3f}" for b, v in sorted(batch_scores.items())))
    print(f"\nTargets: the learned policy meets {met} of {total}, the {E.ROUTE} {route_met} of "
          f"{route_total}; the privileged expert meets {reach_met} of its {reach_total} (summary.md has which)")
    print(f"full table: {args.out / 'summary.md'}; raw runs: {args.out / 'runs.csv'}; plots: "
          f"{', '.join(str(args.out / p.name) for p in plots)}; OMPL benchmark logs ({len(logs)}): {args.out / 'ompl'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
