#!/usr/bin/env python3
"""Records how Mitsuba 3.9.1 (scalar_rgb) reads groove's RGBE / PFM / PLY-attribute test assets
(tests/data/textures/make_hdr_pfm.py), for tests/scene/float_images.rs and
tests/scene/mesh_attribute.rs:

    /work/.venv-mitsuba/bin/python tests/data/textures/mitsuba_float_images.py

writes tests/data/textures/float_images.json: each image's size, channel count and values (top row
first, as mi.Bitmap holds them), and each PLY's attributes (mi.traverse of the loaded shape).
"""
import json
import os

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.dirname(HERE)
out = {"mitsuba": mi.__version__, "images": {}, "ply": {}}
for rel in ["textures/hdr_rle.hdr", "textures/pfm_rgb_be.pfm", "textures/pfm_grey_le.pfm",
            "envmaps/sky_rle.hdr"]:
    b = mi.Bitmap(os.path.join(DATA, rel))
    a = np.array(b, dtype=np.float32)
    out["images"][rel] = {"width": b.width(), "height": b.height(), "channels": b.channel_count(),
                          "values": [float(v) for v in a.reshape(-1)]}
for rel in ["geometry/attr_types.ply", "geometry/attr_grid.ply"]:
    s = mi.load_dict({"type": "ply", "filename": os.path.join(DATA, rel)})
    p = mi.traverse(s)
    out["ply"][rel] = {k: [float(v) for v in p[k]] for k in p.keys()
                       if k.startswith(("vertex_", "face_"))
                       and k not in ("vertex_positions", "vertex_normals", "vertex_texcoords")}
with open(os.path.join(HERE, "float_images.json"), "w") as f:
    json.dump(out, f, indent=1)
print({k: (v["width"], v["height"], v["channels"]) for k, v in out["images"].items()})
print({k: {a: len(b) for a, b in v.items()} for k, v in out["ply"].items()})
