"""Which frame makes an OMPL.app solution replay: the environment's instanced parts and the robot's origin.

    PYTHONPATH=$PWD python scripts/experiments/omplapp_frames.py --omplapp DIR --problem Twistycooler
    PYTHONPATH=$PWD python scripts/experiments/omplapp_frames.py --omplapp DIR --problem alpha-1.2 --centres-only

Three of the ``.path`` solutions OMPL.app ships (``Twistycooler``, ``alpha-1.1``, ``alpha-1.2``) have states
that meet the environment as ``planners.worlds.omplapp`` reads it. This replays a problem's solution (FCL's
collision test, state by state) under other readings of its meshes:

* the environment's instanced parts (a COLLADA ``<node>`` holding a ``<matrix>`` and an ``<instance_node>``):
  each placed as the file says, left out, or turned the other way (its rotation transposed), every
  combination where there are at most four, each alone otherwise;
* the robot's origin: the mean of its vertices as the file indexes them (``load_omplapp``'s, as OMPL.app's
  ``getRobotCenter``), of its distinct positions, of its triangles' corners, and its bounding box's centre.

It prints how many of the solution's states are free under each, and which are not. Nothing here is a
setting of the library: it narrows down what OMPL.app's reading was when the solution was made.
"""

from __future__ import annotations

import argparse
import configparser
import itertools
import re
import sys
import tempfile
from pathlib import Path

import numpy as np

#: An instanced part: the node, its placement, the instance (``<instance_node url="..."/>``).
INSTANCE = re.compile(r"(<node\b[^>]*>\s*<matrix>)([^<]*)(</matrix>\s*<instance_node\b[^>]*/>\s*</node>)")
#: How each instanced part may be read: as the file places it, left out, its rotation transposed.
READINGS = ("as given", "left out", "transposed")


def with_readings(text: str, readings: tuple[str, ...]) -> str:
    """The COLLADA ``text`` with its instanced parts read as ``readings`` says, in the file's order."""
    parts, last = [], 0
    for m, how in zip(INSTANCE.finditer(text), readings, strict=True):
        parts.append(text[last:m.start()])
        if how == "as given":
            parts.append(m.group(0))
        elif how == "transposed":
            M = np.array(m.group(2).split(), dtype=float).reshape(4, 4)
            M[:3, :3] = M[:3, :3].T
            parts.append(m.group(1) + " ".join(repr(float(v)) for v in M.ravel()) + m.group(3))
        elif how != "left out":
            raise ValueError(f"unknown reading {how!r}; expected one of {READINGS}")
        last = m.end()
    return "".join(parts) + text[last:]


def _model(fcl, vertices, faces):
    m = fcl.BVHModel()
    m.beginModel(len(vertices), len(faces))
    m.addSubModel(vertices, faces)
    m.endModel()
    return m


def in_contact(env, robot, states) -> list[int]:
    """Indices of the ``states`` ((k, 6), ours) at which the centred ``robot`` meets ``env`` (FCL's collision test)."""
    import fcl

    from planners.worlds.mesh import rotation_matrices

    e = fcl.CollisionObject(_model(fcl, *env), fcl.Transform())
    b = fcl.CollisionObject(_model(fcl, *robot), fcl.Transform())
    rotations = rotation_matrices(states[:, 3:])
    bad = []
    for i, (R, q) in enumerate(zip(rotations, states, strict=True)):
        b.setTransform(fcl.Transform(R, q[:3].copy()))
        if fcl.collide(b, e, fcl.CollisionRequest(), fcl.CollisionResult()):
            bad.append(i)
    return bad


def centres(vertices: np.ndarray, faces: np.ndarray) -> dict[str, np.ndarray]:
    """The robot origins compared: the library's (``vertex mean``) first."""
    return {"vertex mean (load_omplapp)": vertices.mean(axis=0),
            "distinct positions' mean": np.unique(vertices, axis=0).mean(axis=0),
            "triangle corners' mean": vertices[faces.ravel()].mean(axis=0),
            "bounding box's centre": 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))}


def _listed(bad: list[int]) -> str:
    return ", ".join(map(str, bad[:12])) + (", ..." if len(bad) > 12 else "")


def main(argv=None) -> int:
    from planners.base.fileio import InputError
    from planners.worlds.mesh import read_mesh
    from planners.worlds.omplapp import load_omplapp_world, omplapp_dir, read_omplapp_path

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--omplapp", help="OMPL.app's root or resources/3D (default $SAMPLERGYM_OMPLAPP_DIR)")
    ap.add_argument("--problem", default="Twistycooler", help="a .cfg name with a .path beside it")
    ap.add_argument("--centres-only", action="store_true", help="only the robot origins, the meshes as read")
    args = ap.parse_args(argv)
    try:
        folder = omplapp_dir(args.omplapp)
    except InputError as e:
        ap.error(str(e))
    if folder is None:
        ap.error("no OMPL.app copy: give --omplapp DIR or set SAMPLERGYM_OMPLAPP_DIR")
    cfg, solution = folder / f"{args.problem}.cfg", folder / f"{args.problem}.path"
    for f in (cfg, solution):
        if not f.is_file():
            ap.error(f"{f} does not exist")
    try:
        world = load_omplapp_world(cfg)
        states = read_omplapp_path(solution)
        parser = configparser.ConfigParser(strict=False, interpolation=None, inline_comment_prefixes=("#",))
        parser.read_string(cfg.read_text(encoding="utf-8"), source=str(cfg))
        env_file = cfg.parent / parser["problem"]["world"].strip()
        env_text = env_file.read_text(encoding="utf-8")
    except (InputError, UnicodeDecodeError, configparser.Error, KeyError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{args.problem}: {len(states)} solution states\n")
    print("| robot origin | free states | states in contact |\n|---|---|---|")
    robot = (world.body_vertices, world.body_faces)  # its vertex mean at the origin, as load_omplapp reads it
    env = (world.env_vertices, world.env_faces)
    for label, c in centres(*robot).items():
        bad = in_contact(env, (robot[0] - c, robot[1]), states)
        print(f"| {label} | {len(states) - len(bad)} | {_listed(bad)} |", flush=True)
    if args.centres_only:
        return 0
    count = len(INSTANCE.findall(env_text))
    if count == 0:
        print(f"\n{env_file.name} has no instanced parts")
        return 0
    if count <= 4:
        combos = list(itertools.product(READINGS, repeat=count))
    else:
        combos = [tuple("as given" if j != i else how for j in range(count)) for i in range(count) for how in READINGS]
        combos = list(dict.fromkeys(combos + [("left out",) * count]))
    print(f"\n{env_file.name}: {count} instanced parts, the robot's origin its vertex mean\n")
    print("| " + " | ".join(f"part {i}" for i in range(count)) + " | free states | states in contact |")
    print("|" + "---|" * (count + 2))
    with tempfile.TemporaryDirectory() as tmp:
        variant = Path(tmp) / env_file.name
        for combo in combos:
            variant.write_text(with_readings(env_text, combo), encoding="utf-8")
            bad = in_contact(read_mesh(variant), robot, states)
            print("| " + " | ".join(combo) + f" | {len(states) - len(bad)} | {_listed(bad)} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
