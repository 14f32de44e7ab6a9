#!/usr/bin/env python3
"""The directional albedo of a rough dielectric, three ways, by numerical quadrature (numpy,
float64, written from the papers and the renderers' documented formulas, not from strahl's
code); the reference of tests/cycles.rs's `a_rough_dielectric_sphere_under_a_white_world`.

Under a uniform white world of radiance 1 and with nothing else in view, a convex object's
pixel shows exactly the BRDF's directional albedo E(mu_o) = int f(o, i) mu_i dw_i at that
pixel's viewing cosine. For a glTF dielectric (metallic 0, base colour c, roughness r,
alpha = r^2, GGX D) the models are, with E_x(mu_o) the albedo of the term x:

  strahl      F_schlick(0.04) D G2_corr / (4 mu_o mu_i)  + Kulla-Conty f_ms  (albedo E_s)
              + c/pi (1 - E_s(mu_o)) (1 - E_s(mu_i)) / (1 - avg E_s)   (albedo c (1 - E_s(mu_o)))
              (src/bsdf/gltf.rs, microfacet.rs, lambert.rs)
  cycles      F_dielectric(1.5) D G1(o) G1(i) / (4 mu_o mu_i)       (separable Smith, single
              scattering: Principled BSDF v1 with "GGX", Specular 0.5, as Blender 3.4's glTF
              importer sets it up; the Fresnel of `interpolate_fresnel_color` with cspec0 = F0)
              + c/pi [(1 - FV/2)(1 - FL/2) + RR (FL + FV + FL FV (RR - 1))],
              FV = (1 - mu_o)^5, FL = (1 - mu_i)^5, RR = r (1 + o.i)     (Disney diffuse)
  appendix_b  (1 - F_schlick(o.h)) c/pi + F_schlick D G2_corr / (4 mu_o mu_i)   (glTF 2.0's
              "sample implementation", as written)

Specular terms are integrated over half vectors distributed as D cos(theta_h) (a Gauss-Legendre
rule in the CDF variable u, tan(theta_h) = alpha sqrt(u / (1 - u)), times a periodic rule in
phi): E = int F G2 (o.h) / (mu_o cos theta_h) dP. Diffuse terms over w_i, Gauss-Legendre in
mu_i. The tables also print the single-scattering albedo with F = 1 (the white furnace of
Kulla-Conty's compensation) at mu_o = 1 and its hemispherical average.

    python3 tools/dielectric_albedo.py            # E(mu) tables for roughness 0.1, 0.44, 0.8
    python3 tools/dielectric_albedo.py --bands    # the test's per-band expectations
    python3 tools/dielectric_albedo.py --bands NAME=STRAHL.exr[:PREFIX] NAME=CYCLES.exr ...
                                                  # the same, beside the bands of rendered images

The bands are those of tools/gltf/dielectric_sphere.py's files (64 x 64 pixels): each pixel
is classified by its centre's mu_o and its expected value averaged over 8 x 8 sub-pixel rays.
"""

import functools
import os
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "gltf"))
import dielectric_sphere as scene  # noqa: E402

SIZE = 64
BANDS = [(0.9, 1.0), (0.7, 0.9), (0.5, 0.7), (0.3, 0.5)]
MUS = np.linspace(0.005, 1.0, 200)
F0 = 0.04
IOR = 1.5


def gl(n, a=0.0, b=1.0):
    x, w = np.polynomial.legendre.leggauss(n)
    return a + (b - a) * (x + 1) / 2, w * (b - a) / 2


def schlick(c):
    return F0 + (1 - F0) * (1 - c) ** 5


def fresnel_dielectric(c):
    """Unpolarised Fresnel reflectance from outside at incidence cosine c (Walter et al. 2007)."""
    g = np.sqrt(np.maximum(IOR * IOR - 1 + c * c, 0))
    a = (g - c) / (g + c)
    b = (c * (g + c) - 1) / (c * (g - c) + 1)
    return 0.5 * a * a * (1 + b * b)


def smith_lambda(alpha, mu):
    mu = np.clip(mu, 1e-9, 1)
    return (-1 + np.sqrt(1 + alpha * alpha * (1 - mu * mu) / (mu * mu))) / 2


def specular_albedo(mu_o, roughness, fresnel, correlated=True, nu=300, nphi=192):
    alpha = roughness * roughness
    u, wu = gl(nu)
    phi = (np.arange(nphi) + 0.5) * 2 * np.pi / nphi
    U, P = np.meshgrid(u, phi, indexing="ij")
    tan_t = alpha * np.sqrt(U / (1 - U))
    ct = 1 / np.sqrt(1 + tan_t**2)
    st = tan_t * ct
    h = np.stack([st * np.cos(P), st * np.sin(P), ct], -1)
    o = np.array([np.sqrt(1 - mu_o**2), 0.0, mu_o])
    oh = h @ o
    mu_i = (2 * oh[..., None] * h - o)[..., 2]
    lo, li = smith_lambda(alpha, mu_o), smith_lambda(alpha, mu_i)
    g2 = 1 / (1 + lo + li) if correlated else 1 / ((1 + lo) * (1 + li))
    val = np.where((oh > 0) & (mu_i > 0), fresnel(np.clip(oh, 0, 1)) * g2 * oh / (mu_o * ct), 0)
    return float((val * wu[:, None]).sum() / nphi)


def diffuse_albedo(mu_o, brdf, n=96, nphi=96):
    m, wm = gl(n)
    phi = (np.arange(nphi) + 0.5) * 2 * np.pi / nphi
    M, P = np.meshgrid(m, phi, indexing="ij")
    s = np.sqrt(1 - M * M)
    i = np.stack([s * np.cos(P), s * np.sin(P), M], -1)
    o = np.array([np.sqrt(1 - mu_o**2), 0.0, mu_o])
    return float((brdf(o, i) * M * wm[:, None]).sum() * 2 * np.pi / nphi)


def disney(roughness):
    def f(o, i):
        fv, fl = (1 - o[2]) ** 5, (1 - i[..., 2]) ** 5
        rr = roughness * (i @ o + 1)
        return ((1 - 0.5 * fv) * (1 - 0.5 * fl) + rr * (fl + fv + fl * fv * (rr - 1))) / np.pi

    return f


def appendix_b_diffuse(o, i):
    h = o + i
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    return (1 - schlick(np.clip(h @ o, 0, 1))) / np.pi


@functools.lru_cache
def models(roughness):
    """Per mu in MUS: {model: (specular albedo, diffuse albedo per unit base colour)}."""
    one = np.ones_like
    e1 = np.array([specular_albedo(m, roughness, one) for m in MUS])
    gm, gw = gl(64)
    e1_avg = 2 * np.sum(gw * gm * np.interp(gm, MUS, e1))
    f_avg = F0 + (1 - F0) / 21
    f_ms = f_avg * f_avg * e1_avg / (1 - f_avg * (1 - e1_avg))
    ess = np.array([specular_albedo(m, roughness, schlick) for m in MUS])
    strahl_spec = ess + f_ms * (1 - e1)
    cycles_spec = np.array([specular_albedo(m, roughness, fresnel_dielectric, correlated=False) for m in MUS])
    return {
        "strahl": (strahl_spec, 1 - strahl_spec),
        "cycles": (cycles_spec, np.array([diffuse_albedo(m, disney(roughness)) for m in MUS])),
        "appendix_b": (ess, np.array([diffuse_albedo(m, appendix_b_diffuse) for m in MUS])),
        "_furnace": (e1, e1_avg),
    }


def pixel_mu(sub):
    """mu_o of rays through sub x sub points of each pixel (NaN off the sphere), shape
    (SIZE, SIZE, sub*sub), row 0 at the top."""
    half = np.tan(np.radians(scene.YFOV_DEG) / 2)
    s = (np.arange(SIZE * sub) + 0.5) / (SIZE * sub) * 2 - 1
    X, Y = np.meshgrid(s * half, -s * half)
    d = np.stack([X, Y, -np.ones_like(X)], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    e = np.array([0.0, 0.0, scene.DISTANCE])
    b = d @ e
    disc = b * b - (e @ e - 1)
    t = -b - np.sqrt(np.where(disc > 0, disc, np.nan))
    n = e + t[..., None] * d
    mu = -(n * d).sum(-1)
    return mu.reshape(SIZE, sub, SIZE, sub).transpose(0, 2, 1, 3).reshape(SIZE, SIZE, sub * sub)


def band_masks():
    centre = pixel_mu(1)[..., 0]
    return [(lo, hi, (centre >= lo) & (centre < hi if hi < 1 else centre <= 1)) for lo, hi in BANDS]


def read_exr(path, prefix):
    import Imath
    import OpenEXR

    f = OpenEXR.InputFile(path)
    dw = f.header()["dataWindow"]
    w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
    pt = Imath.PixelType(Imath.PixelType.FLOAT)
    return np.stack([np.frombuffer(f.channel(prefix + c, pt), np.float32).reshape(h, w) for c in "RGB"], -1)


def bands(images):
    mu = pixel_mu(8)
    masks = band_masks()
    for name, (base, roughness) in scene.MATERIALS.items():
        m = models(roughness)
        base = np.array(base)
        print(f"{name}: base colour {base.tolist()}, roughness {roughness}; band means of R, G, B")
        rows = {}
        for model in ("strahl", "cycles", "appendix_b"):
            spec, diff = m[model]
            e = np.interp(mu, MUS, spec)[..., None] + np.interp(mu, MUS, diff)[..., None] * base
            with warnings.catch_warnings():  # pixels off the sphere
                warnings.simplefilter("ignore", RuntimeWarning)
                rows[model] = np.nanmean(e, axis=2)
        for label, spec in images.items():
            if label.startswith(name + "."):
                path, _, prefix = spec.partition(":")
                rows["[" + label.split(".", 1)[1] + "]"] = read_exr(path, prefix)
        for lo, hi, mask in masks:
            cells = "  ".join(f"{k} {' '.join(f'{v:.5f}' for v in img[mask].mean(0))}" for k, img in rows.items())
            print(f"  mu [{lo}, {hi}] ({mask.sum()} px): {cells}")


def tables():
    for roughness in (0.1, 0.44, 0.8):
        m = models(roughness)
        e1, e1_avg = m["_furnace"]
        print(f"roughness {roughness}: single-scattering E (F = 1) at mu 1: {e1[-1]:.4f}, average {e1_avg:.4f}")
        print("   mu   strahl spec  cycles spec  appB spec   strahl diff  cycles diff  appB diff")
        for target in (1.0, 0.8, 0.6, 0.4, 0.2, 0.1):
            k = int(np.argmin(abs(MUS - target)))
            vals = [m[x][0][k] for x in ("strahl", "cycles", "appendix_b")]
            vals += [m[x][1][k] for x in ("strahl", "cycles", "appendix_b")]
            print(f"  {MUS[k]:.2f}  " + "  ".join(f"{v:10.4f}" for v in vals))


if __name__ == "__main__":
    args = sys.argv[1:]
    if args and args[0] == "--bands":
        bands(dict(a.split("=", 1) for a in args[1:]))
    else:
        tables()
