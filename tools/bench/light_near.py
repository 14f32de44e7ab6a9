"""Light sampling near an emitter (docs/performance.md): the mean squared error of strahl's
path tracer on the Cornell box of scenes/cornell-path.toml lit by a small panel lamp 1 cm from
its back wall instead of its ceiling light, for one or more strahl builds taken in turn. The
lamp is two emissive triangles (scene `lamp-near-wall`) or a two-sided quad light
(`lamp-near-wall-quad`), 16 x 5 cm at y = 0.3 m, radiance 30; the script writes both scenes
into WORK from scenes/cornell-path.toml.

    python3 tools/bench/light_near.py --strahl target/release/strahl --work target/bench-light-near
    # options, with their defaults:
    #   --size 128 --spp 64,256 --reference-spp 2048 --threads 2 --scenes lamp-near-wall,lamp-near-wall-quad
    #   --strahl may be given several times (builds to compare, each run in turn)

The reference is rendered once (by the first build) at twice the width and height and averaged
2 x 2, so that it shares no sample with the renders it judges (strahl's samples are a function
of the pixel's index alone); it is kept in WORK and reused. For each build and spp the script
prints MSE x spp over the R, G and B values of every pixel (the variance per sample when the
reference's own noise is small), the relative RMSE and the CPU seconds (user + system) of the
process. Needs python3 with numpy and OpenEXR.
"""

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cycles_time import cpu, parse_list, read_channels, rgb, timed  # noqa: E402

CORNELL = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scenes", "cornell-path.toml")

# The lamp, in the scene file's units (the room's objects are in millimetres, scaled by 0.001).
LAMP_TRIANGLES = """[[objects]]
type = "triangles"
name = "lamp"
positions = [[200, 300, 500], [360, 300, 500], [360, 300, 550], [200, 300, 550]]
indices = [[0, 1, 2], [0, 2, 3]]
scale = 0.001
material = "lamp"
"""
LAMP_MATERIAL = "[materials.lamp]\ndiffuse = 0\nemission = 30\n\n"
LAMP_QUAD = """[[lights]]
type = "quad"
corner = [0.200, 0.300, 0.500]
edge1 = [0.160, 0, 0]
edge2 = [0, 0, 0.050]
radiance = 30
two_sided = true

"""


def write_scene(name, work):
    """Writes scene `name` into `work` (the module docs): scenes/cornell-path.toml with its one
    [[lights]] block replaced by the lamp."""
    with open(CORNELL) as f:
        text = f.read()
    start = text.index("[[lights]]")
    end = text.index("[[objects]]", start)
    if "[[lights]]" in text[end:]:
        sys.exit(f"{CORNELL} has more than one light; this script replaces its one light")
    if name == "lamp-near-wall":
        text = text[:start] + text[end:] + "\n" + LAMP_TRIANGLES
        text = text.replace("[materials.glass]", LAMP_MATERIAL + "[materials.glass]", 1)
    elif name == "lamp-near-wall-quad":
        text = text[:start] + LAMP_QUAD + text[end:]
    else:
        sys.exit(f"unknown scene {name!r}: lamp-near-wall or lamp-near-wall-quad")
    path = os.path.join(work, name + ".toml")
    with open(path, "w") as f:
        f.write(text)
    return path


def render(strahl, scene, out, size, spp, threads):
    cmd = [strahl, "render", scene, "-o", out, "--width", str(size), "--height", str(size)]
    cmd += ["--spp", str(spp), "--threads", str(threads)]
    return timed(cmd, out + ".log")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--strahl", action="append", help="a strahl binary (several: compared in turn)")
    p.add_argument("--work", default="target/bench-light-near")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp", default="64,256")
    p.add_argument("--reference-spp", type=int, default=2048)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--scenes", default="lamp-near-wall,lamp-near-wall-quad")
    args = p.parse_args()
    builds = args.strahl or ["target/release/strahl"]
    os.makedirs(args.work, exist_ok=True)
    n = args.size
    for name in args.scenes.split(","):
        scene = write_scene(name, args.work)
        ref_path = os.path.join(args.work, f"{name}-reference-{2 * n}-{args.reference_spp}spp.exr")
        if not os.path.exists(ref_path):
            print(f"{name}: rendering the reference ({2 * n}² at {args.reference_spp} spp) ...", flush=True)
            render(builds[0], scene, ref_path, 2 * n, args.reference_spp, args.threads)
        ref = rgb(read_channels(ref_path)[0], "ViewLayer.Combined.")
        ref = ref.reshape(n, 2, n, 2, 3).mean(axis=(1, 3))
        for spp in parse_list(args.spp):
            for k, strahl in enumerate(builds):
                out = os.path.join(args.work, f"{name}-test-{k}-{n}-{spp}spp.exr")
                record = render(strahl, scene, out, n, spp, args.threads)
                image = rgb(read_channels(out)[0], "ViewLayer.Combined.")
                mse = float(((image - ref) ** 2).mean())
                print(
                    f"{name}, {strahl}: {spp} spp, MSE x spp {mse * spp:.4e}, relative RMSE "
                    f"{100 * np.sqrt(mse) / ref.mean():.2f} %, CPU {cpu(record):.2f} s",
                    flush=True,
                )

if __name__ == "__main__":
    main()
