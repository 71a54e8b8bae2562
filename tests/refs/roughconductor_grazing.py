#!/usr/bin/env python3
"""Mitsuba 3.9.1's `roughconductor` at grazing incidence (issue 14's rim doubt).

For GGX and Beckmann, alpha 0.25, eta 0.2, k 3, wi at 80..89.95 degrees: the mean sample weight
with visible-normal sampling and with all-normal sampling (2M samples each, llvm_ad_rgb), and a
quadrature of `eval` over the hemisphere (1500 x 3000 midpoint cells in cos(theta_o), phi_o).
If a sampler dropped energy at grazing angles its mean weight would fall below the integral.
groove's side: tests/bsdf/grazing.rs.

Run:  python3 tests/refs/roughconductor_grazing.py
"""
import numpy as np
import drjit as dr
import mitsuba as mi

mi.set_variant('llvm_ad_rgb')


def first_channel(x):
    a = np.array(x)
    return a[0] if a.shape[0] == 3 else a[:, 0]


def interaction(wi, n):
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*[np.full(n, c, dtype=np.float32) for c in wi])
    si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
    return si


def main():
    ctx = mi.BSDFContext()
    for dist in ['ggx', 'beckmann']:
        desc = {'type': 'roughconductor', 'distribution': dist, 'alpha': 0.25, 'eta': 0.2, 'k': 3.0}
        visible = mi.load_dict(dict(desc, sample_visible=True))
        all_normals = mi.load_dict(dict(desc, sample_visible=False))
        for theta in [80, 85, 87, 88, 89, 89.5, 89.8, 89.95]:
            t = np.radians(theta)
            wi = [np.sin(t), 0.0, np.cos(t)]
            n = 2_000_000
            rng = np.random.default_rng(1)
            si = interaction(wi, n)
            u1 = mi.Float(rng.random(n).astype(np.float32))
            u2 = mi.Point2f(rng.random(n).astype(np.float32), rng.random(n).astype(np.float32))
            means = []
            for b in (visible, all_normals):
                _, w = b.sample(ctx, si, u1, u2)
                w = np.nan_to_num(first_channel(w))
                means.append((w.mean(), w.std() / np.sqrt(n)))
            m = 1500
            c = (np.arange(m) + 0.5) / m
            phi = (np.arange(2 * m) + 0.5) / (2 * m) * 2 * np.pi
            C, P = np.meshgrid(c, phi, indexing='ij')
            S = np.sqrt(1 - C * C)
            wo = [x.ravel().astype(np.float32) for x in (S * np.cos(P), S * np.sin(P), C)]
            e = first_channel(visible.eval(ctx, interaction(wi, wo[0].size), mi.Vector3f(*wo)))
            integral = np.nan_to_num(e).sum() * (1 / m) * (2 * np.pi / (2 * m))
            print(f"{dist} alpha 0.25 theta_i {theta}: E[weight] visible {means[0][0]:.5f} "
                  f"± {means[0][1]:.5f}, all normals {means[1][0]:.5f} ± {means[1][1]:.5f}, "
                  f"integral of eval {integral:.5f}", flush=True)


if __name__ == '__main__':
    main()
