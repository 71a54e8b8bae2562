#!/usr/bin/env python3
"""Reference values of Mitsuba 3.9.1 (scalar_rgb) `principled` and `principledthin` for groove's
pointwise test (tests/bsdf/principled_points.rs).

Run:  /work/.venv-mitsuba/bin/python tests/refs/principled_points.py > tests/data/principled_points.json

For each parameter set (given once, as XML for groove's loader and as the equivalent Mitsuba
dict) it evaluates Mitsuba's `eval` and `pdf` in both transport modes on fixed (wi, wo) pairs:
incident directions on both sides, outgoing directions drawn over the sphere plus ones near the
mirror, refracted and straight-through directions. Directions are rounded to f32 first so both
renderers see identical inputs; the local frame is the identity. Textured sets are evaluated at
several uv positions.
"""
import json
import sys
import numpy as np
import mitsuba as mi

mi.set_variant('scalar_rgb')
rng = np.random.default_rng(14)


def f32(x):
    return float(np.float32(x))


def unit(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return [f32(c) for c in (np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))]


def normalized(v):
    v = np.asarray(v, dtype=float)
    return [f32(c) for c in v / np.linalg.norm(v)]


WI = [unit(0.0, 0.0), unit(30.0, 20.0), unit(60.0, 200.0), unit(85.0, 75.0),
      unit(155.0, 40.0), unit(110.0, 300.0)]


def wo_set(wi, eta, n=8):
    out = [normalized(rng.normal(size=3)) for _ in range(n)]
    wi = np.array(wi)
    refl = np.array([-wi[0], -wi[1], wi[2]])
    out.append(normalized(refl + 0.05 * rng.normal(size=3)))
    out.append(normalized(refl + 0.15 * rng.normal(size=3)))
    # near the refracted direction (entering or leaving)
    e = eta if wi[2] > 0 else 1.0 / eta
    t = np.array([-wi[0] / e, -wi[1] / e, 0.0])
    s2 = t[0] ** 2 + t[1] ** 2
    if s2 < 1.0:
        t[2] = -np.sign(wi[2]) * np.sqrt(1.0 - s2)
        out.append(normalized(t + 0.05 * rng.normal(size=3)))
    # near straight through (the thin sheet's transmission)
    out.append(normalized(-wi + 0.08 * rng.normal(size=3)))
    return out


def xml_value(name, v):
    if isinstance(v, dict):
        return v['xml'].replace('NAME', name)
    if isinstance(v, list):
        return '<rgb name="%s" value="%s"/>' % (name, ', '.join(repr(float(c)) for c in v))
    return '<float name="%s" value="%r"/>' % (name, float(v))


def mi_value(v):
    if isinstance(v, dict):
        return v['mi']
    if isinstance(v, list):
        return {'type': 'rgb', 'value': v}
    return float(v)


def checker(c0, c1, scalar):
    tag = 'float' if scalar else 'rgb'
    fmt = (lambda c: repr(float(c))) if scalar else (lambda c: ', '.join(repr(float(x)) for x in c))
    xml = ('<texture type="checkerboard" name="NAME"><%s name="color0" value="%s"/>'
           '<%s name="color1" value="%s"/></texture>') % (tag, fmt(c0), tag, fmt(c1))
    if scalar:
        m = {'type': 'checkerboard', 'color0': float(c0), 'color1': float(c1)}
    else:
        m = {'type': 'checkerboard', 'color0': {'type': 'rgb', 'value': c0},
             'color1': {'type': 'rgb', 'value': c1}}
    return {'xml': xml, 'mi': m}


PRINCIPLED = [
    {},
    {'base_color': [0.8, 0.3, 0.1], 'metallic': 0.7, 'specular': 0.6, 'roughness': 0.3,
     'spec_tint': 0.4, 'anisotropic': 0.5, 'sheen': 0.3, 'sheen_tint': 0.2, 'clearcoat': 0.6,
     'clearcoat_gloss': 0.3, 'spec_trans': 0.4},
    {'spec_trans': 1.0, 'eta': 1.33, 'roughness': 0.2, 'base_color': [0.9, 0.95, 1.0]},
    {'clearcoat': 1.0, 'clearcoat_gloss': 0.9, 'roughness': 0.6, 'base_color': [0.2, 0.5, 0.8],
     'flatness': 0.5},
    {'metallic': 1.0, 'anisotropic': 0.8, 'roughness': 0.4, 'base_color': [0.9, 0.6, 0.3]},
    {'sheen': 1.0, 'sheen_tint': 0.7, 'roughness': 0.9, 'base_color': [0.3, 0.6, 0.2],
     'main_specular_sampling_rate': 0.5, 'diffuse_reflectance_sampling_rate': 2.0,
     'clearcoat': 0.3, 'clearcoat_sampling_rate': 3.0, 'spec_tint': 1.0},
    {'spec_trans': 0.5, 'eta': 1.0, 'metallic': 0.2, 'roughness': 0.5},
    {'spec_trans': 0.7, 'eta': 0.8, 'roughness': 0.35, 'sheen': 0.5},
    {'spec_trans': 0.0, 'metallic': 0.0, 'specular': 0.2, 'roughness': 0.1},
    {'base_color': checker([0.9, 0.2, 0.1], [0.1, 0.4, 0.9], False),
     'roughness': checker(0.15, 0.7, True), 'metallic': checker(0.0, 0.8, True),
     'spec_trans': checker(0.3, 0.0, True), 'clearcoat': 0.5},
]

THIN = [
    {},
    {'spec_trans': 0.6, 'diff_trans': 0.8, 'eta': 1.4, 'roughness': 0.3, 'spec_tint': 0.5,
     'base_color': [0.7, 0.4, 0.2], 'sheen': 0.5, 'sheen_tint': 0.5, 'flatness': 0.4,
     'anisotropic': 0.3},
    {'spec_trans': 1.0, 'eta': 1.5, 'roughness': 0.15},
    {'diff_trans': 2.0, 'base_color': [0.3, 0.8, 0.5]},
    {'diff_trans': 1.0, 'spec_trans': 0.3, 'roughness': 0.7, 'eta': 1.2,
     'specular_reflectance_sampling_rate': 2.0, 'specular_transmittance_sampling_rate': 0.5,
     'diffuse_reflectance_sampling_rate': 0.7, 'diffuse_transmittance_sampling_rate': 1.5},
    {'base_color': checker([0.9, 0.2, 0.1], [0.1, 0.4, 0.9], False),
     'eta': checker(1.3, 1.6, True), 'spec_trans': checker(0.5, 0.9, True),
     'diff_trans': checker(0.4, 1.2, True), 'roughness': 0.4},
]

UVS_PLAIN = [[0.25, 0.25]]
UVS_TEX = [[0.25, 0.25], [0.75, 0.25], [0.3, 0.8], [0.8, 0.7]]


def cases(model, sets):
    out = []
    for params in sets:
        d = {'type': model}
        for k, v in params.items():
            d[k] = mi_value(v)
        b = mi.load_dict(d)
        textured = any(isinstance(v, dict) for v in params.values())
        eta = params.get('eta', 1.5)
        if not isinstance(eta, (int, float)):
            eta = 1.5
        points = []
        for uv in (UVS_TEX if textured else UVS_PLAIN):
            for wi in WI:
                for wo in wo_set(wi, eta):
                    for mode in (0, 1):
                        si = mi.SurfaceInteraction3f()
                        si.wi = mi.Vector3f(*wi)
                        si.uv = mi.Point2f(*uv)
                        si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0),
                                                 mi.Vector3f(0, 0, 1))
                        ctx = mi.BSDFContext()
                        ctx.mode = (mi.TransportMode.Radiance if mode == 0
                                    else mi.TransportMode.Importance)
                        e = b.eval(ctx, si, mi.Vector3f(*wo))
                        p = b.pdf(ctx, si, mi.Vector3f(*wo))
                        points.append({'mode': mode, 'uv': uv, 'wi': wi, 'wo': wo,
                                       'eval': [float(e[0]), float(e[1]), float(e[2])],
                                       'pdf': float(p)})
        xml = '<bsdf type="%s">%s</bsdf>' % (
            model, ''.join(xml_value(k, v) for k, v in params.items()))
        out.append({'xml': xml, 'points': points})
    return out


json.dump({'mitsuba': mi.__version__, 'variant': 'scalar_rgb',
           'principled': cases('principled', PRINCIPLED),
           'principledthin': cases('principledthin', THIN)},
          sys.stdout, indent=None, separators=(',', ':'))
sys.stdout.write('\n')
