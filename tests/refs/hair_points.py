#!/usr/bin/env python3
"""Reference values of Mitsuba 3.9.1's `hair` BSDF (scalar_rgb) for groove's pointwise test.

Run:  /work/.venv-mitsuba/bin/python tests/refs/hair_points.py > tests/data/mitsuba_hair_points.json

For a few parameter sets it evaluates Mitsuba's `eval` and `pdf` on fixed (wi, wo) pairs over
the whole sphere (directions rounded to f32 first, so both renderers see identical inputs). The
local frame is the identity (s = x, t = y along the fiber, n = z). Read by tests/bsdf/hair.rs.
"""
import json
import numpy as np
import mitsuba as mi

mi.set_variant('scalar_rgb')
rng = np.random.default_rng(11)

PARAMS = [
    {},
    {'eumelanin': 0.2, 'pheomelanin': 0.4, 'longitudinal_roughness': 0.15,
     'azimuthal_roughness': 0.6, 'scale_tilt': 4.0},
    {'sigma_a': [0.06, 0.1, 0.3], 'scale': 2.0, 'int_ior': 1.45,
     'longitudinal_roughness': 0.5, 'azimuthal_roughness': 0.2},
    {'eumelanin': 0.0, 'pheomelanin': 0.0, 'longitudinal_roughness': 0.05, 'scale_tilt': 0.0},
]


def f32v(v):
    return [float(np.float32(c)) for c in v]


def rand_dir(upper):
    while True:
        v = rng.normal(size=3)
        v /= np.linalg.norm(v)
        if not upper or v[2] > 0.05:
            return f32v(v)


def main():
    out = []
    for params in PARAMS:
        d = {'type': 'hair'}
        for k, v in params.items():
            d[k] = {'type': 'rgb', 'value': v} if k == 'sigma_a' else v
        bsdf = mi.load_dict(d)
        ctx = mi.BSDFContext()
        for _ in range(8):
            wi = rand_dir(True)
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(*wi)
            si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
            for _ in range(6):
                wo = rand_dir(False)
                e = bsdf.eval(ctx, si, mi.Vector3f(*wo))
                p = bsdf.pdf(ctx, si, mi.Vector3f(*wo))
                out.append({'params': params, 'wi': wi, 'wo': wo,
                            'eval': [float(e[0]), float(e[1]), float(e[2])], 'pdf': float(p)})
    print(json.dumps({'generator': 'tests/refs/hair_points.py', 'mitsuba': mi.__version__,
                      'variant': 'scalar_rgb', 'points': out}, indent=1))


main()
