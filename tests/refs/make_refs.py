#!/usr/bin/env python3
"""Render the Mitsuba 3 reference images used by groove's statistical acceptance tests.

Run from anywhere with the Mitsuba venv's python:

    /work/.venv-mitsuba/bin/python tests/refs/make_refs.py [--threads 2] [--only NAME ...]
        [--spp-scale F] [--out DIR]

For every job below the scene is loaded once (Mitsuba 3.9.1, variant scalar_rgb) and rendered K
times with mi.render(scene, spp=SPP, seed=s) for the listed seeds. Written per job, float32 RGB:

    NAME.exr      per-pixel mean of the K renders
    NAME.var.exr  per-pixel variance OF THE MEAN: unbiased sample variance across the K seeds / K

All test scenes use the box reconstruction filter, so pixels are independent estimates (the
statistics in tests/common/imgcmp.rs rely on that). A summary (timings, noise levels) is printed
and written to refs.json next to the images.
"""
import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
SCENES = os.path.join(REPO, "tests", "data", "scenes")
CBOX = os.path.normpath(os.path.join(REPO, "..", "shared", "scenes", "mitsuba_cbox", "cbox-rgb.xml"))
CBOX_VALUES = os.path.join(os.path.dirname(CBOX), "cbox.xml")  # wavelength:value spectra, gaussian filter
CBOX_SPECTRAL = os.path.join(os.path.dirname(CBOX), "cbox-spectral.xml")  # includes, box filter

REF_SEEDS = [0, 1, 2, 3]

# name, scene file, -D defines, spp per seed, seeds
JOBS = [
    ("furnace_sphere", os.path.join(SCENES, "furnace_sphere.xml"), {}, 4096, REF_SEEDS),
    ("depth_sphere_d1", os.path.join(SCENES, "depth_sphere.xml"), {"max_depth": "1"}, 2048, REF_SEEDS),
    ("depth_sphere_d2", os.path.join(SCENES, "depth_sphere.xml"), {"max_depth": "2"}, 4096, REF_SEEDS),
    ("depth_sphere_d3", os.path.join(SCENES, "depth_sphere.xml"), {"max_depth": "3"}, 4096, REF_SEEDS),
    ("mis_quad", os.path.join(SCENES, "mis_quad.xml"), {}, 2048, REF_SEEDS),
    ("mis_quad_nopoint", os.path.join(SCENES, "mis_quad.xml"), {"point": "0"}, 2048, REF_SEEDS),
    ("cbox_v3", os.path.join(SCENES, "cbox_v3.xml"), {}, 1024, REF_SEEDS),
    ("area_point", os.path.join(SCENES, "area_point.xml"), {}, 1024, REF_SEEDS),
    # Bitmap textures (bilinear + nearest/mirror/to_uv) under a constant environment.
    ("textured_quad", os.path.join(SCENES, "textured_quad.xml"), {}, 4096, REF_SEEDS),
    # The shared Cornell box (meshes, includes, referenced emitter), unchanged, at 64x64.
    ("cbox", CBOX, {"res": "64"}, 2048, REF_SEEDS),
    # An independent, cheaper render of the same scene (other seeds) for the harness self-check.
    ("cbox.check", CBOX, {"res": "64"}, 256, [100, 101, 102, 103]),
    # Emitters: spot + directional; envmap only; dim envmap + small bright area light.
    ("light_spot_dir", os.path.join(SCENES, "light_spot_dir.xml"), {}, 4096, REF_SEEDS),
    ("light_envmap", os.path.join(SCENES, "light_envmap.xml"), {}, 4096, REF_SEEDS),
    ("light_envmap_area", os.path.join(SCENES, "light_envmap_area.xml"), {}, 4096, REF_SEEDS),
    # Materials (BSDF families) under an area light + dim constant environment.
    ("mat_roughconductor_ggx", os.path.join(SCENES, "mat_roughconductor.xml"),
     {"distribution": "ggx"}, 4096, REF_SEEDS),
    ("mat_roughconductor_beckmann", os.path.join(SCENES, "mat_roughconductor.xml"),
     {"distribution": "beckmann"}, 4096, REF_SEEDS),
    ("mat_metals", os.path.join(SCENES, "mat_metals.xml"), {}, 4096, REF_SEEDS),
    ("mat_roughglass", os.path.join(SCENES, "mat_roughglass.xml"), {}, 4096, REF_SEEDS),
    ("mat_glass", os.path.join(SCENES, "mat_glass.xml"), {}, 4096, REF_SEEDS),
    ("mat_plastic", os.path.join(SCENES, "mat_plastic.xml"), {}, 4096, REF_SEEDS),
    ("mat_plastic_nl", os.path.join(SCENES, "mat_plastic.xml"), {"nonlinear": "true"}, 4096, REF_SEEDS),
    # The shared Cornell boxes, unchanged: wavelength:value spectra (gaussian filter, so also tile
    # statistics from 16 seeds, see TILE_STATS) and the include-based spectral variant (box filter).
    ("cbox_values", CBOX_VALUES, {"res": "64"}, 512, list(range(16))),
    ("cbox_spectral", CBOX_SPECTRAL, {"res": "64"}, 2048, REF_SEEDS),
    # Classic normalmap (3.9.1 defaults: flip + shadowing term) and the plain model (both off).
    ("nmap_plane", os.path.join(SCENES, "nmap_plane.xml"), {}, 2048, REF_SEEDS),
    ("nmap_plane_plain", os.path.join(SCENES, "nmap_plane.xml"),
     {"flip": "false", "shadow": "false"}, 2048, REF_SEEDS),
    # mask (checkerboard and constant opacity) and null; bumpmap (bitmap height); textured
    # roughness (roughconductor alpha, roughdielectric alpha_u); a bitmap-textured area light.
    ("mat_mask", os.path.join(SCENES, "mat_mask.xml"), {}, 8192, REF_SEEDS),
    ("mat_bumpmap", os.path.join(SCENES, "mat_bumpmap.xml"), {}, 4096, REF_SEEDS),
    ("mat_rough_tex", os.path.join(SCENES, "mat_rough_tex.xml"), {}, 4096, REF_SEEDS),
    ("light_area_tex", os.path.join(SCENES, "light_area_tex.xml"), {}, 4096, REF_SEEDS),
    # Mitsuba `serialized` meshes (tests/data/geometry/make_serialized.py): v4 two-mesh file with
    # shape_index 0 (normals, uvs) and 1 (double precision, face_normals), and a v3 file.
    ("serialized", os.path.join(SCENES, "serialized.xml"), {}, 8192, REF_SEEDS),
    # The `moment` and `aov` integrators (tests/render/aov.rs): every film channel, see CHANNELS.
    ("moment", os.path.join(SCENES, "moment.xml"), {}, 4096, REF_SEEDS),
    ("aov", os.path.join(SCENES, "aov.xml"), {}, 4096, REF_SEEDS),
    # Sensors `orthographic` (scaled film, near_clip cutting the scene) and `thinlens` (visible
    # defocus), and the open `cylinder` shape (p0/p1/radius, to_world + uv checkerboard, emitting
    # and flip_normals emitting cylinders) under a rectangle area light.
    ("cam_ortho", os.path.join(SCENES, "cam_ortho.xml"), {}, 8192, REF_SEEDS),
    ("cam_thinlens", os.path.join(SCENES, "cam_thinlens.xml"), {}, 16384, REF_SEEDS),
    ("shape_cylinder", os.path.join(SCENES, "shape_cylinder.xml"), {}, 16384, REF_SEEDS),
    # The curve shapes: `linearcurve` (diffuse, uv checkerboard, to_world) and `bsplinecurve`
    # (rough gold; diffuse with a uv checkerboard) under a rectangle area light.
    ("shape_curves", os.path.join(SCENES, "shape_curves.xml"), {}, 8192, REF_SEEDS),
    # The `hair` BSDF on B-spline fibers (default brown, blonde, a thick helix with sigma_a).
    ("mat_hair", os.path.join(SCENES, "mat_hair.xml"), {}, 4096, REF_SEEDS),
    # principled (metal with textured roughness, glass, clearcoat, sheen, the documented mix)
    # and a principledthin sheet.
    ("mat_principled", os.path.join(SCENES, "mat_principled.xml"), {}, 4096, REF_SEEDS),
    # Linear float images (tests/data/textures/make_hdr_pfm.py): bitmaps from a run-length RGBE
    # file and from colour (big-endian) and grey (little-endian, scaled) PFM files; an envmap from
    # an RGBE file; mesh_attribute (PLY vertex colours, a face attribute as a blend weight) and
    # rawconstant (3-D reflectances, a 1-D roughness).
    ("tex_hdr_pfm", os.path.join(SCENES, "tex_hdr_pfm.xml"), {}, 1024, REF_SEEDS),
    ("light_envmap_hdr", os.path.join(SCENES, "light_envmap_hdr.xml"), {}, 1024, REF_SEEDS),
    ("tex_mesh_attr", os.path.join(SCENES, "tex_mesh_attr.xml"), {}, 1024, REF_SEEDS),
    # shapegroup + instance: a mesh, a sphere and a cube placed four times (translated, rotated and
    # scaled, non-uniformly scaled, mirrored).
    ("shape_instance", os.path.join(SCENES, "shape_instance.xml"), {}, 8192, REF_SEEDS),
    # Issue 14: the projector (bitmap, non-square, oblique) and the textured spot; `direct` with
    # emitter_samples = 4 beside a point light (Mitsuba's delta-light weight); non-unit
    # <rotate> axes on smooth-normal meshes; an OBJ area light with zero-area triangles.
    ("light_projector", os.path.join(SCENES, "light_projector.xml"), {}, 2048, REF_SEEDS),
    ("light_spot_tex", os.path.join(SCENES, "light_spot_tex.xml"), {}, 2048, REF_SEEDS),
    ("direct_delta", os.path.join(SCENES, "direct_delta.xml"), {}, 1024, REF_SEEDS),
    ("rotate_axis", os.path.join(SCENES, "rotate_axis.xml"), {}, 2048, REF_SEEDS),
    ("degenerate_mesh", os.path.join(SCENES, "degenerate_mesh.xml"), {}, 2048, REF_SEEDS),
    # Issue 19: light tracing (`ptracer`, the scenes' default $integrator) on a Cornell box, delta
    # lights (point, spot, directional), glass caustics (smooth and rough) and classic normal
    # mapping. 8 seeds: light paths splat into many pixels, so the per-pixel variance is taken
    # across more independent renders than for the path tracer's references.
    ("ptracer_cbox", os.path.join(SCENES, "ptracer_cbox.xml"), {}, 2048, list(range(8))),
    ("ptracer_point_spot", os.path.join(SCENES, "ptracer_point_spot.xml"), {}, 2048, list(range(8))),
    ("ptracer_glass", os.path.join(SCENES, "ptracer_glass.xml"), {}, 2048, list(range(8))),
    ("ptracer_nmap", os.path.join(SCENES, "ptracer_nmap.xml"), {}, 2048, list(range(8))),
    # Mitsuba's transform quirks on a rectangle, a disk (non-unit <rotate> axes), spheres under a
    # non-uniform scale and a shear, and an instance under a non-unit axis; and the aov
    # integrator's shape_index and normals under instancing.
    ("rotate_shapes", os.path.join(SCENES, "rotate_shapes.xml"), {}, 2048, REF_SEEDS),
    ("aov_instance", os.path.join(SCENES, "aov_instance.xml"), {}, 2048, REF_SEEDS),
    # Participating media (volpath): a homogeneous hg sphere behind a null boundary under an area
    # light; the sensor, objects and an area light inside a fog (blendphase); a dielectric sphere
    # with an absorbing interior.
    ("media_sphere", os.path.join(SCENES, "media_sphere.xml"), {}, 2048, REF_SEEDS),
    ("media_fog", os.path.join(SCENES, "media_fog.xml"), {}, 2048, REF_SEEDS),
    ("media_glass", os.path.join(SCENES, "media_glass.xml"), {}, 2048, REF_SEEDS),
    # The same under volpathmis (spectral MIS), and a strongly chromatic medium sphere where
    # spectral MIS matters (volpath's estimate there is heavy-tailed).
    ("media_chroma_mis", os.path.join(SCENES, "media_chroma.xml"), {}, 2048, REF_SEEDS),
    ("media_fog_mis", os.path.join(SCENES, "media_fog.xml"), {"integrator": "volpathmis"}, 2048, REF_SEEDS),
    ("media_glass_mis", os.path.join(SCENES, "media_glass.xml"), {"integrator": "volpathmis"}, 2048, REF_SEEDS),
    # Heterogeneous media (gridvolume, delta / ratio tracking): a smooth 1-channel density
    # (trilinear) and a 3-channel checkerboard (nearest) behind null cubes, area light.
    ("media_hetero", os.path.join(SCENES, "media_hetero.xml"), {}, 2048, REF_SEEDS),
    # A homogeneous medium with a gridvolume albedo (evaluated per scattering point; sigma_t
    # constant), under volpath and volpathmis.
    ("media_albedo_grid", os.path.join(SCENES, "media_albedo_grid.xml"), {}, 2048, REF_SEEDS),
    ("media_albedo_grid_mis", os.path.join(SCENES, "media_albedo_grid.xml"),
     {"integrator": "volpathmis"}, 2048, REF_SEEDS),
    # ... with the medium's emitter sampling off (as Mitsuba's medium_homogeneous_sss_textured.xml).
    ("media_albedo_grid_nonee", os.path.join(SCENES, "media_albedo_grid.xml"),
     {"sample_emitters": "false"}, 2048, REF_SEEDS),
    # ... and with has_spectral_extinction off: Mitsuba's grey shortcut, whose shadow rays see
    # exp(-sigma_t[c] d) in every channel for the path's channel c.
    ("media_albedo_grid_grey", os.path.join(SCENES, "media_albedo_grid.xml"),
     {"sample_emitters": "false", "spectral": "false"}, 2048, REF_SEEDS),
    ("media_albedo_grid_grey_mis", os.path.join(SCENES, "media_albedo_grid.xml"),
     {"sample_emitters": "false", "spectral": "false", "integrator": "volpathmis"}, 2048, REF_SEEDS),
    # The same under volpathmis: null collisions in the spectral-MIS weights, on camera, bounce
    # and shadow rays (the checkerboard is chromatic).
    ("media_hetero_mis", os.path.join(SCENES, "media_hetero.xml"), {"integrator": "volpathmis"}, 2048, REF_SEEDS),
    # The cylinder under a non-uniform scale, a shear and a non-unit <rotate>, lit by an elliptic
    # cylinder light (sampled as Mitsuba samples it: as a round tube).
    ("cylinder_quirks", os.path.join(SCENES, "cylinder_quirks.xml"), {}, 2048, REF_SEEDS),
    # sdfgrid on the generated grids of tests/data/sdfgrid (make_sdfgrids.py): an instanced
    # torus with smooth normals and an ellipsoid with analytic ones.
    ("sdfgrid", os.path.join(SCENES, "sdfgrid.xml"), {}, 2048, REF_SEEDS),
]

# Jobs whose film has extra channels (AOVs): the statistics are those of the film's developed
# bitmap (what Mitsuba writes to disk: all channels, named as in the EXR Mitsuba writes), and
# NAME.channels.exr / NAME.channels.var.exr hold every channel (mean over the seeds, variance of
# that mean); NAME.exr / NAME.var.exr are the film's R, G, B as for the other jobs.
CHANNELS = {"moment", "aov", "aov_instance"}

# Jobs whose pixels are correlated (non-box filter): also write NAME.tT.exr / NAME.tT.var.exr, the
# mean over seeds of the T x T tile averages and the variance of that mean estimated from the
# per-seed tile averages (so covariances between pixels of a tile are included).
TILE_STATS = {"cbox_values": 8}


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--only", nargs="*", default=None, help="job names to (re)render")
    ap.add_argument("--spp-scale", type=float, default=1.0,
                    help="multiply every job's spp (for quick trial runs; do not commit those)")
    ap.add_argument("--out", default=HERE, help="output folder (default: tests/refs)")
    args = ap.parse_args()

    import drjit as dr
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    dr.set_thread_count(args.threads)
    mi.set_log_level(mi.LogLevel.Warn)

    os.makedirs(args.out, exist_ok=True)
    summary_path = os.path.join(args.out, "refs.json")
    summary = {}
    if os.path.isfile(summary_path):
        with open(summary_path) as f:
            summary = json.load(f)

    for name, scene_path, defines, spp, seeds in JOBS:
        if args.only and name not in args.only:
            continue
        spp = max(1, int(round(spp * args.spp_scale)))
        t0 = time.perf_counter()
        scene = mi.load_file(scene_path, **defines)
        t_load = time.perf_counter() - t0
        renders, times, channel_renders, channel_names = [], [], [], None
        for s in seeds:
            t0 = time.perf_counter()
            img = np.array(mi.render(scene, spp=spp, seed=s), dtype=np.float64)[:, :, :3]
            times.append(time.perf_counter() - t0)
            if name in CHANNELS:
                bmp = scene.sensors()[0].film().bitmap()
                channel_names = [f.name for f in bmp.struct_()]
                all_ch = np.array(bmp, dtype=np.float64)
                channel_renders.append(all_ch)
                img = all_ch[:, :, [channel_names.index(c) for c in "RGB"]]
            renders.append(img)
        stack = np.stack(renders)  # K x H x W x 3
        k = stack.shape[0]
        mean = stack.mean(axis=0)
        var_mean = stack.var(axis=0, ddof=1) / k

        def write(arr, path):
            bmp = mi.Bitmap(np.ascontiguousarray(arr, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
            bmp.write(path)

        write(mean, os.path.join(args.out, f"{name}.exr"))
        write(var_mean, os.path.join(args.out, f"{name}.var.exr"))
        if name in CHANNELS:
            cs = np.stack(channel_renders)
            for arr, suffix in [(cs.mean(axis=0), "channels"),
                                (cs.var(axis=0, ddof=1) / cs.shape[0], "channels.var")]:
                bmp = mi.Bitmap(np.ascontiguousarray(arr, dtype=np.float32),
                                mi.Bitmap.PixelFormat.MultiChannel, channel_names=channel_names)
                bmp.write(os.path.join(args.out, f"{name}.{suffix}.exr"))
        if name in TILE_STATS:
            t = TILE_STATS[name]
            hh, ww = stack.shape[1] // t, stack.shape[2] // t
            tiles = stack[:, :hh * t, :ww * t].reshape(k, hh, t, ww, t, 3).mean(axis=(2, 4))
            write(tiles.mean(axis=0), os.path.join(args.out, f"{name}.t{t}.exr"))
            write(tiles.var(axis=0, ddof=1) / k, os.path.join(args.out, f"{name}.t{t}.var.exr"))

        # Noise summary over "lit" pixels: mean luminance above 10% of the median non-zero pixel
        # (excludes black background; directly seen emitters, exact in Mitsuba, are included).
        lum = mean.mean(axis=2)
        pos = lum[lum > 0]
        lit = lum > 0.1 * (np.median(pos) if pos.size else 0.0)
        rel = np.sqrt(var_mean.mean(axis=2))[lit] / np.maximum(lum[lit], 1e-12)
        h, w = mean.shape[:2]
        rec = {
            "scene": os.path.relpath(scene_path, REPO),
            "defines": defines,
            "width": w, "height": h,
            "spp_per_seed": spp, "seeds": seeds, "total_spp": spp * k,
            "load_s": round(t_load, 3),
            "render_s_per_seed": [round(t, 2) for t in times],
            "render_s_total": round(sum(times), 2),
            "mean_rgb": [round(float(x), 6) for x in mean.reshape(-1, 3).mean(axis=0)],
            "rel_se_lit_median": round(float(np.median(rel)), 5),
            "rel_se_lit_p90": round(float(np.percentile(rel, 90)), 5),
            "rel_se_lit_max": round(float(rel.max()), 5),
            "whole_image_rel_se": round(float(np.sqrt(var_mean.sum()) / max(mean.sum(), 1e-12)), 6),
            "mitsuba": mi.__version__, "variant": "scalar_rgb", "threads": args.threads,
        }
        summary[name] = rec
        print(f"{name:18s} {w}x{h} spp {spp}x{k}  render {sum(times):7.1f} s  "
              f"mean {rec['mean_rgb']}  relSE lit median {rec['rel_se_lit_median']:.4f} "
              f"p90 {rec['rel_se_lit_p90']:.4f} max {rec['rel_se_lit_max']:.4f}", flush=True)
        with open(summary_path, "w") as f:
            json.dump(summary, f, indent=1, sort_keys=True)


if __name__ == "__main__":
    sys.exit(main())
