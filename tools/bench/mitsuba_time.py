"""strahl against Mitsuba 3: samples per CPU-second and the CPU time each takes to reach the same
error, on the Cornell box both render from one description (docs/performance.md, "strahl
against Mitsuba 3"; `make bench-mitsuba` runs it).

    python3 tools/bench/mitsuba_time.py --work target/bench-mitsuba
    # options, with their defaults:
    #   --strahl target/release/strahl --scene tools/mitsuba/cornell-path.toml
    #   --size 128 --spp 4,16,64,256 --reference-spp 4096 --threads 1,2 --variants scalar_rgb
    #   --samplers independent,ldsampler
    #   --target 0.1,0.05,0.02

Needs python3 with mitsuba (pip), numpy and OpenEXR, and a release strahl.

The scene is the one `make test-mitsuba` checks the two renderers agree on: the Cornell box of
tools/mitsuba/cornell-path.toml (diffuse walls, the quad light of the ceiling's opening, 8
bounces), translated for Mitsuba by tools/mitsuba-compare.py (PLY walls, a `rectangle` emitter,
the `path` integrator with `max_depth` 9 = 8 scatterings, a box filter), rendered as an RGB
image of `--size`², with each of Mitsuba's `--samplers` (`independent`, as `make test-mitsuba`
uses, and `ldsampler`, its low-discrepancy one; strahl's is an Owen-scrambled Sobol sequence).

Every run is a fresh process timed from outside (os.wait4's user + system CPU time of that one
child): strahl's `render` of the TOML file, Mitsuba's a python3 of this script (`--mitsuba-run`)
that loads the scene, renders it on `--threads` threads (drjit's pool) and saves the image
(NumPy). The
line `CPU = U0 + N·u` through each renderer's runs gives `u`, its CPU seconds per sample per
pixel, and `U0`, what a run costs besides sampling (Python and Mitsuba's import: about 0.5 s).

Error: RMSE over R, G, B of every pixel, relative to the image mean, against each renderer's own
reference of `--reference-spp`: Mitsuba's rendered with seed 1 (the runs use seed 0), strahl's
at twice the size with a quarter of the samples, averaged 2 × 2 (strahl's samples are a function
of the pixel index: other pixels' samples are independent of the runs'). The reference's own
noise is taken out with the constant `c` of the fit `MSE(N) = a/N + c` over the runs. The line
through (log CPU seconds of sampling, log RMSE) gives the CPU time to each `--target`.

Mitsuba's `llvm_ad_rgb` needs an LLVM newer than Debian bookworm's 14 (its kernels use
`fminimum`, which LLVM 14 cannot select; bookworm's LLVM 15 and 16, given through
`DRJIT_LIBLLVM_PATH`, fail the same way): on this machine image it aborts, and the run says so
instead of timing it.
"""

import argparse
import importlib.util
import os
import subprocess
import sys
import tempfile
import tomllib

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import error_fit  # noqa: E402
from cycles_time import cpu, parse_list, read_channels, rgb, timed  # noqa: E402


def mitsuba_run(variant, sampler, scene_path, size, spp, threads, seed, out):
    """One Mitsuba render, in this process (the benchmark's child), with its `sampler`."""
    spec = importlib.util.spec_from_file_location("mitsuba_compare", os.path.join(ROOT, "tools", "mitsuba-compare.py"))
    compare = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(compare)
    import drjit as dr
    import mitsuba as mi

    mi.set_variant(variant)
    # One thread: a pool of 0 (the calling thread renders); a pool of 1 never finishes in
    # Mitsuba 3.9.1's scalar variant.
    dr.set_thread_count(threads if threads > 1 else 0)
    with open(scene_path, "rb") as f:
        toml = tomllib.load(f)
    with tempfile.TemporaryDirectory() as tmp:
        description = compare.mitsuba_scene(toml, size, spp, tmp)
        description["sensor"]["sampler"] = {"type": sampler, "sample_count": spp}
        scene = mi.load_dict(description)
        image = mi.render(scene, seed=seed, spp=spp)
        # As a NumPy array: Mitsuba's EXR writer waits on the thread pool, which a pool of 0
        # never runs.
        np.save(out, np.array(image, dtype=np.float32)[..., :3])
    # Leave without the thread pool's teardown, which hangs after a pool of 0 too.
    sys.stdout.flush()
    os._exit(0)


class Bench:
    def __init__(self, args):
        self.args = args
        self.dir = os.path.abspath(args.work)
        os.makedirs(self.dir, exist_ok=True)

    def run(self, renderer, spp, threads, reference=False):
        """One run (fresh process) of `renderer` (`strahl` or `VARIANT/SAMPLER` of Mitsuba): its
        record."""
        a, size = self.args, self.args.size
        name = renderer.replace("/", "-")
        key = f"{name}-{'reference' if reference else 'test'}-{size}-{spp}spp-{threads}t"
        exr = os.path.join(self.dir, key + (".exr" if renderer == "strahl" else ".npy"))
        log = os.path.join(self.dir, key + ".log")
        w, n = (2 * size, spp // 4) if reference and renderer == "strahl" else (size, spp)
        if renderer == "strahl":
            cmd = [a.strahl, "render", a.scene, "-o", exr, "--width", str(w), "--height", str(w)]
            cmd += ["--spp", str(n), "--threads", str(threads), "--integrator", "path", "--passes", "combined"]
        else:
            seed = 1 if reference else 0
            cmd = [sys.executable, os.path.abspath(__file__), "--mitsuba-run", *renderer.split("/"), a.scene]
            cmd += [str(size), str(spp), str(threads), str(seed), exr]
        print(f"  {key} ...", end="", flush=True)
        record = timed(cmd, log)
        record.update({"exr": exr, "renderer": renderer, "spp": spp, "threads": threads, "size": w})
        print(f" wall {record['wall']:.1f} s, CPU {cpu(record):.1f} s, load {record['load_before']:.1f}", flush=True)
        return record

    def image(self, record):
        """The run's image at `--size`² (strahl's reference, rendered at twice the size,
        averaged 2 × 2)."""
        size = self.args.size
        if record["renderer"] != "strahl":
            return np.load(record["exr"]).astype(np.float64).reshape(size, size, 3)
        channels, _ = read_channels(record["exr"])
        img = rgb(channels, "ViewLayer.Combined.")
        if record["size"] != size:
            img = img.reshape(size, 2, size, 2, 3).mean(axis=(1, 3))
        return img.reshape(size, size, 3)


def works(variant):
    """Whether the Mitsuba variant renders here (llvm_ad_rgb aborts with Debian's LLVM 14)."""
    code = (
        "import mitsuba as mi, drjit as dr; mi.set_variant(%r); "
        "s = mi.load_dict(mi.cornell_box()); dr.eval(mi.render(s, spp=1))" % variant
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["(no message)"])[0]
        print(f"mitsuba {variant}: skipped, it does not render on this machine: {last}")
    return done.returncode == 0


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--work", default=os.path.join(ROOT, "target", "bench-mitsuba"))
    p.add_argument("--strahl", default=os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "strahl"))
    p.add_argument("--scene", default=os.path.join(ROOT, "tools", "mitsuba", "cornell-path.toml"))
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp", default="4,16,64,256")
    p.add_argument("--reference-spp", type=int, default=4096)
    p.add_argument("--threads", default="1,2")
    p.add_argument("--variants", default="scalar_rgb")
    p.add_argument("--samplers", default="independent,ldsampler", help="Mitsuba's samplers, each timed")
    p.add_argument("--target", default="0.1,0.05,0.02")
    p.add_argument("--mitsuba-run", nargs=8, metavar=("VARIANT", "SAMPLER", "SCENE", "SIZE", "SPP", "THREADS", "SEED", "OUT"))
    args = p.parse_args()
    if args.mitsuba_run:
        v, sampler, scene, size, spp, threads, seed, out = args.mitsuba_run
        mitsuba_run(v, sampler, scene, int(size), int(spp), int(threads), int(seed), out)
        return
    bench = Bench(args)
    variants = [v for v in args.variants.split(",") if v and works(v)]
    renderers = ["strahl"] + [f"{v}/{s}" for v in variants for s in args.samplers.split(",") if s]
    spps, targets = parse_list(args.spp), [float(t) for t in args.target.split(",")]
    threads = parse_list(args.threads)
    print(f"load average at start: {os.getloadavg()}")
    rows = error_fit.measure(bench, renderers, args.reference_spp, spps, threads, targets)
    error_fit.print_table(f"{args.size}² pixels, {os.path.basename(args.scene)}, spp {spps}, references {args.reference_spp} spp", rows, targets)
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
