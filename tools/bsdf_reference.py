#!/usr/bin/env python3
"""Independent reference values of glTF 2.0's Appendix B BRDF, for src/bsdf/tests.rs.

Evaluates the specification's formulas with numpy in float64 (written from the
specification's text, not from strahl's code), and again with the GGX distribution D and
Smith's G1 taken from Mitsuba 3 (`mi.MicrofacetDistribution`, an independent implementation),
combined into the height-correlated G2 = 1/(1/G1(o) + 1/G1(i) - 1). Prints the values and the
largest relative difference between the two; the test `appendix_b_matches_independent_reference`
holds the printed table.

    python3 tools/bsdf_reference.py          # needs numpy; Mitsuba (pip install mitsuba) optional
"""
import numpy as np

CASES = [
    # (base_color, metallic, roughness, wo, wi)
    ((1.0, 0.766, 0.336), 1.0, 0.3, (0.3, 0.1, 0.9), (-0.5, 0.2, 0.6)),
    ((1.0, 0.766, 0.336), 1.0, 0.8, (0.7, 0.0, 0.3), (-0.6, -0.3, 0.4)),
    ((0.8, 0.1, 0.1), 0.0, 0.5, (0.0, 0.0, 1.0), (0.4, 0.4, 0.8)),
    ((0.8, 0.1, 0.1), 0.0, 0.1, (0.6, 0.0, 0.8), (-0.6, 0.02, 0.8)),
    ((0.2, 0.9, 0.4), 0.5, 0.6, (0.9, 0.1, 0.2), (-0.3, -0.8, 0.5)),
    ((0.5, 0.5, 0.5), 0.2, 1.0, (0.1, 0.9, 0.3), (0.2, -0.2, 0.95)),
]


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def appendix_b(base, metallic, roughness, v, l, d_fn=None, g1_fn=None):
    base = np.asarray(base, dtype=np.float64)
    n = np.array([0.0, 0.0, 1.0])
    v, l = unit(v), unit(l)
    h = unit(v + l)
    a = roughness * roughness
    nv, nl, nh, vh = n @ v, n @ l, n @ h, v @ h
    if d_fn is None:
        d = a * a / (np.pi * (nh * nh * (a * a - 1) + 1) ** 2)
        vis = 1.0 / (2.0 * (nv * np.sqrt(a * a + (1 - a * a) * nl * nl) + nl * np.sqrt(a * a + (1 - a * a) * nv * nv)))
    else:
        d = d_fn(a, h)
        g2 = 1.0 / (1.0 / g1_fn(a, v, h) + 1.0 / g1_fn(a, l, h) - 1.0)
        vis = g2 / (4.0 * nv * nl)
    c_diff = base * (1 - metallic)
    f0 = 0.04 * (1 - metallic) + base * metallic
    f = f0 + (1 - f0) * (1 - abs(vh)) ** 5
    return (1 - f) * c_diff / np.pi + f * d * vis


def mitsuba_fns():
    try:
        import mitsuba as mi
    except ImportError:
        return None
    mi.set_variant("scalar_rgb")

    def d_fn(a, h):
        return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, a).eval(mi.Vector3f(*h))

    def g1_fn(a, w, h):
        return mi.MicrofacetDistribution(mi.MicrofacetType.GGX, a).smith_g1(mi.Vector3f(*w), mi.Vector3f(*h))

    return d_fn, g1_fn


def main():
    fns = mitsuba_fns()
    worst = 0.0
    for base, m, r, wo, wi in CASES:
        f = appendix_b(base, m, r, wo, wi)
        line = f"(({base[0]}, {base[1]}, {base[2]}), {m}, {r}, {wo}, {wi}, [{f[0]:.7e}, {f[1]:.7e}, {f[2]:.7e}]),"
        if fns is not None:
            g = appendix_b(base, m, r, wo, wi, *fns)
            rel = float(np.max(np.abs(g - f) / np.abs(f)))
            worst = max(worst, rel)
            line += f"  // Mitsuba D, G1: rel. diff. {rel:.1e}"
        print(line)
    if fns is None:
        print("mitsuba not installed: numpy values only")
    else:
        print(f"largest relative difference numpy vs Mitsuba's D and G1: {worst:.2e}")


if __name__ == "__main__":
    main()
