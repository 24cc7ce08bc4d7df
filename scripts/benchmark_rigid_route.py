"""What the 6-DoF route samplers cost per query: the route search, its centring, the model's observation and pass.

    python scripts/benchmark_rigid_route.py                       # 4 test scenes of every family
    python scripts/benchmark_rigid_route.py --part validation --scenes 10 --repeats 5
    python scripts/benchmark_rigid_route.py --omplapp DIR             # OMPL.app's problems instead (mesh worlds)

``rigid_route`` does this work once per query, when a planner binds it; a solved run's time includes it. Prints
per family the median ms of each piece and of the whole bind of ``rigid_route`` and ``rigid_route_ablation``, and of
one draw of its samples (64 that follow the trees, compiled; 64 and 1,024 along the whole route, numpy)
(``learning.evaluation.rigid_speed.setup_times``: compilation left out, one torch thread); with ``--omplapp DIR``
(or ``$SAMPLERGYM_OMPLAPP_DIR`` with ``--omplapp`` alone) the same per OMPL.app problem (``--problems``, default
every ``.cfg`` there; one that does not load is listed with the reason). Wall-clock figures: run it on a quiet
machine. Exit status: 0 done, 2 bad input.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def main(argv=None) -> int:
    from learning.evaluation.rigid_speed import PIECES, setup_times
    from planners.base.fileio import InputError
    from planners.worlds.rigid_scenes import FAMILIES, TEST_ONLY_FAMILIES, rigid_scene, scene_seeds

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--part", choices=("validation", "tuning", "test"), default="test")
    ap.add_argument("--families", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    ap.add_argument("--scenes", type=int, default=4, help="scenes per family")
    ap.add_argument("--repeats", type=int, default=3, help="timed calls of each piece (the median is kept)")
    ap.add_argument("--omplapp", nargs="?", const="", metavar="DIR",
                    help="OMPL.app's problems instead of the scene set (default folder $SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--problems", nargs="+", help="OMPL.app problem names for --omplapp (default every .cfg)")
    args = ap.parse_args(argv)
    if args.scenes < 1 or args.repeats < 1:
        print("error: --scenes and --repeats must be at least 1", file=sys.stderr)
        return 2
    if args.problems and args.omplapp is None:
        print("error: --problems goes with --omplapp", file=sys.stderr)
        return 2
    if args.omplapp is not None:
        return _omplapp(args, PIECES, setup_times)
    families = [f for f in args.families if args.part == "test" or f not in TEST_ONLY_FAMILIES]
    if not families:
        print(f"error: the {args.part} part has none of the families {', '.join(args.families)} (test-only)",
              file=sys.stderr)
        return 2
    print("| family | scenes | boxes | route points | " + " | ".join(f"{p} (ms)" for p in PIECES) + " |")
    print("|---|---|---|---|" + "---|" * len(PIECES))
    try:
        for family in families:
            rows = setup_times([rigid_scene(family, s) for s in scene_seeds(family, args.part, args.scenes)],
                               args.repeats)
            med = {k: float(np.median([r[k] for r in rows])) for k in (*PIECES, "boxes", "route points")}
            print(f"| {family} | {len(rows)} | {med['boxes']:.0f} | {med['route points']:.0f} | "
                  + " | ".join(_fmt(p, med[p]) for p in PIECES) + " |", flush=True)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


def _fmt(piece: str, ms: float) -> str:
    """A piece's ms: a draw's to hundredths (tens of microseconds), the rest to tenths."""
    return f"{ms:.2f}" if piece.startswith("draw") else f"{ms:.1f}"


def _omplapp(args, pieces, setup_times) -> int:
    """The table per OMPL.app problem (``--omplapp``)."""
    from planners.base.fileio import InputError
    from planners.worlds.omplapp import load_omplapp_cfg, omplapp_dir

    try:
        folder = omplapp_dir(args.omplapp or None)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if folder is None:
        print("error: --omplapp without a folder needs $SAMPLERGYM_OMPLAPP_DIR", file=sys.stderr)
        return 2
    names = args.problems or sorted(p.stem for p in folder.glob("*.cfg"))
    if missing := [n for n in names if not (folder / f"{n}.cfg").is_file()]:
        print(f"error: --problems {missing[0]}: no {missing[0]}.cfg in {folder}", file=sys.stderr)
        return 2
    print("| problem | route points | " + " | ".join(f"{p} (ms)" for p in pieces) + " |")
    print("|---|---|" + "---|" * len(pieces))
    for name in names:
        try:
            problem = load_omplapp_cfg(folder / f"{name}.cfg")
        except InputError as e:
            print(f"| {name} | not loaded: {e} |", flush=True)
            continue
        rows = setup_times([problem], args.repeats)
        if not rows:
            print(f"| {name} | no workspace route |", flush=True)
            continue
        r = rows[0]
        print(f"| {name} | {r['route points']} | " + " | ".join(_fmt(p, r[p]) for p in pieces) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
