"""The time-to-error analysis `mitsuba_time.py` and `pathtracer_time.py` share: from one
renderer's runs at several sample counts and its reference, its CPU cost per sample, its error
per run and the CPU time it takes to each target error; and the table of those figures.

CPU: the line `CPU = U0 + N·u` through the runs (`u`: CPU seconds per sample per pixel).
Error: RMSE over R, G, B of every pixel relative to the reference's mean, the reference's own
noise taken out with the constant `c` of the fit `MSE(N) = a/N + c`; the line through (log CPU
seconds of sampling `u·N`, log RMSE) gives the time to each target.
"""

import numpy as np

from cycles_time import cpu, line_fit, mse_fit


def fit(renderer, threads, runs, images, reference, targets):
    """The row of `renderer` on `threads` threads: `runs` (records with `spp` and CPU times)
    and their `images` against `reference`."""
    mean = reference.mean()
    u0, u = line_fit([r["spp"] for r in runs], [cpu(r) for r in runs])
    mses = [float(((img - reference) ** 2).mean()) for img in images]
    a, c = mse_fit([r["spp"] for r in runs], mses)
    rmse = [np.sqrt(max(m - c, 1e-30)) / mean for m in mses]
    b0, b1 = line_fit(np.log([u * r["spp"] for r in runs]), np.log(rmse))
    to = {x: float(np.exp((np.log(x) - b0) / b1)) for x in targets}
    pixels = reference.shape[0] * reference.shape[1]
    return {"renderer": renderer, "threads": threads, "sps": pixels / u, "u0": u0, "mean": mean,
            "a": a / mean**2, "c": c / mean**2, "rmse": rmse, "to": to}


def measure(bench, renderers, reference_spp, spps, threads, targets):
    """Each renderer's reference (on the most threads), then its runs at `spps` on each of
    `threads`: the rows of [`fit`]. `bench.run(renderer, spp, threads, reference=...)` renders
    and returns a record; `bench.image(record)` reads its image at the runs' size."""
    rows = []
    for renderer in renderers:
        reference = bench.image(bench.run(renderer, reference_spp, max(threads), reference=True))
        for t in threads:
            runs = [bench.run(renderer, n, t) for n in spps]
            rows.append(fit(renderer, t, runs, [bench.image(r) for r in runs], reference, targets))
    return rows


def print_table(title, rows, targets):
    print(f"\n{title}")
    print("| renderer | threads | samples per CPU-second | U0 (CPU s) | image mean | relative MSE per sample (a / mean²) | reference noise (c / mean²) | RMSE / mean | CPU s to " + " | ".join(f"{x:.0%}" for x in targets) + " |")
    print("|---|---|---|---|---|---|---|---|" + "---|" * len(targets))
    for r in rows:
        errors = " / ".join(f"{100 * e:.1f}" for e in r["rmse"])
        times = " | ".join(f"{r['to'][x]:.2f}" for x in targets)
        print(f"| {r['renderer']} | {r['threads']} | {r['sps'] / 1e3:.0f} k | {r['u0']:.2f} | {r['mean']:.4f} | {r['a']:.3e} | {r['c']:.1e} | {errors} % | {times} |")
