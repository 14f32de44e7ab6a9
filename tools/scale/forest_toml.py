#!/usr/bin/env python3
"""Writes scenes/scale/forest.toml: 1,000 instances of the shipped 5,120-triangle blob refined
to 327,680 triangles (`subdivide = 3`), i.e. 327.7 M triangles as rays see them, over a
40 x 25 jittered grid; and scenes/scale/one.toml, the same scene with the one refined blob
only (the memory baseline). Deterministic (Python's random with a fixed seed); stdlib only.

    python3 tools/scale/forest_toml.py        # rewrites both files
    python3 tools/scale/forest_toml.py DIR    # writes them into DIR instead (tests/scale.rs)
"""
import random
import sys
from pathlib import Path

HEADER = """# {title}
# Written by tools/scale/forest_toml.py; render with `make scale` (see docs/performance.md, Memory).

[render]
integrator = "whitted"   # the lecture's tracer: direct light, mirrors, glass, ambient

[camera]
eye = [0.0, 9.0, 24.0]
target = [0.0, 0.0, -14.0]
up = [0, 1, 0]
fov_deg = 50

[image]
width = 1920
height = 1080
spp = 1
max_depth = 2
background = [0.45, 0.6, 0.85]
ambient = 0.1

[materials.ground]
diffuse = [0.35, 0.3, 0.22]

[materials.moss]
diffuse = [0.25, 0.5, 0.2]

[materials.rust]
diffuse = [0.6, 0.3, 0.15]

[materials.stone]
diffuse = [0.55, 0.55, 0.5]
specular = 0.2
shininess = 50

[[lights]]
type = "directional"
direction = [-0.4, -1.0, -0.5]
irradiance = 2.5          # W/m²

[[objects]]
type = "plane"
name = "ground"
normal = [0, 1, 0]
distance = -1.1
material = "ground"

# The refined blob, named so that instances can place it again: stored once (327,680
# triangles), drawn here and by every instance below.
[[objects]]
type = "mesh"
name = "blob"
path = "../meshes/blob.ply"
subdivide = 3
material = "moss"
translate = [0.0, 0.0, 8.0]
"""

COLS, ROWS, STEP = 40, 25, 2.6


def main() -> None:
    default = Path(__file__).resolve().parents[2] / "scenes" / "scale"
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else default
    root.mkdir(parents=True, exist_ok=True)
    (root / "one.toml").write_text(
        HEADER.format(title="The scale scene's baseline: one refined blob (327,680 triangles), no instances.")
    )
    rng = random.Random(12)
    lines = [HEADER.format(title="The scale scene: 1,000 instances of a 327,680-triangle blob (327.7 M triangles as rays see them).")]
    lines.append("# 999 instances (with the blob itself, 1,000 placements), one per grid cell but the")
    lines.append("# blob's own, jittered, turned and scaled; materials moss, rust, stone.")
    n = 0
    for row in range(ROWS):
        for col in range(COLS):
            x = (col - (COLS - 1) / 2) * STEP + rng.uniform(-0.6, 0.6)
            z = 8.0 - row * STEP + rng.uniform(-0.6, 0.6)
            turn = [round(rng.uniform(-20, 20), 1), round(rng.uniform(0, 360), 1), 0.0]
            s = round(rng.uniform(0.6, 1.1), 3)
            material = rng.choice(["moss", "rust", "stone"])
            if row == 0 and col == COLS // 2:
                continue  # the blob itself stands here
            lines.append(
                f'[[objects]]\ntype = "instance"\nof = "blob"\nmaterial = "{material}"\n'
                f"translate = [{x:.3f}, {s - 1.1 + 0.0:.3f}, {z:.3f}]\nrotate_deg = {turn}\nscale = {s}\n"
            )
            n += 1
    assert n == COLS * ROWS - 1
    (root / "forest.toml").write_text("\n".join(lines))
    print(f"wrote {root / 'forest.toml'} ({n} instances) and {root / 'one.toml'}", file=sys.stderr)


if __name__ == "__main__":
    main()
