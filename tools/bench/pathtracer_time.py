"""strahl against Embree's tutorial `pathtracer` (embree-tools): samples per CPU-second and the
CPU time each takes to reach the same error, on the scene both read (docs/performance.md,
"The path tracer against Embree's `pathtracer`"; `make bench-pathtracer` runs it).

    python3 tools/bench/pathtracer_time.py --work target/bench-pathtracer
    # options, with their defaults:
    #   --strahl target/release/strahl --size 128 --spp 4,16,64,256 --reference-spp 4096
    #   --threads 1,2 --target 0.1,0.05,0.02

Needs python3 with numpy and OpenEXR, `pathtracer` (Debian's embree-tools), a release strahl,
and the Cornell box OBJ of the test data (`STRAHL_TEST_DATA`, else ../shared/data).

The scene is tests/embree_pathtracer.rs's: the Cornell box OBJ with every `Ke` set to 0 (strahl
would light the ceiling's lamp, `pathtracer` does not), lit by the point light both take on the
command line and in the TOML file, 8 bounces, the same camera. The two do not trace the same
paths: `pathtracer` ends a path when its throughput falls below 0.01 (no Russian roulette; a
bias) and traces about 1.75 times as many rays per sample as strahl, whose paths end by Russian
roulette from the third vertex on; so samples per second alone do not compare them, the time
to the same error does.

Every run is a fresh process timed from outside (os.wait4's user + system CPU time). The line
`CPU = U0 + N·u` through each renderer's runs gives `u`, its CPU seconds per sample per pixel.
Error: RMSE over R, G, B of every pixel, relative to the image mean, against each renderer's
own reference of `--reference-spp`, rendered at twice the size with a quarter of the samples and
averaged 2 × 2 (both renderers seed a pixel's samples by its index in the image, so the
reference's samples are not the runs'); the reference's own noise is taken out with the
constant `c` of the fit `MSE(N) = a/N + c`. `pathtracer` writes its image through an 8-bit
frame buffer: a quantisation error of about 0.3 % of this image's mean per pixel, far below the
targets.
"""

import argparse
import os
import shutil
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import error_fit  # noqa: E402
from cycles_time import cpu, parse_list, read_channels, rgb, timed  # noqa: E402

EYE, TARGET, UP = (0.0, 1.0, 3.9), (0.0, 1.0, 0.0), (0.0, 1.0, 0.0)
FOV_DEG, DEPTH = 38.0, 8
LIGHT, INTENSITY = (0.3, 1.5, 0.4), 0.7
OBJ, MTL = "CornellBox-Original.obj", "CornellBox-Original.mtl"


def read_pfm(path, size):
    """A little-endian RGB PFM of `size`², top row first (PFM stores the bottom row first)."""
    with open(path, "rb") as f:
        magic, dims, scale = (f.readline().strip() for _ in range(3))
        data = f.read()
    if magic != b"PF" or dims.split() != [str(size).encode()] * 2 or float(scale) >= 0:
        raise SystemExit(f"{path}: not a little-endian RGB PFM of {size}²")
    return np.frombuffer(data, dtype="<f4").astype(np.float64).reshape(size, size, 3)[::-1]


def scene(work, data):
    """The OBJ, its MTL with every Ke 0, and strahl's TOML, in `work`: the TOML's path."""
    source = os.path.join(data, "meshes", "cornell")
    if not os.path.isfile(os.path.join(source, OBJ)):
        raise SystemExit(f"{os.path.join(source, OBJ)}: not found (set STRAHL_TEST_DATA to the test data)")
    shutil.copy(os.path.join(source, OBJ), os.path.join(work, OBJ))
    with open(os.path.join(source, MTL)) as f:
        lines = [("  Ke 0 0 0" if line.strip().startswith("Ke ") else line.rstrip("\n")) for line in f]
    with open(os.path.join(work, MTL), "w") as f:
        f.write("\n".join(lines) + "\n")
    vec = lambda v: "[" + ", ".join(str(x) for x in v) + "]"  # noqa: E731
    toml = os.path.join(work, "cornell.toml")
    with open(toml, "w") as f:
        f.write(
            f'[render]\nintegrator = "path"\n\n[camera]\neye = {vec(EYE)}\ntarget = {vec(TARGET)}\n'
            f"up = {vec(UP)}\nfov_deg = {FOV_DEG}\n\n[image]\nwidth = 64\nheight = 64\nspp = 1\n"
            f'max_depth = {DEPTH}\n\n[[lights]]\ntype = "point"\nposition = {vec(LIGHT)}\n'
            f'intensity = {vec([INTENSITY] * 3)}\n\n[[objects]]\ntype = "mesh"\npath = "{OBJ}"\n'
        )
    return toml


class Bench:
    def __init__(self, args):
        self.args = args
        self.dir = os.path.abspath(args.work)
        os.makedirs(self.dir, exist_ok=True)
        data = os.environ.get("STRAHL_TEST_DATA", os.path.join(ROOT, "..", "shared", "data"))
        self.toml = scene(self.dir, data)

    def run(self, renderer, spp, threads, reference=False):
        """One run (fresh process) of `renderer` (`strahl` or `pathtracer`): its record."""
        a = self.args
        size, n = (2 * a.size, spp // 4) if reference else (a.size, spp)
        key = f"{renderer}-{'reference' if reference else 'test'}-{a.size}-{spp}spp-{threads}t"
        out = os.path.join(self.dir, key + (".exr" if renderer == "strahl" else ".pfm"))
        if renderer == "strahl":
            cmd = [a.strahl, "render", self.toml, "-o", out, "--width", str(size), "--height", str(size)]
            cmd += ["--spp", str(n), "--threads", str(threads), "--passes", "combined"]
        else:
            cmd = ["pathtracer", "-i", os.path.join(self.dir, OBJ), "--vp", *map(str, EYE), "--vi", *map(str, TARGET)]
            cmd += ["--vu", *map(str, UP), "--fov", str(FOV_DEG), "--size", str(size), str(size)]
            cmd += ["--spp", str(n), "--max-path-length", str(DEPTH), "--pointlight", *map(str, LIGHT)]
            cmd += [str(INTENSITY)] * 3 + ["--threads", str(threads), "-o", out]
        print(f"  {key} ...", end="", flush=True)
        record = timed(cmd, os.path.join(self.dir, key + ".log"))
        record.update({"out": out, "renderer": renderer, "spp": spp, "threads": threads, "size": size})
        print(f" wall {record['wall']:.1f} s, CPU {cpu(record):.1f} s, load {record['load_before']:.1f}", flush=True)
        return record

    def image(self, record):
        size = record["size"]
        if record["renderer"] == "strahl":
            channels, _ = read_channels(record["out"])
            img = rgb(channels, "ViewLayer.Combined.").reshape(size, size, 3)
        else:
            img = read_pfm(record["out"], size)
        if size != self.args.size:
            img = img.reshape(self.args.size, 2, self.args.size, 2, 3).mean(axis=(1, 3))
        return img


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--work", default=os.path.join(ROOT, "target", "bench-pathtracer"))
    p.add_argument("--strahl", default=os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "strahl"))
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp", default="4,16,64,256")
    p.add_argument("--reference-spp", type=int, default=4096)
    p.add_argument("--threads", default="1,2")
    p.add_argument("--target", default="0.1,0.05,0.02")
    args = p.parse_args()
    if shutil.which("pathtracer") is None:
        raise SystemExit("pathtracer not found: install Debian's embree-tools")
    bench = Bench(args)
    spps, targets, threads = parse_list(args.spp), [float(t) for t in args.target.split(",")], parse_list(args.threads)
    print(f"load average at start: {os.getloadavg()}")
    rows = error_fit.measure(bench, ["strahl", "pathtracer"], args.reference_spp, spps, threads, targets)
    error_fit.print_table(f"{args.size}² pixels, the Cornell box OBJ and a point light, spp {spps}, references {args.reference_spp} spp", rows, targets)
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
