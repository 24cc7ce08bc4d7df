"""Write the small ROS map_server example maps under tests/data/ros/ from the seeded generators.

    python examples/make_ros_maps.py [--out tests/data/ros]

Each map is a generated family's map saved as ``<name>/map.pgm`` (254 free, 0 occupied, 205 unknown)
and ``<name>/map.yaml`` with a resolution and an origin, as ``map_saver`` writes them. The same
command always writes the same bytes. ``tests/data/ros/README.md`` lists what each map is.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from planners.maps.generators import generate

#: (folder, family, seed, side in cells, resolution in m, origin (x, y) in m, unknown border in cells)
MAPS = (
    ("forest", "forest", 7, 96, 0.05, (-2.4, -2.4), 0),
    ("maze", "maze", 8, 96, 0.1, (0.0, 0.0), 0),
    ("rooms", "rooms", 9, 128, 0.05, (-1.0, -2.0), 4),
)

YAML = """image: map.pgm
resolution: {resolution:.6f}
origin: [{x:.6f}, {y:.6f}, 0.000000]
negate: 0
occupied_thresh: 0.65
free_thresh: 0.196
"""


def write(out: Path, folder: str, family: str, seed: int, side: int, resolution: float, origin, border: int) -> Path:
    """Write one map's ``map.pgm`` and ``map.yaml`` under ``out / folder``; returns the yaml's path."""
    from PIL import Image

    obstacles = generate(family, seed, side).world.obstacles
    pixels = np.where(obstacles, 0, 254).astype(np.uint8)
    if border:
        pixels = np.pad(pixels, border, constant_values=205)  # unknown space around the mapped area
    d = out / folder
    d.mkdir(parents=True, exist_ok=True)
    Image.fromarray(pixels, mode="L").save(d / "map.pgm")
    (d / "map.yaml").write_text(YAML.format(resolution=resolution, x=origin[0], y=origin[1]))
    return d / "map.yaml"


def main(argv: list[str] | None = None) -> None:
    """Write the maps under ``--out``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("tests/data/ros"), help="folder to write the maps under")
    args = ap.parse_args(argv)
    for spec in MAPS:
        print(write(args.out, *spec))


if __name__ == "__main__":
    main()
