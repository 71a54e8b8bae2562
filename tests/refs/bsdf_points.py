#!/usr/bin/env python3
"""Reference values of Mitsuba 3 (scalar_rgb) BSDFs for groove's pointwise unit tests.

Run:  /work/.venv-mitsuba/bin/python tests/refs/bsdf_points.py > tests/data/mitsuba_bsdf_points.json

For every model and parameter set it evaluates Mitsuba's `eval` and `pdf` on fixed (wi, wo) pairs
(directions rounded to f32 first, so both renderers see identical inputs), and for the delta models
it calls `sample` with fixed random numbers. The local frame is the identity (s = x, t = y, n = z).
`bsdf_points.py conductors` prints the RGB (eta, k) Mitsuba uses for named conductors
(src/bsdf/ior.rs); `bsdf_points.py defaults` the values of `defaults_match_mitsuba`.
The test reading the file: tests/bsdf_mitsuba/models.rs (module `models` of the test crate
bsdf_mitsuba_wrappers); it checks the point counts, so a changed point set updates them there.
"""
import sys
import numpy as np
import mitsuba as mi

mi.set_variant('scalar_rgb')
rng = np.random.default_rng(7)

def f32(x):
    return float(np.float32(x))

def lit(x):
    """The shortest decimal that round-trips through f32 (a valid JSON number and Rust literal)."""
    v = np.float32(x)
    if not np.isfinite(v):
        raise ValueError('non-finite reference value %r has no JSON form' % x)
    s = str(v)
    if 'e' not in s and '.' not in s:
        s += '.0'
    return s

def jbool(b):
    return 'true' if b else 'false'

def vec(v):
    return '[' + ', '.join(lit(c) for c in v) + ']'

def unit(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    v = np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])
    return [f32(c) for c in v]

def make_si(wi):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*wi)
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    return si

def ctx_of(mode):
    ctx = mi.BSDFContext()
    ctx.mode = mi.TransportMode.Radiance if mode == 0 else mi.TransportMode.Importance
    return ctx

# Incident directions: normal, moderate, oblique, grazing; outgoing: a fixed random set over the
# sphere plus the specular directions (where the rough lobes peak).
WI_UP = [unit(0.0, 0.0), unit(30.0, 20.0), unit(60.0, 200.0), unit(85.0, 75.0)]
WI_DOWN = [[w[0], w[1], -w[2]] for w in [unit(25.0, 40.0), unit(70.0, 300.0)]]

def wo_set(wi, n=6):
    out = []
    for _ in range(n):
        v = rng.normal(size=3)
        v /= np.linalg.norm(v)
        out.append([f32(c) for c in v])
    # near-specular reflection and a direction near the refracted one
    r = np.array([-wi[0], -wi[1], wi[2]])
    r = r + 0.05 * rng.normal(size=3)
    r /= np.linalg.norm(r)
    out.append([f32(c) for c in r])
    t = np.array([-wi[0] / 1.5, -wi[1] / 1.5, 0.0])
    t[2] = -np.sign(wi[2]) * np.sqrt(max(0.0, 1 - t[0] ** 2 - t[1] ** 2))
    t = t + 0.05 * rng.normal(size=3)
    t /= np.linalg.norm(t)
    out.append([f32(c) for c in t])
    return out

rows = []
srows = []

def eval_rows(model, desc, key, wis, modes=(0,)):
    b = mi.load_dict(desc)
    for wi in wis:
        for wo in wo_set(wi):
            for mode in modes:
                si = make_si(wi)
                ctx = ctx_of(mode)
                e = b.eval(ctx, si, mi.Vector3f(*wo))
                p = b.pdf(ctx, si, mi.Vector3f(*wo))
                rows.append((model, key, mode, wi, wo, [e[0], e[1], e[2]], float(p)))

def sample_rows(model, desc, key, wis, us, modes=(0,)):
    b = mi.load_dict(desc)
    for wi in wis:
        for (u1, u2) in us:
            for mode in modes:
                si = make_si(wi)
                ctx = ctx_of(mode)
                bs, w = b.sample(ctx, si, f32(u1), mi.Point2f(f32(u2[0]), f32(u2[1])))
                delta = bool(mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta))
                srows.append((model, key, mode, wi, f32(u1), [f32(u2[0]), f32(u2[1])],
                              [bs.wo[0], bs.wo[1], bs.wo[2]], [w[0], w[1], w[2]], float(bs.pdf),
                              float(bs.eta), delta))

def key_str(dist=0, au=0.0, av=0.0, sv=True, mat='', int_ior=0.0, ext_ior=0.0,
            refl=(0.0, 0.0, 0.0), nonlinear=False):
    return (dist, au, av, sv, mat, int_ior, ext_ior, refl, nonlinear)

US = [(0.01, (0.3, 0.7)), (0.5, (0.2, 0.4)), (0.99, (0.8, 0.1)), (0.2, (0.55, 0.95))]

def build():
    dists = [(0, 'beckmann'), (1, 'ggx')]
    # roughconductor
    for di, dn in dists:
        for (au, av) in [(0.05, 0.05), (0.2, 0.2), (0.6, 0.6), (0.1, 0.4)]:
            for sv in [True, False]:
                for mat in ['Au', 'none', 'Cr']:
                    if mat != 'Au' and (au, sv) != (0.2, True):
                        continue
                    desc = {'type': 'roughconductor', 'distribution': dn, 'alpha_u': au,
                            'alpha_v': av, 'sample_visible': sv, 'material': mat}
                    eval_rows('roughconductor', desc, key_str(di, au, av, sv, mat), WI_UP)
    # roughdielectric (both sides, both modes, an index below 1 too)
    for di, dn in dists:
        for (au, av) in [(0.05, 0.05), (0.2, 0.2), (0.6, 0.6), (0.1, 0.4)]:
            for sv in [True, False]:
                for (ii, ei) in [(1.5046, 1.000277), (1.0, 1.33)]:
                    if (ii, ei) != (1.5046, 1.000277) and au != 0.2:
                        continue
                    desc = {'type': 'roughdielectric', 'distribution': dn, 'alpha_u': au,
                            'alpha_v': av, 'sample_visible': sv, 'int_ior': ii, 'ext_ior': ei}
                    eval_rows('roughdielectric', desc, key_str(di, au, av, sv, '', ii, ei),
                              WI_UP + WI_DOWN, modes=(0, 1))
    # roughplastic
    for di, dn in dists:
        for a in [0.05, 0.2, 0.6]:
            for sv in [True, False]:
                for nl in [False, True]:
                    refl = (0.2, 0.5, 0.8)
                    desc = {'type': 'roughplastic', 'distribution': dn, 'alpha': a,
                            'sample_visible': sv, 'nonlinear': nl,
                            'diffuse_reflectance': {'type': 'rgb', 'value': list(refl)}}
                    eval_rows('roughplastic', desc, key_str(di, a, a, sv, '', 1.49, 1.000277, refl, nl),
                              WI_UP)
    # plastic
    for nl in [False, True]:
        for (ii, refl) in [(1.49, (0.2, 0.5, 0.8)), (1.9, (0.9, 0.1, 0.4))]:
            desc = {'type': 'plastic', 'nonlinear': nl, 'int_ior': ii,
                    'diffuse_reflectance': {'type': 'rgb', 'value': list(refl)}}
            k = key_str(0, 0, 0, True, '', ii, 1.000277, refl, nl)
            eval_rows('plastic', desc, k, WI_UP)
            sample_rows('plastic', desc, k, WI_UP, US)
    # delta models
    for mat in ['none', 'Au', 'Ag', 'Cu', 'Al', 'Cr']:
        desc = {'type': 'conductor', 'material': mat}
        sample_rows('conductor', desc, key_str(mat=mat), WI_UP, US[:1])
    for (ii, ei) in [(1.5046, 1.000277), (1.0, 1.33), (2.419, 1.0)]:
        for model in ['dielectric', 'thindielectric']:
            desc = {'type': model, 'int_ior': ii, 'ext_ior': ei}
            sample_rows(model, desc, key_str(int_ior=ii, ext_ior=ei), WI_UP + WI_DOWN, US, modes=(0, 1))

def emit():
    """Writes tests/data/mitsuba_bsdf_points.json: the parameter sets ("keys"), one `eval`/`pdf`
    row per line ("eval") and one `sample` row per line ("sample"), each a JSON array in the order
    its "..._columns" list names. Numbers are the shortest strings that round-trip through f32."""
    out = sys.stdout
    keys = []
    index = {}
    for r in rows + srows:
        if r[1] not in index:
            index[r[1]] = len(keys)
            keys.append(r[1])
    def key(k):
        dist, au, av, sv, mat, ii, ei, refl, nl = k
        return ('{"dist": %d, "alpha_u": %s, "alpha_v": %s, "sample_visible": %s, "material": "%s", '
                '"int_ior": %s, "ext_ior": %s, "reflectance": %s, "nonlinear": %s}') % (
            dist, lit(au), lit(av), jbool(sv), mat, lit(ii), lit(ei), vec(refl), jbool(nl))
    def body(lines):
        return ',\n'.join('    ' + l for l in lines) + '\n'
    out.write('{\n')
    out.write('  "generator": "tests/refs/bsdf_points.py",\n')
    out.write('  "mitsuba": "%s",\n' % mi.__version__)
    out.write('  "variant": "scalar_rgb",\n')
    out.write('  "keys": [\n' + body([key(k) for k in keys]) + '  ],\n')
    out.write('  "eval_columns": ["model", "key", "mode", "wi", "wo", "eval", "pdf"],\n')
    out.write('  "eval": [\n' + body(['["%s", %d, %d, %s, %s, %s, %s]' % (
        model, index[k], mode, vec(wi), vec(wo), vec(e), lit(p))
        for (model, k, mode, wi, wo, e, p) in rows]) + '  ],\n')
    out.write('  "sample_columns": ["model", "key", "mode", "wi", "u1", "u2", "wo", "weight", "pdf", '
              '"eta", "delta"],\n')
    out.write('  "sample": [\n' + body(['["%s", %d, %d, %s, %s, %s, %s, %s, %s, %s, %s]' % (
        model, index[k], mode, vec(wi), lit(u1), vec(u2), vec(wo), vec(w), lit(p), lit(eta),
        jbool(delta)) for (model, k, mode, wi, u1, u2, wo, w, p, eta, delta) in srows]) + '  ]\n')
    out.write('}\n')


def defaults():
    """eval/pdf of each model with Mitsuba's default parameters (test `defaults_match_mitsuba`)."""
    wi = [f32(0.3), f32(0.2), f32(np.sqrt(1 - 0.13))]
    si = make_si(wi)
    for wo in [[-0.25, -0.2, np.sqrt(1 - 0.1025)], [-0.2, -0.1, -np.sqrt(1 - 0.05)]]:
        wo = [f32(c) for c in wo]
        for t in ['plastic', 'roughplastic', 'roughconductor', 'roughdielectric', 'diffuse']:
            b = mi.load_dict({'type': t})
            e = b.eval(mi.BSDFContext(), si, mi.Vector3f(*wo))
            p = b.pdf(mi.BSDFContext(), si, mi.Vector3f(*wo))
            print('("%s", %s, %s, %s, %s),' % (t, vec(wi), vec(wo), lit(e[0]), lit(p)))


def conductors():
    for m in ['Au', 'Ag', 'Cu', 'Al', 'Cr']:
        p = mi.traverse(mi.load_dict({'type': 'conductor', 'material': m}))
        print(m, list(p['eta.value']), list(p['k.value']))

if __name__ == '__main__':
    if len(sys.argv) > 1 and sys.argv[1] == 'conductors':
        conductors()
    elif len(sys.argv) > 1 and sys.argv[1] == 'defaults':
        defaults()
    else:
        build()
        emit()
