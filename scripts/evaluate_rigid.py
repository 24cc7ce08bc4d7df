"""Planners x samplers on the generated 6-DoF scenes: success, iterations, collision checks and time.

    python scripts/evaluate_rigid.py                   # validation part, 2 scenes a family, 1 seed: 2.5 min
    python scripts/evaluate_rigid.py --part validation --scenes 2 --seeds 2 --out results/rigid
    python scripts/evaluate_rigid.py --part test --families slot windows --planners RRTConnect \\
        --samplers uniform gaussian rigid_workspace_route --out results/rigid-test
    python scripts/evaluate_rigid.py --mesh --omplapp DIR --scenes 1 --max-iterations 2000 --out results/rigid-mesh
    python scripts/evaluate_rigid.py --samplers rigid_route --sampler-params '{"rigid_route": {"uniform_share": 1.0}}'

Runs ``learning.evaluation.rigid.evaluate_rigid`` on a part of the scene set
(``planners.worlds.rigid_scenes.RigidSceneSet``: every scene proved solvable first) and prints a
table per planner and sampler, one per family, and the targets of each learned sampler per scene set and
planner, marked held or not (``learning.evaluation.rigid.rigid_targets``; each OMPL.app problem its own set).
Writes ``rows.json`` (every run), ``summary.md`` (the tables), ``scenes.json`` (the set's record),
``ecdf-rigid.png`` and ``ecdf-rigid-time.png`` (the fraction of runs solved within n iterations and within t
seconds, one panel per planner, one line per sampler) and ``passage.png`` (a solved run in 3-D: ``rigid_route``
with RRT-Connect on a test-only family's scene where one solved, solved again from its seed) under ``--out``.
Tune on ``tuning``, choose on ``validation``; ``test`` is for the reported comparison only.
``--mesh`` runs the test-only mesh set instead (``MeshSceneSet``: the test-only families written as
meshes, and OMPL.app's problems from ``--omplapp`` or ``$SAMPLERGYM_OMPLAPP_DIR``; the ``mesh``
extra); ``rigid_route`` runs there too, its box-trained classes carried to each body's own axes.
``--sampler-params`` passes parameters to the registry's samplers by name (``make_sampler(name, **params)``);
``--sampler NAME=SPEC`` adds a sampler of yours, e.g. a Stable-Baselines3 model trained on
``SamplerGym/RRT-RigidScenes-v1``:

    python scripts/evaluate_rigid.py --samplers uniform goal_bias --sampler mine=ppo.zip@SamplerGym/RRT-RigidScenes-v1

Exit status: 0 done, 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from planners.base.fileio import InputError, atomic_write_text, check_output_place
from planners.worlds.rigid_scenes import TEST_ONLY_FAMILIES, TRAINING_FAMILIES


def main(argv=None) -> int:
    from learning.evaluation.rigid import (
        PLANNERS,
        RIGID_FIGURES,
        SAMPLERS,
        check_names,
        evaluate_rigid,
        format_table,
        rigid_targets,
        save_rigid_figures,
        summarize,
        targets_markdown,
    )
    from learning.samplers.registry import checked_user_samplers
    from planners.worlds.rigid_scenes import RigidSceneSet

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--part", choices=("validation", "tuning", "test"), default="validation")
    ap.add_argument("--families", nargs="+", default=list(TRAINING_FAMILIES), help="training families")
    ap.add_argument("--test-only", nargs="*", default=list(TEST_ONLY_FAMILIES),
                    help="test-only families (in --part test only)")
    ap.add_argument("--scenes", type=int, default=2, help="scenes per family")
    ap.add_argument("--first-scene", type=int, default=0, metavar="K",
                    help="each family's scenes of --part from its K-th on (0: its first; fresh scenes beside ones "
                         "already looked at)")
    ap.add_argument("--seeds", type=int, default=1, help="planner seeds per scene (0, 1, ...)")
    ap.add_argument("--planners", nargs="+", default=list(PLANNERS))
    ap.add_argument("--samplers", nargs="+", help=f"registry names (default {' '.join(SAMPLERS)})")
    ap.add_argument("--max-iterations", type=int, help="lower every planner's cap (quick looks only)")
    ap.add_argument("--restarts", type=int, default=0, metavar="UNIT",
                    help="RRT's and RRT-Connect's runs restart after Luby's sequence times UNIT iterations "
                         "(planners.solve_with_restarts; the cap over all attempts); 0: none")
    ap.add_argument("--sampler", action="append", default=[], metavar="NAME=SPEC",
                    help="also compare a sampler of yours (repeatable): NAME=MODEL.zip@ENV_ID[@stochastic] for a "
                         "Stable-Baselines3 model trained on that SamplerGym id (e.g. SamplerGym/RRT-RigidScenes-v1), "
                         "or NAME=module:callable for a factory returning a Sampler")
    ap.add_argument("--sampler-params", default="{}",
                    help='parameters by sampler name as JSON, e.g. \'{"rigid_route": {"uniform_share": 1.0}}\'')
    ap.add_argument("--out", type=Path, default=Path("results/rigid"))
    ap.add_argument("--mesh", action="store_true", help="the test-only mesh scenes (and OMPL.app's problems)")
    ap.add_argument("--omplapp", help="folder of OMPL.app's problems for --mesh (default $SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--problems", nargs="+", help="OMPL.app problem names to take for --mesh (default all)")
    args = ap.parse_args(argv)

    def fail(msg: str) -> int:
        print(f"error: {msg}", file=sys.stderr)
        return 2

    if args.scenes < 1 or args.seeds < 1:
        return fail(f"--scenes and --seeds must be at least 1, got {args.scenes} and {args.seeds}")
    if args.first_scene < 0:
        return fail(f"--first-scene must be 0 or more, got {args.first_scene}")
    if args.first_scene and args.mesh:
        return fail("--first-scene is for the generated box scenes; the mesh scene set is test-only")
    if args.max_iterations is not None and args.max_iterations < 1:
        return fail(f"--max-iterations must be at least 1, got {args.max_iterations}")
    if args.restarts < 0:
        return fail(f"--restarts must be 0 (none) or a number of iterations, got {args.restarts}")
    if args.restarts and "PRM" in args.planners:
        return fail("--restarts is for RRT and RRTConnect: give --planners without PRM")
    try:
        sampler_params = json.loads(args.sampler_params)
    except ValueError as e:
        return fail(f"--sampler-params is not JSON: {e}")
    if not (isinstance(sampler_params, dict) and all(isinstance(v, dict) for v in sampler_params.values())):
        return fail("--sampler-params must be a JSON object of objects: {\"NAME\": {\"KEY\": VALUE}}")
    samplers = args.samplers or list(SAMPLERS)
    try:  # each built once here, so a bad file or spec is refused before any run
        check_output_place(args.out, "--out")  # a file there, a figure's name, no write access: before the scenes
        users = checked_user_samplers(args.sampler, "--sampler", tuple(samplers))
        check_names(args.planners, samplers, users)  # and the names before the scenes are made
    except InputError as exc:
        return fail(str(exc))
    if args.mesh and args.part != "test":
        return fail("--mesh scenes are test-only: use --part test")
    if not args.mesh and (args.omplapp or args.problems):
        return fail("--omplapp and --problems go with --mesh")
    try:
        if args.mesh:
            from planners.worlds.rigid_scenes import MeshSceneSet

            scenes = MeshSceneSet(args.test_only, args.scenes, args.omplapp, args.problems)
        else:
            scenes = RigidSceneSet(args.families, args.test_only, {args.part: args.scenes},
                                   first={args.part: args.first_scene})
        print(scenes.describe(), flush=True)

        def show(row) -> None:
            print(f"{row.scene:>18} {row.planner:>10} {row.sampler:>22} seed {row.seed}: "
                  f"{'solved' if row.solved else 'failed'} {row.iterations:>6} iterations "
                  f"{row.collision_checks:>8} checks {row.time:7.2f} s", flush=True)

        rows = evaluate_rigid(scenes, args.part, planners=args.planners, samplers=samplers,
                              seeds=range(args.seeds), max_iterations=args.max_iterations, progress=show,
                              sampler_params=sampler_params, user_samplers=users, restarts=args.restarts)
    except InputError as e:
        return fail(str(e))
    by_sampler = format_table(summarize(rows))
    by_family = format_table(summarize(rows, ("family", "planner", "sampler")), ("family", "planner", "sampler"))
    text = (f"# {args.part} part: {args.scenes} scenes per family"
            + (f" from its scene {args.first_scene} on" if args.first_scene else "") + f", {args.seeds} seeds"
            + (f", runs restarting by Luby's sequence x {args.restarts} iterations" if args.restarts else "") + "\n\n"
            "Times are wall-clock seconds on whatever machine ran this (compilation left out), from building the "
            "planner (the sampler's per-scene work and inference included) to the end of the solve.\n\n"
            f"{by_sampler}\n\n## By family\n\n{by_family}\n\n## Targets\n\n"
            f"{targets_markdown(rigid_targets(rows))}\n")
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.out / "rows.json", json.dumps([r.as_dict() for r in rows], indent=1) + "\n")
    atomic_write_text(args.out / "summary.md", text)
    atomic_write_text(args.out / "scenes.json", json.dumps(scenes.record(), indent=1) + "\n")
    for name in RIGID_FIGURES:  # an earlier run's figures would pass for this one's where this one draws none
        (args.out / name).unlink(missing_ok=True)
    figures = save_rigid_figures(rows, args.out, scenes, sampler_params=sampler_params, user_samplers=users,
                                 restarts=args.restarts)
    drawn = [p.name for p in figures]
    note = "" if RIGID_FIGURES[2] in drawn else " (no passage.png: no run solved again)"
    print(f"wrote {args.out}/" + ", ".join(["rows.json", "summary.md", "scenes.json", *drawn]) + note)
    return 0


if __name__ == "__main__":
    sys.exit(main())
