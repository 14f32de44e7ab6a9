#!/usr/bin/env python3
"""Renders tools/mitsuba/cornell-diffuse.toml with strahl and the same scene with Mitsuba 3, and
compares the two images (see docs/mitsuba.md).

    python3 tools/mitsuba-compare.py STRAHL_BINARY [--spp N] [--size S] [--copies K]
        [--mitsuba-spp M] [--seeds J] [--scene FILE]

The Mitsuba scene is built from the TOML file itself (tomllib), so both renderers see the same
numbers: `triangles` objects (positions × scale, the same triangles, so the Cornell walls that
are not exact rectangles stay exact) as PLY meshes in a temporary directory with two-sided
`diffuse` BSDFs of the same RGB reflectance (strahl shades both sides of a surface); `quad`
lights as `rectangle` shapes with a one-sided `area` emitter, whose to_world maps the
rectangle's [-1, 1]² onto the parallelogram and its +z normal onto edge1 × edge2; a
`perspective` sensor with the same eye, target and up and the vertical field of view
(`fov_axis = 'y'`); a `box` reconstruction filter (each sample counts for its own pixel only, as
strahl's mean over the pixel); the `direct` integrator with one emitter sample and no BSDF
sample (light sampling by area, an unbiased estimate of emission plus direct light, exactly what
strahl's Whitted integrator computes in an all-diffuse scene), or for a scene with
`[render] integrator = "path"` Mitsuba's `path` integrator with the same number of bounces
(tools/mitsuba/cornell-path.toml); variant `scalar_rgb`.

**Noise.** Both images are Monte Carlo estimates, so each pixel's difference is compared with
its standard error, and each renderer's error is measured from independent renders:

* Mitsuba: `--seeds J` renders with seeds 0 … J−1 of `M/J` samples each (the `independent`
  sampler); a pixel's estimate is their mean, its variance their sample variance over J.
* strahl draws every pixel's samples from its index `y·W + x` alone, so a second render of the
  same file is the same image. But the camera of a `W'`-wide image, `W' = W + 2j`, traces
  through pixel `x + j` exactly the rays of pixel `x` of the `W`-wide one (the image plane grows
  by `j` pixels on each side; checked bit for bit at 1 spp), with other pixel indices and so
  independent samples. `--copies K` renders `--region j,0,j+W,H` of the `(W + 2j)`-wide image for
  j = 0 … K−1; a pixel's estimate is their mean, its variance their sample variance over K.

With K and J small a pixel's own variance estimate is itself noisy, so each is replaced by the
larger of it and its 3×3 neighbourhood's mean (clipped at the border): the mean steadies it in
smooth regions, the pixel's own keeps the larger noise of a pixel on an edge. A pixel agrees when `|S − M| ≤ 3·√(σ_S² + σ_M²) + 1e-5·max(S, M)`
in every channel (the last term is float rounding where both are exact: the light seen directly,
the unlit ceiling, the background at the image border). The exit status is non-zero when a
channel's image mean differs by more than 1 %, or fewer than 99 % of the pixels agree, or the
mean of the signed z-scores `(S − M)/σ` over the noisy pixels, which is 0 ± 1/√n for unbiased
renderers, is outside ±0.15 (a systematic bias smaller than the noise in every pixel).
"""

import argparse
import math
import os
import struct
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np

try:
    import mitsuba as mi
except ImportError:
    sys.exit("mitsuba-compare: python3 cannot import mitsuba (pip install mitsuba, or make test-mitsuba)")

mi.set_variant("scalar_rgb")

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_SCENE = os.path.join(HERE, "mitsuba", "cornell-diffuse.toml")

MEAN_TOLERANCE = 0.01  # relative difference of a channel's image mean
AGREE_FRACTION = 0.99  # pixels within 3 standard errors, at least
MEAN_Z_BOUND = 0.15  # |mean signed z-score| over the noisy pixels, at most


def colour(v):
    """A TOML colour: a number (grey) or [r, g, b]."""
    return [float(v)] * 3 if isinstance(v, (int, float)) else [float(c) for c in v]


def write_ply(path, positions, indices):
    """A binary PLY of float32 vertices and int32 triangles."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {len(positions)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(indices)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        for p in positions:
            f.write(struct.pack("<3f", *p))
        for t in indices:
            f.write(struct.pack("<B3i", 3, *t))


def quad_to_world(corner, edge1, edge2):
    """The to_world taking Mitsuba's rectangle ([-1, 1]² in z = 0, normal +z) onto the
    parallelogram corner + a·edge1 + b·edge2, its normal onto edge1 × edge2."""
    c, e1, e2 = (np.array(v, dtype=np.float64) for v in (corner, edge1, edge2))
    n = np.cross(e1, e2)
    m = np.eye(4)
    m[:3, 0] = e1 / 2
    m[:3, 1] = e2 / 2
    m[:3, 2] = n / np.linalg.norm(n)  # det > 0: the rectangle's normal maps onto +n
    m[:3, 3] = c + (e1 + e2) / 2
    return mi.ScalarTransform4f(mi.ScalarMatrix4f(m))


def disk_to_world(center, normal, radius):
    """The to_world taking Mitsuba's disk (radius 1 in z = 0, normal +z) onto the disk of
    `radius` around `center` perpendicular to `normal`, its normal onto `normal`."""
    n = np.array(normal, dtype=np.float64)
    n /= np.linalg.norm(n)
    t = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    t /= np.linalg.norm(t)
    b = np.cross(n, t)  # t × b = n: det > 0
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = float(radius) * t, float(radius) * b, n
    m[:3, 3] = center
    return mi.ScalarTransform4f(mi.ScalarMatrix4f(m))


def integrator(toml):
    """Mitsuba's `direct` for strahl's Whitted integrator (`[render] integrator = "whitted"`), its
    `path` for strahl's path tracer (the default) with the same bounces: Mitsuba's `max_depth` counts path
    segments (1 shows the emitters only), strahl's scatterings (0 does), so it is strahl's + 1."""
    if toml.get("render", {}).get("integrator", "path") == "path":
        return {"type": "path", "max_depth": int(toml.get("image", {}).get("max_depth", 8)) + 1}
    return {"type": "direct", "emitter_samples": 1, "bsdf_samples": 0}


def mitsuba_scene(toml, size, spp, tmp):
    """The scene dictionary for mi.load_dict; refuses what it does not translate."""
    cam, image = toml["camera"], toml.get("image", {})
    for key, default in (("ambient", 0), ("background", 0)):
        if colour(image.get(key, default)) != [0.0] * 3:
            sys.exit(f"mitsuba-compare: image.{key} must be 0 (Mitsuba's direct integrator has no such term)")
    bsdfs = {}
    for name, mat in toml.get("materials", {}).items():
        if set(mat) != {"diffuse"}:
            sys.exit(f"mitsuba-compare: material {name}: only `diffuse` is translated, not {sorted(mat)}")
        bsdfs[name] = {
            "type": "twosided",
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": colour(mat["diffuse"])}},
        }
    scene = {
        "type": "scene",
        "integrator": integrator(toml),
        "sensor": {
            "type": "perspective",
            "fov": float(cam["fov_deg"]),
            "fov_axis": "y",
            "near_clip": 1e-4,
            "far_clip": 1e4,
            "to_world": mi.ScalarTransform4f.look_at(
                origin=[float(v) for v in cam["eye"]],
                target=[float(v) for v in cam["target"]],
                up=[float(v) for v in cam.get("up", [0, 1, 0])],
            ),
            "film": {
                "type": "hdrfilm",
                "width": size,
                "height": size,
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
                "component_format": "float32",
            },
            "sampler": {"type": "independent", "sample_count": spp},
        },
    }
    for i, obj in enumerate(toml.get("objects", [])):
        if obj.get("type") != "triangles" or set(obj) - {"type", "name", "positions", "indices", "scale", "material"}:
            sys.exit(f"mitsuba-compare: object {i}: only `triangles` with positions, indices, scale, material")
        s = float(obj.get("scale", 1.0))
        positions = [[float(c) * s for c in p] for p in obj["positions"]]
        path = os.path.join(tmp, f"object{i}.ply")
        write_ply(path, positions, obj["indices"])
        scene[f"object{i}"] = {"type": "ply", "filename": path, "face_normals": True, "bsdf": bsdfs[obj["material"]]}
    for i, light in enumerate(toml.get("lights", [])):
        kind = light.get("type")
        if kind not in ("quad", "disk", "sphere") or light.get("two_sided", False):
            sys.exit(f"mitsuba-compare: light {i}: only one-sided quad, disk and sphere lights are translated")
        if kind == "quad":
            shape = {"type": "rectangle", "to_world": quad_to_world(light["corner"], light["edge1"], light["edge2"])}
        elif kind == "disk":
            shape = {"type": "disk", "to_world": disk_to_world(light["center"], light["normal"], light["radius"])}
        else:
            shape = {"type": "sphere", "center": [float(v) for v in light["center"]], "radius": float(light["radius"])}
        scene[f"light{i}"] = shape | {
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": colour(light["radiance"])}},
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
        }
    return scene


def read_exr(path):
    """The RGB channels of an EXR as a float64 array (rows from the top)."""
    return np.array(mi.Bitmap(path), dtype=np.float64)[:, :, :3]


def mean_and_variance(images):
    """Per-pixel mean of independent estimates and the variance of that mean."""
    stack = np.stack(images)
    return stack.mean(axis=0), stack.var(axis=0, ddof=1) / len(images)


def smooth(var):
    """The mean of each pixel's 3×3 neighbourhood (clipped at the image border)."""
    h, w = var.shape[:2]
    padded = np.pad(var, ((1, 1), (1, 1), (0, 0)), constant_values=np.nan)
    windows = [padded[dy : dy + h, dx : dx + w] for dy in range(3) for dx in range(3)]
    return np.nanmean(np.stack(windows), axis=0)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("strahl", help="the strahl binary")
    ap.add_argument("--scene", default=DEFAULT_SCENE)
    ap.add_argument("--size", type=int, default=64, help="image width and height (default 64)")
    ap.add_argument("--spp", type=int, default=256, help="strahl samples per pixel per copy (default 256)")
    ap.add_argument("--copies", type=int, default=4, help="independent strahl renders (default 4)")
    ap.add_argument("--mitsuba-spp", type=int, default=4096, help="Mitsuba samples per pixel in all (default 4096)")
    ap.add_argument("--seeds", type=int, default=8, help="independent Mitsuba renders (default 8)")
    args = ap.parse_args()
    if args.copies < 2 or args.seeds < 2 or args.mitsuba_spp % args.seeds:
        sys.exit("mitsuba-compare: --copies and --seeds at least 2, --mitsuba-spp a multiple of --seeds")
    with open(args.scene, "rb") as f:
        toml = tomllib.load(f)
    n = args.size

    with tempfile.TemporaryDirectory(prefix="strahl-mitsuba-") as tmp:
        t0 = time.monotonic()
        strahl_images = []
        for j in range(args.copies):
            out = os.path.join(tmp, f"strahl{j}.exr")
            cmd = [args.strahl, "render", args.scene, "-o", out, "--spp", str(args.spp),
                   "--width", str(n + 2 * j), "--height", str(n), "--region", f"{j},0,{j + n},{n}",
                   "--passes", "combined", "--exr-layout", "nuke"]
            run = subprocess.run(cmd, capture_output=True, text=True)
            if run.returncode != 0:
                sys.exit(f"mitsuba-compare: {' '.join(cmd)} failed:\n{run.stderr.strip()}")
            strahl_images.append(read_exr(out))
        t_strahl = time.monotonic() - t0

        t0 = time.monotonic()
        per_seed = args.mitsuba_spp // args.seeds
        scene = mi.load_dict(mitsuba_scene(toml, n, per_seed, tmp))
        mitsuba_images = [np.array(mi.render(scene, seed=k, spp=per_seed), dtype=np.float64) for k in range(args.seeds)]
        t_mitsuba = time.monotonic() - t0

    s, var_s = mean_and_variance(strahl_images)
    m, var_m = mean_and_variance(mitsuba_images)
    sigma = np.sqrt(np.maximum(var_s, smooth(var_s)) + np.maximum(var_m, smooth(var_m)))
    diff = s - m
    tolerance = 3 * sigma + 1e-5 * np.maximum(np.abs(s), np.abs(m))
    agree = np.all(np.abs(diff) <= tolerance, axis=2)
    noisy = sigma > 1e-6 * np.maximum(np.abs(s), np.abs(m)) + 1e-12
    z = diff[noisy] / sigma[noisy]
    mean_z = float(z.mean()) if z.size else 0.0

    print(f"scene {args.scene}, {n}×{n} pixels")
    print(f"strahl:  {args.copies} × {args.spp} spp in {t_strahl:.1f} s; "
          f"Mitsuba {mi.__version__} scalar_rgb {integrator(toml)['type']}: {args.seeds} × {per_seed} spp in {t_mitsuba:.1f} s")
    means_s, means_m = s.mean(axis=(0, 1)), m.mean(axis=(0, 1))
    rel = (means_s - means_m) / means_m
    # The standard error of the difference of the two image means (pixels are independent).
    se = np.sqrt((var_s + var_m).sum(axis=(0, 1))) / (n * n) / means_m
    for c, name in enumerate("RGB"):
        print(f"mean radiance {name}: strahl {means_s[c]:.6f}  Mitsuba {means_m[c]:.6f}  "
              f"relative difference {rel[c]:+.4%} (standard error {se[c]:.4%})")
    # The red wall is on the image's left (x large in world space, seen from z < 0 along +z).
    half = n // 2
    red_left = m[:, :half, 0].mean() > m[:, half:, 0].mean() and s[:, :half, 0].mean() > s[:, half:, 0].mean()
    print(f"red wall on the left in both: {red_left}")
    fraction = agree.mean()
    print(f"pixels within 3 standard errors in every channel: {agree.sum()}/{agree.size} = {fraction:.2%}")
    print(f"mean signed z-score over {z.size} noisy pixel channels: {mean_z:+.3f} "
          f"(±{1 / math.sqrt(max(z.size, 1)):.3f} expected); largest |z| {np.abs(z).max() if z.size else 0:.1f}")
    worst = np.argsort(-(np.abs(diff) / np.maximum(tolerance, 1e-30)).max(axis=2), axis=None)[:5]
    for i in worst:
        y, x = divmod(int(i), n)
        print(f"  pixel ({x}, {y}): strahl {np.round(s[y, x], 5)}  Mitsuba {np.round(m[y, x], 5)}  "
              f"σ {np.round(sigma[y, x], 5)}")

    failures = []
    if np.any(np.abs(rel) > MEAN_TOLERANCE):
        failures.append(f"a channel's mean differs by more than {MEAN_TOLERANCE:.0%}")
    if fraction < AGREE_FRACTION:
        failures.append(f"fewer than {AGREE_FRACTION:.0%} of the pixels agree")
    if abs(mean_z) > MEAN_Z_BOUND:
        failures.append(f"the mean z-score is outside ±{MEAN_Z_BOUND} (a systematic difference)")
    if not red_left:
        failures.append("the red wall is not on the left in both images (mirrored?)")
    if failures:
        print("FAIL: " + "; ".join(failures))
        return 1
    print("OK: strahl and Mitsuba 3 agree")
    return 0


if __name__ == "__main__":
    sys.exit(main())
