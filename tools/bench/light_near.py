"""Light sampling near an emitter (docs/performance.md): the mean squared error of strahl's
path tracer on benches/lamp-near-wall.toml, a Cornell box lit by a small panel lamp of two
emissive triangles 1 cm from its back wall, and on benches/lamp-near-wall-quad.toml, the same
lamp as a quad light, for one or more strahl builds taken in turn.

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

BENCHES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "benches")


def render(strahl, scene, out, size, spp, threads):
    cmd = [strahl, "render", os.path.join(BENCHES, scene + ".toml"), "-o", out, "--width", str(size), "--height", str(size)]
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
    for scene in args.scenes.split(","):
        ref_path = os.path.join(args.work, f"{scene}-reference-{2 * n}-{args.reference_spp}spp.exr")
        if not os.path.exists(ref_path):
            print(f"{scene}: rendering the reference ({2 * n}² at {args.reference_spp} spp) ...", flush=True)
            render(builds[0], scene, ref_path, 2 * n, args.reference_spp, args.threads)
        ref = rgb(read_channels(ref_path)[0], "ViewLayer.Combined.")
        ref = ref.reshape(n, 2, n, 2, 3).mean(axis=(1, 3))
        for spp in parse_list(args.spp):
            for k, strahl in enumerate(builds):
                out = os.path.join(args.work, f"{scene}-test-{k}-{n}-{spp}spp.exr")
                record = render(strahl, scene, out, n, spp, args.threads)
                image = rgb(read_channels(out)[0], "ViewLayer.Combined.")
                mse = float(((image - ref) ** 2).mean())
                print(
                    f"{scene}, {strahl}: {spp} spp, MSE x spp {mse * spp:.4e}, relative RMSE "
                    f"{100 * np.sqrt(mse) / ref.mean():.2f} %, CPU {cpu(record):.2f} s",
                    flush=True,
                )

if __name__ == "__main__":
    main()
