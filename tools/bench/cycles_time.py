"""strahl against Blender Cycles (CPU): samples per second, and the CPU time each takes to reach
the same error, on one scene given to both as the same file (docs/performance.md, "strahl
against Cycles: time to the same error"; `make bench-cycles` runs it on both scenes).

    python3 tools/bench/cycles_time.py --scene cornell --work target/bench-cycles
    python3 tools/bench/cycles_time.py --scene dense --work target/bench-cycles
    # options, with their defaults:
    #   --strahl target/release/strahl (cargo build --release)
    #   --size 240x135 --spp 4,16,64,256 --adaptive-spp 128,512 --reference-spp 1024 --threads 2
    #   --sps-size 1920x1080 --sps-spp 1,4 --sps-threads 1,2 --target 0.1,0.05,0.02 --depth 8
    #   --only sps|error (one half of the runs) --seeds 1

Needs `blender` (3.4, run headless with `-b`), python3 with numpy and OpenEXR, and a release
strahl. Every run's record is kept in WORK/SCENE/runs.json, so an interrupted benchmark resumes
where it stopped; delete the directory to measure again.

The scene. tools/gltf/blender_cornell.py builds it in Blender and writes it twice: as glTF
(exported by Blender's own exporter), which strahl renders, and as the .blend Cycles renders,
set to what strahl computes: the same max bounces (`--depth 8` scatterings, Cycles' max bounces
7 of every kind), no clamps, no glossy filter, no denoiser, a box pixel filter one pixel wide
(strahl's pixel filter, as tests/cycles.rs sets it), adaptive sampling off. `cornell` is the
Cornell-like room of tests/cycles.rs (diffuse walls and light, a diffuse block, a mirror-like
metal sphere and a glass sphere, 8,000 triangles); `dense` the same room with a Suzanne
subdivided to 1,007,616 triangles in place of the block and a 200 x 200 floor grid, both textured
with a UV grid image (1,095,568 triangles). All sizes must have the aspect of the first one the
scene was exported at (16:9 by default), since the glTF camera keeps it.

The runs, each a fresh process, timed from outside: wall time, and user + system CPU time of
the process (os.wait4's rusage of that one child). On a shared machine the CPU time is the
figure to compare: it does not count the time a thread waits for a core. The renderers take
turns (strahl first at one setting, Cycles first at the next) and the load average is recorded
before and after each run.

- Samples per second, at `--sps-size` on each of `--sps-threads`: strahl and Cycles (adaptive
  sampling off) at each of `--sps-spp`. The CPU time of a run is `U0 + N·u` for N samples per
  pixel: the line through the runs gives `u`, the CPU time per sample per pixel, and `U0`, what
  a run costs before and after sampling. Both renderers also say where their wall time went:
  Cycles writes its synchronisation time (scene export to the device, shaders, BVH build) and
  its rendering time into the EXR's header (`cycles.ViewLayer.synchronization_time`,
  `render_time`); strahl prints its BVH build and its rendering time. What is left of the wall
  time is start-up (Blender's own is seconds: it loads its Python and add-ons) and output.
- Error against a reference, at `--size`: strahl and Cycles at each of `--spp`, each with
  adaptive sampling (Blender's default for Cycles: noise threshold 0.01, automatic minimum
  samples; strahl's `--adaptive-threshold 0.01`, the same rule) at each of `--adaptive-spp` as
  its maximum, each against its own renderer's reference of
  `--reference-spp` samples per pixel, so that the figure measures noise, not the systematic
  differences between the two renderers (tests/cycles.rs measures those). RMSE over the R, G
  and B values of every pixel. The reference shares no sample with the images it judges:
  Cycles' reference is rendered with another seed (1, the others 0); strahl's samples are a
  function of the pixel's index alone, so its reference is rendered at twice the width and
  height with a quarter of the samples and averaged 2 x 2, which with a box filter one pixel
  wide is the same estimate of each pixel from other sample sequences. The reference's own
  noise is subtracted: RMSE = sqrt(MSE - c), with c the constant of the fit MSE(N) = a/N + c
  over the renderer's uniform runs of 16 spp and more (the first samples of a low-discrepancy
  sequence converge faster than 1/N, which would make c negative); for strahl also with its
  reference's variance pass in place of c (the four sub-pixels' variances of the mean over 16),
  printed beside it: computed from the samples as if they were independent, it is the larger
  of the two. The RMSE is given relative to the reference's image mean.
- Time to a fixed error: the line through each renderer's points (log CPU seconds of
  sampling, log RMSE) gives the CPU time at which it reaches each relative RMSE of `--target`,
  sampling alone (u·N of the error runs' own line for the uniform runs, the run's CPU time
  less U0 for the adaptive ones; U0 is printed beside it); a target outside the runs' range is extrapolated along the line and marked so.
  The time to a given error scales with the pixel count; the figures are for `--size`.
- `--seeds K`: every test run of the error half is made K times, with K seeds (strahl's
  `--seed`: 0 to K - 1; Cycles' seed: 0, then 2 to K, 1 being its reference's), and the
  squared errors and CPU times of a setting are the means over its K runs. One run's squared
  error on a scene with caustics moves by several percent with its rare bright samples (on
  *cornell* at 64 spp, eight runs of either renderer spread over -4 % to +6 % of their mean);
  the standard error of the K runs' mean is printed beside it.
"""

import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import time

import numpy as np
import OpenEXR

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
STRAHL_LAYER = "ViewLayer.Combined."
VARIANCE_LAYER = "ViewLayer.Variance."


def parse_size(text):
    w, h = text.lower().split("x")
    return int(w), int(h)


def parse_list(text):
    return [int(v) for v in text.split(",") if v]


def clock_seconds(text):
    """Blender's "MM:SS.ss" or "HH:MM:SS.ss" as seconds."""
    seconds = 0.0
    for part in text.strip().split(":"):
        seconds = 60.0 * seconds + float(part)
    return seconds


def blender_env():
    """The environment for Blender: Debian's Blender takes its Python home from the first
    python3 on PATH, so a pyenv or virtualenv python running this script (which puts its own
    bin/ first) would hide the system's modules (numpy, which its glTF exporter needs)."""
    env = dict(os.environ)
    hidden = [d for d in (env.get("PYENV_ROOT"), env.get("VIRTUAL_ENV"), sys.prefix) if d and d != "/usr"]
    dirs = env.get("PATH", "").split(os.pathsep)
    env["PATH"] = os.pathsep.join(d for d in dirs if not any(d.startswith(h) for h in hidden))
    return env


def timed(cmd, log_path):
    """Runs `cmd` with its output in `log_path`; returns wall seconds, user and system CPU
    seconds of that process (and its children, which neither renderer has), and the load
    average before and after."""
    load_before = os.getloadavg()[0]
    start = time.monotonic()
    with open(log_path, "w") as log:
        env = blender_env() if cmd[0] == "blender" else None
        proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, env=env)
        _, status, usage = os.wait4(proc.pid, 0)
    wall = time.monotonic() - start
    code = os.waitstatus_to_exitcode(status)
    if code != 0:
        with open(log_path) as log:
            tail = log.read()[-3000:]
        sys.exit(f"{cmd[0]} failed ({code}); {log_path}:\n{tail}")
    return {
        "wall": wall,
        "user": usage.ru_utime,
        "sys": usage.ru_stime,
        "load_before": load_before,
        "load_after": os.getloadavg()[0],
    }


def read_channels(path):
    with OpenEXR.File(path, separate_channels=True) as f:
        header = dict(f.header())  # before reading the channels, which empties it
        return {name: np.asarray(ch.pixels, dtype=np.float64) for name, ch in f.channels().items()}, header


def rgb(channels, prefix):
    return np.stack([channels[prefix + c] for c in "RGB"], axis=-1)


class Bench:
    def __init__(self, args):
        self.args = args
        self.dir = os.path.abspath(os.path.join(args.work, args.scene))
        os.makedirs(self.dir, exist_ok=True)
        self.records_path = os.path.join(self.dir, "runs.json")
        self.gltf = os.path.join(self.dir, "cornell.gltf")
        self.blend = os.path.join(self.dir, "cornell.blend")

    def records(self):
        """The runs recorded so far (read afresh: two benchmarks may share the directory)."""
        if not os.path.exists(self.records_path):
            return {}
        with open(self.records_path) as f:
            return json.load(f)

    def save(self, key, record):
        records = self.records()
        records[key] = record
        tmp = f"{self.records_path}.{os.getpid()}.tmp"
        with open(tmp, "w") as f:
            json.dump(records, f, indent=1, sort_keys=True)
        os.replace(tmp, self.records_path)

    def export(self):
        if os.path.exists(self.gltf) and os.path.exists(self.blend):
            return
        w, h = parse_size(self.args.size)
        flags = ["blend"] + (["dense"] if self.args.scene == "dense" else [])
        print(f"exporting the {self.args.scene} scene with Blender into {self.dir}", flush=True)
        cmd = ["blender", "-b", "--factory-startup", "--python", os.path.join(ROOT, "tools/gltf/blender_cornell.py")]
        cmd += ["--", self.dir, f"{w}x{h}", "0", str(self.args.depth)] + flags
        timed(cmd, os.path.join(self.dir, "export.log"))

    def run(self, renderer, size, spp, threads, kind="test", seed=0):
        """One render (cached): `renderer` strahl | strahl-adaptive | cycles | cycles-adaptive; `kind` test |
        reference; `seed` the test run's seed (strahl's `--seed`; Cycles' seed, 0 where it is 0).
        Returns its record."""
        w, h = size
        key = f"{renderer}-{kind}-{w}x{h}-{spp}spp-{threads}t" + (f"-seed{seed}" if seed else "")
        done = self.records().get(key)
        if done is not None and os.path.exists(done["exr"]):
            return done
        exr = os.path.join(self.dir, key + ".exr")
        log = os.path.join(self.dir, key + ".log")
        if renderer.startswith("strahl"):
            if kind == "reference":
                w, h, spp_run = 2 * w, 2 * h, spp // 4
            else:
                spp_run = spp
            cmd = [self.args.strahl, "render", self.gltf, "-o", exr, "--width", str(w), "--height", str(h)]
            cmd += ["--spp", str(spp_run), "--depth", str(self.args.depth), "--threads", str(threads)]
            cmd += ["--integrator", "path", "--passes", "combined,variance" if kind == "reference" else "combined"]
            cmd += ["--progress-interval", "30"] + (["--seed", str(seed)] if seed else [])
            if renderer == "strahl-adaptive":
                cmd += ["--adaptive-threshold", str(self.args.strahl_threshold)]
        else:
            adaptive = renderer == "cycles-adaptive"
            seed = 1 if kind == "reference" else seed
            setup = (
                "import bpy; s = bpy.context.scene; c = s.cycles; "
                f"c.samples = {spp}; c.seed = {seed}; c.use_adaptive_sampling = {adaptive}; "
                "c.adaptive_threshold = 0.01; c.adaptive_min_samples = 0; "
                f"s.render.resolution_x = {w}; s.render.resolution_y = {h}; s.render.resolution_percentage = 100"
            )
            out = exr[: -len(".exr")] + "-#"
            cmd = ["blender", "-b", self.blend, "--python-expr", setup, "-t", str(threads), "-o", out, "-f", "1"]
        print(f"  {key} ...", end="", flush=True)
        record = timed(cmd, log)
        if not renderer.startswith("strahl"):
            os.replace(exr[: -len(".exr")] + "-1.exr", exr)
        record.update(self.phases(renderer, exr, log))
        record.update({"exr": exr, "renderer": renderer, "kind": kind, "width": size[0], "height": size[1]})
        record.update({"spp": spp, "threads": threads, "seed": seed})
        print(
            f" wall {record['wall']:.1f} s, CPU {record['user'] + record['sys']:.1f} s, "
            f"setup {record['setup']:.2f} s, sampling {record['sampling']:.1f} s, load {record['load_before']:.1f}",
            flush=True,
        )
        self.save(key, record)
        return record

    def phases(self, renderer, exr, log):
        """Wall seconds of setup (scene to the device, BVH build) and of sampling, as the
        renderer reports them."""
        if renderer.startswith("strahl"):
            with open(log) as f:
                text = f.read()
            build = re.search(r"BVH built in ([0-9.]+) ms", text)
            render = re.search(r"time: ([0-9.]+) s rendering", text)
            return {"setup": float(build.group(1)) / 1e3, "sampling": float(render.group(1))}
        _, header = read_channels(exr)
        return {
            "setup": clock_seconds(header["cycles.ViewLayer.synchronization_time"]),
            "sampling": clock_seconds(header["cycles.ViewLayer.render_time"]),
        }

    def image(self, record):
        """The RGB image of a run, and for a strahl reference the variance of its pixels'
        means (2 x 2 pooled)."""
        channels, _ = read_channels(record["exr"])
        if record["renderer"].startswith("strahl"):
            img = rgb(channels, STRAHL_LAYER)
        else:
            img = np.stack([channels[c] for c in "RGB"], axis=-1)
        if record["renderer"] == "strahl" and record["kind"] == "reference":
            h, w = record["height"], record["width"]
            img = img.reshape(h, 2, w, 2, 3).mean(axis=(1, 3))
            var = rgb(channels, VARIANCE_LAYER).reshape(h, 2, w, 2, 3).sum(axis=(1, 3)) / 16.0
            return img, var
        return img, None


def line_fit(xs, ys):
    """Least-squares y = a + b·x."""
    b, a = np.polyfit(np.asarray(xs, float), np.asarray(ys, float), 1)
    return a, b


def mse_fit(ns, mses):
    """MSE(N) = a/N + c, least squares relative to each MSE (so every N counts alike)."""
    ns, mses = np.asarray(ns, float), np.asarray(mses, float)
    design = np.stack([1.0 / ns, np.ones_like(ns)], axis=1) / mses[:, None]
    (a, c), *_ = np.linalg.lstsq(design, np.ones_like(ns), rcond=None)
    return a, c


def cpu(record):
    return record["user"] + record["sys"]


def seeds_of(renderer, k):
    """The seeds of a setting's K test runs: strahl 0 to K - 1; Cycles 0, then 2 to K (its
    reference has seed 1)."""
    if renderer.startswith("strahl"):
        return list(range(k))
    return [0] + list(range(2, k + 1))


def mean_over_seeds(runs, mses):
    """One record per spp: the runs' mean CPU time and load, and the mean of their squared
    errors with its standard error (0 for one run)."""
    by_spp = {}
    for r, m in zip(runs, mses):
        by_spp.setdefault(r["spp"], []).append((r, m))
    out, means, spread = [], [], []
    for spp in sorted(by_spp):
        group = by_spp[spp]
        r = dict(group[0][0])
        for field in ["user", "sys", "wall", "setup", "sampling"]:
            r[field] = float(np.mean([g[0][field] for g in group]))
        r["load_before"] = min(g[0]["load_before"] for g in group)
        r["load_after"] = max(g[0]["load_after"] for g in group)
        ms = np.array([g[1] for g in group])
        out.append(r)
        means.append(float(ms.mean()))
        spread.append(float(ms.std(ddof=1) / math.sqrt(len(ms))) if len(ms) > 1 else 0.0)
    return out, means, spread


def sps(bench):
    args = bench.args
    size = parse_size(args.sps_size)
    rows = []
    turn = 0
    for threads in parse_list(args.sps_threads):
        runs = {"strahl": [], "cycles": []}
        for spp in parse_list(args.sps_spp):
            order = ["strahl", "cycles"] if turn % 2 == 0 else ["cycles", "strahl"]
            turn += 1
            for renderer in order:
                runs[renderer].append(bench.run(renderer, size, spp, threads))
        for renderer, rs in runs.items():
            u0, u = line_fit([r["spp"] for r in rs], [cpu(r) for r in rs])
            pixels = size[0] * size[1]
            last = rs[-1]
            rows.append(
                {
                    "renderer": renderer,
                    "threads": threads,
                    "cpu_per_spp": u,
                    "cpu_fixed": u0,
                    "samples_per_cpu_second": pixels / u,
                    "samples_per_wall_second": pixels * last["spp"] / last["sampling"],
                    "samples_per_cpu_second_run": pixels * last["spp"] / cpu(last),
                    "setup": last["setup"],
                    "wall": last["wall"],
                    "sampling": last["sampling"],
                    "spp": last["spp"],
                    "load": (min(r["load_before"] for r in rs), max(r["load_after"] for r in rs)),
                }
            )
    w, h = size
    print(f"\nSamples per second, {args.scene}, {w} x {h}, depth {args.depth}")
    print(
        "| renderer | threads | samples/s (wall, sampling) | samples per CPU-second (whole run, N spp) | "
        "the same from the line's slope | CPU s per spp | CPU s outside sampling (U0) | setup (wall) | "
        "whole run (wall, N spp) | load average |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['renderer']} | {r['threads']} | {r['samples_per_wall_second'] / 1e3:.0f} k | "
            f"{r['samples_per_cpu_second_run'] / 1e3:.0f} k | "
            f"{r['samples_per_cpu_second'] / 1e3:.0f} k | {r['cpu_per_spp']:.2f} | {r['cpu_fixed']:.2f} | "
            f"{r['setup']:.2f} s | {r['wall']:.1f} s ({r['spp']}) | {r['load'][0]:.1f}–{r['load'][1]:.1f} |"
        )
    return rows


def error(bench):
    args = bench.args
    size = parse_size(args.size)
    threads = args.threads
    refs = {}
    for renderer in ["strahl", "cycles"]:
        refs[renderer] = bench.run(renderer, size, args.reference_spp, threads, kind="reference")
    plan = [("strahl", n) for n in parse_list(args.spp)] + [("cycles", n) for n in parse_list(args.spp)]
    plan += [(f"{r}-adaptive", n) for r in ["strahl", "cycles"] for n in parse_list(args.adaptive_spp)]
    # Take turns: strahl's run at one count, then Cycles' at it, then the next count, Cycles first.
    ordered = []
    counts = sorted({n for _, n in plan})
    for i, n in enumerate(counts):
        here = [p for p in plan if p[1] == n]
        ordered += here if i % 2 == 0 else here[::-1]
    runs = {"strahl": [], "cycles": [], "strahl-adaptive": [], "cycles-adaptive": []}
    for renderer, n in ordered:
        for seed in seeds_of(renderer, args.seeds):
            runs[renderer].append(bench.run(renderer, size, n, threads, seed=seed))

    images = {}
    for name, ref in refs.items():
        images[name] = bench.image(ref)
    results = {}
    for renderer, rs in runs.items():
        base = "strahl" if renderer.startswith("strahl") else "cycles"
        ref_img, ref_var = images[base]
        rs = sorted(rs, key=lambda r: r["spp"])
        mses = [float(((bench.image(r)[0] - ref_img) ** 2).mean()) for r in rs]
        rs, mses, spread = mean_over_seeds(rs, mses)
        results[renderer] = {"runs": rs, "mses": mses, "spread": spread, "mean": float(ref_img.mean())}
    # The reference's own noise: the fit's constant for both renderers (over the runs of 16 spp
    # and more, where a/N holds best: the first samples of a low-discrepancy sequence converge
    # faster), and for strahl also its reference's variance pass.
    fits = {}
    for renderer in ["strahl", "cycles"]:
        pairs = [(r["spp"], m) for r, m in zip(results[renderer]["runs"], results[renderer]["mses"]) if r["spp"] >= 16]
        fits[renderer] = mse_fit(*zip(*pairs))
    var_s = float(images["strahl"][1].mean())
    subtract = {
        "strahl": {"variance pass": var_s, "fit": fits["strahl"][1]},
        "cycles": {"fit": fits["cycles"][1]},
        "strahl-adaptive": {"variance pass": var_s, "fit": fits["strahl"][1]},
        "cycles-adaptive": {"fit": fits["cycles"][1]},
    }
    # What a run costs outside sampling: the intercept of CPU time against spp of the uniform runs.
    for renderer in ["strahl", "cycles"]:
        rs = results[renderer]["runs"]
        results[renderer]["u0"], results[renderer]["u"] = line_fit([r["spp"] for r in rs], [cpu(r) for r in rs])
    results["cycles-adaptive"]["u0"] = results["cycles"]["u0"]
    results["strahl-adaptive"]["u0"] = results["strahl"]["u0"]

    w, h = size
    print(f"\nError against each renderer's own reference, {args.scene}, {w} x {h}, depth {args.depth}, {threads} threads")
    for renderer, (a, c) in fits.items():
        m2 = results[renderer]["mean"] ** 2
        print(
            f"{renderer}: reference {args.reference_spp} spp; fit MSE = {a:.3e}/N + {c:.3e} over N >= 16 "
            f"(reference's noise {100 * math.sqrt(max(c, 0) / m2):.2f} % of the mean)"
            + (f"; variance pass {var_s:.3e} ({100 * math.sqrt(var_s / m2):.2f} %)" if renderer == "strahl" else "")
        )
        print(
            f"{renderer}: CPU time = {results[renderer]['u0']:.2f} s + {results[renderer]['u']:.3f} s x spp; "
            f"reference: {cpu(refs[renderer]):.1f} s CPU, wall {refs[renderer]['wall']:.1f} s"
        )
    print(f"{args.seeds} run(s) per setting: CPU times and squared errors are their means")
    print(
        "| renderer | spp | CPU s (whole run) | CPU s sampling | setup (wall) | RMSE / mean, raw | "
        "MSE's standard error over the runs | less the reference's noise (fit) | (variance pass) | load |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    lines = {}
    for renderer, res in results.items():
        points = {variant: [] for variant in subtract[renderer]}
        for r, m, sd in zip(res["runs"], res["mses"], res["spread"]):
            # Uniform runs: the line's u·N (a small run's CPU time less U0 is mostly noise);
            # adaptive runs, whose samples per pixel vary: the run's CPU time less U0.
            sampling_cpu = res["u"] * r["spp"] if "u" in res else cpu(r) - res["u0"]
            rel = {v: math.sqrt(max(m - c, 1e-30)) / res["mean"] for v, c in subtract[renderer].items()}
            for v in rel:
                points[v].append((math.log(sampling_cpu), math.log(rel[v])))
            vp = f"{100 * rel['variance pass']:.2f} %" if "variance pass" in rel else "–"
            print(
                f"| {renderer} | {r['spp']} | {cpu(r):.1f} | {sampling_cpu:.1f} | {r['setup']:.2f} s | "
                f"{100 * math.sqrt(m) / res['mean']:.2f} % | {100 * sd / m:.1f} % | {100 * rel['fit']:.2f} % | {vp} | "
                f"{r['load_before']:.1f}–{r['load_after']:.1f} |"
            )
        for v, pts in points.items():
            xs, ys = zip(*pts)
            a, b = line_fit(xs, ys)
            lines[(renderer, v)] = (a, b, min(xs), max(xs), res["u0"])
    targets = [float(t) for t in str(args.target).split(",")]
    print(f"\nCPU seconds of sampling to a relative RMSE (U0 is added once per run), {w} x {h}")
    print("| renderer | noise taken out by | slope | U0 | " + " | ".join(f"{100 * t:g} %" for t in targets) + " |")
    print("|---|---|---|---|" + "---|" * len(targets))
    times = {}
    for (renderer, v), (a, b, lo, hi, u0) in lines.items():
        cells = []
        for t in targets:
            x = (math.log(t) - a) / b
            times[(renderer, v, t)] = math.exp(x)
            cells.append(f"{math.exp(x):.1f}" + ("" if lo <= x <= hi else " (extrapolated)"))
        print(f"| {renderer} | {v} | {b:.2f} | {u0:.2f} | " + " | ".join(cells) + " |")
    for t in targets:
        for v in ["fit", "variance pass"]:
            s = times[("strahl", v, t)]
            print(
                f"at {100 * t:g} % (strahl's reference noise by {v}): Cycles / strahl {times[('cycles', 'fit', t)] / s:.2f}, "
                f"Cycles adaptive / strahl {times[('cycles-adaptive', 'fit', t)] / s:.2f}, "
                f"Cycles adaptive / strahl adaptive {times[('cycles-adaptive', 'fit', t)] / times[('strahl-adaptive', v, t)]:.2f}"
            )
    return results, times


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", choices=["cornell", "dense"], default="cornell")
    p.add_argument("--work", default=os.path.join(ROOT, "target", "bench-cycles"))
    p.add_argument("--strahl", default=os.path.join(os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target")), "release", "strahl"))
    p.add_argument("--size", default="240x135")
    p.add_argument("--spp", default="4,16,64,256")
    p.add_argument("--adaptive-spp", default="128,512")
    p.add_argument("--strahl-threshold", type=float, default=0.01, help="strahl's --adaptive-threshold (the runs are cached by name: use another --work to change it)")
    p.add_argument("--reference-spp", type=int, default=1024)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--sps-size", default="1920x1080")
    p.add_argument("--sps-spp", default="1,4")
    p.add_argument("--sps-threads", default="1,2")
    p.add_argument("--target", default="0.1,0.05,0.02")
    p.add_argument("--depth", type=int, default=8)
    p.add_argument("--only", choices=["sps", "error"])
    p.add_argument("--seeds", type=int, default=1, help="test runs per setting of the error half, each with its own seed")
    args = p.parse_args()
    if shutil.which("blender") is None:
        print("bench-cycles: skipped, blender is not installed (apt-get install blender python3-numpy)")
        return
    if not os.access(args.strahl, os.X_OK):
        sys.exit(f"{args.strahl}: no strahl binary (cargo build --release, or give --strahl)")
    if args.reference_spp % 4 != 0:
        sys.exit("--reference-spp must be a multiple of 4 (strahl's reference: a quarter of it at 2x2 the pixels)")
    print(f"load average at start: {os.getloadavg()}", flush=True)
    bench = Bench(args)
    bench.export()
    if args.only != "error":
        sps(bench)
    if args.only != "sps":
        error(bench)
    print(f"load average at end: {os.getloadavg()}")


if __name__ == "__main__":
    main()
