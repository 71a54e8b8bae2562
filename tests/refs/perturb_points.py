#!/usr/bin/env python3
"""Mitsuba 3.9.1 (scalar_rgb) reference points for groove's `mask`, `null` and `bumpmap` and for
the bitmap texture's gradient (`eval_1_grad`), read by tests/bsdf/mitsuba_wrappers.rs.

Run:  /work/.venv-mitsuba/bin/python tests/refs/perturb_points.py > tests/data/perturb_points.json

* checkerboard_eval_1: (u, v, eval_1, eval) -- Mitsuba swaps the colours in eval_1
* grad: bitmap textures (tests/data/textures/*, filters, wraps, to_uv) -> (u, v, d/du, d/dv)
* mask / null: eval, pdf in the identity local frame; sample with fixed (u1, u2)
* bumpmap: a full SurfaceInteraction (geometric normal n, shading frame, dp_du, dp_dv, uv) in
  world space, wi/wo given in the shading frame; eval and pdf of the bump-mapped BSDF
"""
import json
import os

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))
TEX = os.path.normpath(os.path.join(HERE, "..", "data", "textures"))
rng = np.random.default_rng(11)


def f32(x):
    return float(np.float32(x))


def unit_rand():
    v = rng.normal(size=3)
    return [f32(c) for c in v / np.linalg.norm(v)]


def dirs(n, upper=None):
    out = []
    while len(out) < n:
        v = unit_rand()
        if upper is None or (v[2] > 0.05) == upper:
            out.append(v)
    return out


def l3(c):
    return [f32(c[0]), f32(c[1]), f32(c[2])]


# ---------------------------------------------------------------- texture gradients
def grad_cases():
    cases = []
    specs = [
        ("bump_height.png", {}, ""),
        ("bump_height.png", {"wrap_mode": "mirror"}, '<string name="wrap_mode" value="mirror"/>'),
        ("bump_height.png", {"wrap_mode": "clamp"}, '<string name="wrap_mode" value="clamp"/>'),
        ("bump_height.png", {"filter_type": "nearest"}, '<string name="filter_type" value="nearest"/>'),
        ("rgb8.png", {}, ""),
        ("alpha_stripes.png", {"to_uv": mi.ScalarTransform4f().scale([2, 3, 1]).rotate([0, 0, 1], 30)},
         '<transform name="to_uv"><rotate z="1" angle="30"/><scale x="2" y="3"/></transform>'),
    ]
    for fname, extra, xml_extra in specs:
        d = {"type": "bitmap", "filename": os.path.join(TEX, fname), "raw": True}
        d.update(extra)
        t = mi.load_dict(d)
        pts = []
        for _ in range(12):
            uv = [f32(rng.uniform(-1.2, 2.2)), f32(rng.uniform(-1.2, 2.2))]
            si = mi.SurfaceInteraction3f()
            si.uv = mi.Point2f(*uv)
            g = t.eval_1_grad(si)
            pts.append(uv + [f32(g[0]), f32(g[1])])
        xml = (f'<texture type="bitmap"><string name="filename" value="{fname}"/>'
               f'<boolean name="raw" value="true"/>{xml_extra}</texture>')
        cases.append({"xml": xml, "points": pts})
    return cases


# ---------------------------------------------------------------- mask / null
NESTED = {
    "diffuse": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.2, 0.5, 0.8]}},
    "roughconductor": {"type": "roughconductor", "material": "Au", "distribution": "ggx", "alpha": 0.2},
}


def local_si(wi):
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(*wi)
    si.sh_frame = mi.Frame3f(mi.Vector3f(1, 0, 0), mi.Vector3f(0, 1, 0), mi.Vector3f(0, 0, 1))
    si.n = mi.Normal3f(0, 0, 1)
    return si


def mask_cases():
    cases = []
    for nested in ["diffuse", "roughconductor"]:
        for opacity in [0.3, 0.75]:
            b = mi.load_dict({"type": "mask", "opacity": opacity, "nested": NESTED[nested]})
            ctx = mi.BSDFContext()
            pts, spts = [], []
            for wi in dirs(4, upper=True):
                for wo in dirs(4):
                    si = local_si(wi)
                    e = b.eval(ctx, si, mi.Vector3f(*wo))
                    p = b.pdf(ctx, si, mi.Vector3f(*wo))
                    pts.append({"wi": wi, "wo": wo, "eval": l3(e), "pdf": f32(p)})
                for u1 in [0.1, 0.5, 0.9]:
                    u2 = [f32(rng.uniform()), f32(rng.uniform())]
                    si = local_si(wi)
                    bs, w = b.sample(ctx, si, u1, mi.Point2f(*u2))
                    null = bool(mi.has_flag(bs.sampled_type, mi.BSDFFlags.Null))
                    spts.append({"wi": wi, "u1": u1, "wo": l3(bs.wo), "weight": l3(w),
                                 "pdf": f32(bs.pdf), "null": null})
            cases.append({"nested": nested, "opacity": opacity, "points": pts, "samples": spts})
    b = mi.load_dict({"type": "null"})
    si = local_si(dirs(1, upper=True)[0])
    bs, w = b.sample(mi.BSDFContext(), si, 0.5, mi.Point2f(0.5, 0.5))
    null = {"wi": l3(si.wi), "wo": l3(bs.wo), "weight": l3(w), "pdf": f32(bs.pdf),
            "flags_null": bool(mi.has_flag(b.flags(), mi.BSDFFlags.Null)),
            "eval": l3(b.eval(mi.BSDFContext(), si, mi.Vector3f(0, 0, 1)))}
    return cases, null


# ---------------------------------------------------------------- bumpmap
def normalize(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def geometry(kind):
    """(n, sh_n, dp_du, dp_dv) in world space."""
    if kind == "plane":  # a rectangle's: tangents in the surface, shading = geometric normal
        n = normalize([0.2, 0.3, 1.0])
        s = normalize(np.cross([0.0, 1.0, 0.0], n))
        t = np.cross(n, s)
        return n, n, 1.6 * s, 1.2 * t + 0.3 * s
    # a smooth-shaded mesh: shading normal tilted from the geometric one, dp_du off the plane
    n = normalize([-0.3, 0.1, 1.0])
    shn = normalize(n + np.array([0.15, -0.1, 0.0]))
    s = normalize(np.cross([0.0, 1.0, 0.0], n))
    t = np.cross(n, s)
    return n, shn, 0.8 * s, 0.7 * t - 0.2 * s


def bump_cases():
    cases = []
    for geo, nested, scale, flip, shadow, tex_xml_extra, tex_extra in [
        ("plane", "diffuse", 0.05, True, True, "", {}),
        ("plane", "roughconductor", 0.2, True, True, "", {}),
        ("plane", "diffuse", 0.3, False, False, "", {}),
        ("mesh", "roughconductor", 0.1, True, True,
         '<transform name="to_uv"><scale x="2" y="2"/></transform>', {"to_uv": mi.ScalarTransform4f().scale([2, 2, 1])}),
        ("mesh", "diffuse", 0.15, True, False, "", {}),
    ]:
        tex = {"type": "bitmap", "filename": os.path.join(TEX, "bump_height.png"), "raw": True}
        tex.update(tex_extra)
        b = mi.load_dict({"type": "bumpmap", "scale": scale, "flip_invalid_normals": flip,
                          "use_shadowing_function": shadow, "height": tex, "nested": NESTED[nested]})
        n, shn, dpdu, dpdv = geometry(geo)
        frame = mi.Frame3f(mi.Vector3f(*shn))
        # Mitsuba's shading frame: s = dp_du made orthogonal to the shading normal.
        s = normalize(np.array(dpdu) - shn * np.dot(shn, dpdu))
        t = np.cross(shn, s)
        frame = mi.Frame3f(mi.Vector3f(*s), mi.Vector3f(*t), mi.Vector3f(*shn))
        pts = []
        for _ in range(5):
            uv = [f32(rng.uniform(0, 1)), f32(rng.uniform(0, 1))]
            for wi in dirs(2, upper=True) + dirs(1, upper=False):
                for wo in dirs(4):
                    si = mi.SurfaceInteraction3f()
                    si.n = mi.Normal3f(*n)
                    si.sh_frame = frame
                    si.dp_du = mi.Vector3f(*dpdu)
                    si.dp_dv = mi.Vector3f(*dpdv)
                    si.uv = mi.Point2f(*uv)
                    si.wi = mi.Vector3f(*wi)
                    ctx = mi.BSDFContext()
                    e = b.eval(ctx, si, mi.Vector3f(*wo))
                    p = b.pdf(ctx, si, mi.Vector3f(*wo))
                    pts.append({"uv": uv, "wi": wi, "wo": wo, "eval": l3(e), "pdf": f32(p)})
        cases.append({
            "geometry": {"n": l3(n), "s": l3(s), "t": l3(t), "sh_n": l3(shn), "dp_du": l3(dpdu),
                         "dp_dv": l3(dpdv)},
            "nested": nested, "scale": scale, "flip_invalid_normals": flip,
            "use_shadowing_function": shadow,
            "texture_xml": ('<texture type="bitmap"><string name="filename" value="bump_height.png"/>'
                            f'<boolean name="raw" value="true"/>{tex_xml_extra}</texture>'),
            "points": pts})
    return cases


def checker_eval_1():
    """Mitsuba 3.9.1's checkerboard `eval_1` (it swaps color0 and color1 relative to `eval`)."""
    xml = ('<texture type="checkerboard"><rgb name="color0" value="0.9"/><rgb name="color1" value="0.1"/>'
           '<transform name="to_uv"><scale x="4" y="3"/></transform></texture>')
    t = mi.load_dict({"type": "checkerboard", "color0": {"type": "rgb", "value": 0.9},
                      "color1": {"type": "rgb", "value": 0.1},
                      "to_uv": mi.ScalarTransform4f().scale([4, 3, 1])})
    pts = []
    for _ in range(16):
        uv = [f32(rng.uniform(0, 1)), f32(rng.uniform(0, 1))]
        si = mi.SurfaceInteraction3f()
        si.uv = mi.Point2f(*uv)
        pts.append(uv + [f32(t.eval_1(si)), f32(t.eval(si)[0])])
    return {"xml": xml, "points": pts}


def main():
    mask, null = mask_cases()
    out = {"mitsuba": mi.__version__, "variant": "scalar_rgb", "generator": "tests/refs/perturb_points.py",
           "grad": grad_cases(), "mask": mask, "null": null, "bumpmap": bump_cases(),
           "checkerboard_eval_1": checker_eval_1()}
    print(json.dumps(out, indent=None, separators=(",", ":")).replace('},{', '},\n{'))


if __name__ == "__main__":
    main()
