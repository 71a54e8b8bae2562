//! Tier A (brute-force analytic intersection, issue 16 item 3) reports the `Hit` the Embree tier
//! reports, bit for bit: same shape, triangle, t, u and v, for the nearest-hit and occlusion
//! queries, one ray at a time (one ray × 8 primitives) and in packets (8 rays × every
//! primitive, full and partial; and 16 rays on AVX-512, equal to the 8-ray packets and single
//! rays bit for bit, `sixteen_consistent`). Over the bench scenes and random primitive sets, ≥ 30,000 rays
//! each: from outside and inside, from points on the surfaces, aimed at sphere silhouettes,
//! rectangle, disk and box edges, grazing along planes, and with tmax/tmin cut at a hit's t.
//!
//! One difference is allowed: two shapes hit at exactly the same t. Tier A takes the lower
//! shape index; Embree takes the one its traversal tests first (its callbacks accept only
//! t < tfar). Such ties are counted and must stay rare.
//!
//! Mesh triangles (issue 18) are tier A's own arithmetic, not Embree's: on the Cornell boxes
//! the two tiers must agree on the shape and triangle away from the triangles' edges, and on t
//! and the hit point within a rounding bound (`cbox_triangles_agree_with_embree`).

use glam::{Mat4, Vec3};
use groove::accel::{Accel, HitRow, RayBuf, Tier};
use groove::geometry::{Hit, Ray, Shape, ShapeKind};
use groove::load::Loaded;
use groove::math::Pcg32;
use std::path::Path;

const RAYS: usize = 36_000;

fn load_file(name: &str) -> Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(name);
    groove::load::load_scene(&path, &Default::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn load_text(body: &str) -> Loaded {
    let text =
        format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n");
    let doc = groove::scene::xml::parse::load_str(&text, Path::new("mem.xml"), &[]).unwrap();
    groove::load::instantiate(&doc, Path::new("mem.xml")).unwrap_or_else(|e| panic!("{e}"))
}

/// A random transform: non-uniform scale, a rotation about a possibly non-unit axis (Mitsuba's
/// quirk), a translation within ±`spread`.
fn transform(rng: &mut Pcg32, spread: f32) -> String {
    let mut u = || 2.0 * rng.next_f32() - 1.0;
    let s = [
        0.2 + 0.6 * u().abs(),
        0.2 + 0.6 * u().abs(),
        0.2 + 0.6 * u().abs(),
    ];
    let axis = [u(), u(), u() + 0.01];
    let angle = 180.0 * u();
    let t = [spread * u(), spread * u(), spread * u()];
    format!(
        r#"<transform name="to_world"><scale x="{}" y="{}" z="{}"/><rotate x="{}" y="{}" z="{}" angle="{angle}"/><translate x="{}" y="{}" z="{}"/></transform>"#,
        s[0], s[1], s[2], axis[0], axis[1], axis[2], t[0], t[1], t[2]
    )
}

/// `n` random spheres, disks, rectangles and cubes (overlapping), plus two rectangles sharing
/// an edge and a disk lying on a cube's face (equal-t contacts).
fn random_set(seed: u64, n: usize) -> Loaded {
    let mut rng = Pcg32::new(seed, 1);
    let mut body = String::new();
    for k in 0..n {
        let tf = transform(&mut rng, 1.5);
        body += &match k % 4 {
            0 => {
                let mut u = || 2.0 * rng.next_f32() - 1.0;
                format!(
                    r#"<shape type="sphere"><point name="center" x="{}" y="{}" z="{}"/><float name="radius" value="{}"/></shape>"#,
                    1.5 * u(),
                    1.5 * u(),
                    1.5 * u(),
                    0.1 + 0.5 * u().abs()
                )
            }
            1 => format!(r#"<shape type="disk">{tf}</shape>"#),
            2 => format!(r#"<shape type="rectangle">{tf}</shape>"#),
            _ => format!(r#"<shape type="cube">{tf}</shape>"#),
        };
    }
    body += r#"<shape type="rectangle"><transform name="to_world"><translate x="-1"/></transform></shape>
               <shape type="rectangle"><transform name="to_world"><translate x="1"/></transform></shape>
               <shape type="cube"><transform name="to_world"><scale value="0.5"/><translate y="2"/></transform></shape>
               <shape type="disk"><transform name="to_world"><scale value="0.3"/><translate y="2" z="0.5"/></transform></shape>"#;
    load_text(&body)
}

/// Tier A's in-place packets (`Accel::intersect8_with`, `intersect8_scatter` and
/// `intersect8_rows`, the stream renderer's, and at 16 rays `Accel::intersect16_with`: each
/// ray read through `ray(k)`, here the lanes in reverse, each hit handed over in lane order as
/// a row, or stored at its id or in place) give `packet`'s hits (`Accel::intersect8` or
/// `intersect16` of `lanes`, at most `W` rays) bit for bit, once per ray; a hit's row is
/// exactly `HitRow::new`'s and a miss's first word is `HitRow::MISS`.
fn in_place_equal<const W: usize>(
    brute: &Accel,
    lanes: &[Ray],
    coherent: bool,
    packet: &[Option<Hit>; W],
) {
    let n = lanes.len();
    let mut got = vec![None; n];
    let mut order = Vec::new();
    let ray = |k: usize| &lanes[n - 1 - k];
    let out = |k: usize, h: HitRow| {
        if h.is_hit() {
            assert_eq!(h, HitRow::new(h.get()), "a hit's row");
        } else {
            assert_eq!(h.0[0], HitRow::MISS, "a miss's row");
        }
        got[k] = h.get();
        order.push(k);
    };
    let mut buf = RayBuf::default();
    match W {
        8 => brute.intersect8_with(&mut buf, n, coherent, ray, out),
        16 => brute.intersect16_with(&mut buf, n, coherent, ray, out),
        _ => unreachable!("packets of 8 or 16 rays"),
    }
    assert_eq!(
        order,
        (0..n).collect::<Vec<_>>(),
        "one hit per ray, in lane order"
    );
    for (k, h) in got.iter().enumerate() {
        let r = &lanes[n - 1 - k];
        assert_eq!(
            bits(h),
            bits(&packet[n - 1 - k]),
            "ray {r:?}: in place ({W})"
        );
    }
    if W == 8 {
        // `Accel::intersect8_scatter` (the stream renderer's packets of active paths): ray k
        // read from `rays[ids[k]]` and its row stored in `col[ids[k]]`, ids spread over
        // columns whose other entries hold other rays (never to be read) and rows that stay
        // as they were; the same rows as the packet's hits.
        let ids: Vec<u32> = (0..n as u32).map(|k| 3 * k + 1).collect();
        let mut rays: Vec<Ray> = lanes.iter().copied().cycle().take(3 * n + 2).collect();
        for (k, &i) in ids.iter().enumerate() {
            rays[i as usize] = *ray(k);
        }
        let untouched = HitRow([7; 8]);
        let mut col = vec![untouched; 3 * n + 2];
        brute.intersect8_scatter(&mut buf, coherent, &ids, &rays, &mut col);
        for (j, row) in col.iter().enumerate() {
            let Some(k) = ids.iter().position(|&i| i as usize == j) else {
                assert_eq!(*row, untouched, "entry {j}: no id names it");
                continue;
            };
            let r = &lanes[n - 1 - k];
            if row.is_hit() {
                assert_eq!(
                    *row,
                    HitRow::new(row.get()),
                    "ray {r:?}: a scattered hit's row"
                );
            } else {
                assert_eq!(row.0[0], HitRow::MISS, "ray {r:?}: a scattered miss's row");
            }
            assert_eq!(
                bits(&row.get()),
                bits(&packet[n - 1 - k]),
                "ray {r:?}: scattered"
            );
        }
        // `Accel::intersect8_rows` (the stream renderer's camera packets): 8 consecutive rays'
        // rows stored in 8 consecutive entries, the same rows as the packet's hits.
        if let Ok(eight) = <&[Ray; 8]>::try_from(lanes) {
            let mut rows = [untouched; 8];
            brute.intersect8_rows(&mut buf, coherent, eight, &mut rows);
            for (k, row) in rows.iter().enumerate() {
                let r = &lanes[k];
                if row.is_hit() {
                    assert_eq!(*row, HitRow::new(row.get()), "ray {r:?}: a row's hit");
                } else {
                    assert_eq!(row.0[0], HitRow::MISS, "ray {r:?}: a row's miss");
                }
                assert_eq!(bits(&row.get()), bits(&packet[k]), "ray {r:?}: rows");
            }
        }
    }
}

/// Tier A's packet, occlusion and 8-wide occlusion answers for `lanes` (at most 8 rays) equal
/// its single-ray hits bit for bit; returns those hits, ray by ray.
fn self_consistent(brute: &Accel, lanes: &[Ray], coherent: bool) -> Vec<Option<Hit>> {
    let mut packet = [None; 8];
    brute.intersect8(lanes, coherent, &mut packet);
    in_place_equal(brute, lanes, coherent, &packet);
    let blocked = brute.occluded8(lanes);
    let mut hits = Vec::with_capacity(lanes.len());
    for (i, ray) in lanes.iter().enumerate() {
        let got = brute.intersect(ray);
        assert_eq!(bits(&got), bits(&packet[i]), "ray {ray:?}: packet");
        assert_eq!(brute.occluded(ray), got.is_some(), "ray {ray:?}: occluded");
        assert_eq!(
            blocked >> i & 1 == 1,
            got.is_some(),
            "ray {ray:?}: occluded8"
        );
        hits.push(got);
    }
    hits
}

/// Whether this CPU runs tier A's 16-ray packets 16 wide (else they are two 8-ray packets, and
/// the comparisons below check only that fallback).
fn has_avx512() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        groove::lane::Avx512::detect().is_some()
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Prints why `name` compares the 16-ray packets only as two 8-ray packets, where it does.
fn note_width(name: &str) {
    if !has_avx512() {
        eprintln!("{name}: this CPU has no AVX-512; 16-ray packets run as two 8-ray packets");
    }
}

/// Tier A's 16-ray packets (`Accel::intersect16`, `occluded16`, and in place
/// `intersect16_with`) give every ray of `all` the hit and the occlusion its 8-ray packets and
/// its single-ray queries give, bit for bit; in
/// packets of 16 rays mostly and of 1..15 every few (so a ray meets every lane position, and
/// the padded lanes stay empty).
fn sixteen_consistent(name: &str, brute: &Accel, all: &[Ray]) {
    let (mut start, mut k) = (0, 0);
    while start < all.len() {
        let n = if k % 4 == 3 { 1 + k % 15 } else { 16 };
        let lanes = &all[start..(start + n).min(all.len())];
        let mut wide = [None; 16];
        brute.intersect16(lanes, k % 2 == 0, &mut wide);
        in_place_equal(brute, lanes, k % 2 == 0, &wide);
        let blocked = brute.occluded16(lanes);
        assert_eq!(u32::from(blocked) >> lanes.len(), 0, "{name}: lanes past n");
        assert!(wide[lanes.len()..].iter().all(Option::is_none), "{name}");
        for (h, half) in lanes.chunks(8).enumerate() {
            let mut eight = [None; 8];
            brute.intersect8(half, false, &mut eight);
            let blocked8 = brute.occluded8(half);
            for (i, r) in half.iter().enumerate() {
                let j = 8 * h + i;
                let one = brute.intersect(r);
                assert_eq!(bits(&wide[j]), bits(&eight[i]), "{name}: {r:?}: 16 vs 8");
                assert_eq!(bits(&wide[j]), bits(&one), "{name}: {r:?}: 16 vs one ray");
                let b = blocked >> j & 1 == 1;
                assert_eq!(b, blocked8 >> i & 1 == 1, "{name}: {r:?}: occluded16 vs 8");
                assert_eq!(b, brute.occluded(r), "{name}: {r:?}: occluded16 vs one ray");
            }
        }
        start += lanes.len();
        k += 1;
    }
}

/// Bit pattern of a hit, for exact comparison (also `packets.rs`'s): its row
/// ([`HitRow::new`]: geom, prim, the bits of t, u and v, inst; a miss's own row).
pub(crate) fn bits(h: &Option<Hit>) -> HitRow {
    HitRow::new(*h)
}

/// A point on the edge, silhouette or rim of shape `s`, seen from `o`.
fn edge_point(rng: &mut Pcg32, s: &Shape, o: Vec3) -> Option<Vec3> {
    let mut u = || 2.0 * rng.next_f32() - 1.0;
    let (side, along) = (if u() < 0.0 { -1.0 } else { 1.0 }, u());
    let flip = u() < 0.0;
    let square = |m: &Mat4| {
        let p = if flip {
            Vec3::new(side, along, 0.0)
        } else {
            Vec3::new(along, side, 0.0)
        };
        m.transform_point3(p)
    };
    Some(match (&s.kind, s.box_to_world) {
        (ShapeKind::Sphere { center, radius, .. }, _) => {
            let axis = (*center - o).normalize_or(Vec3::Z);
            let t = axis.any_orthonormal_vector();
            let b = axis.cross(t);
            let phi = std::f32::consts::PI * u();
            // On the silhouette circle seen from o (approximately: for a distant o).
            *center + (t * phi.cos() + b * phi.sin()) * *radius
        }
        (ShapeKind::Rectangle { to_world }, _) => square(to_world),
        (ShapeKind::Disk { hit_to_world, .. }, _) => {
            let phi = std::f32::consts::PI * u();
            hit_to_world.transform_point3(Vec3::new(phi.cos(), phi.sin(), 0.0))
        }
        (ShapeKind::Mesh(_), Some(m)) => {
            let mut p = [side, if u() < 0.0 { -1.0 } else { 1.0 }, along];
            p.rotate_left((rng.next_u32() % 3) as usize);
            m.transform_point3(Vec3::from_array(p))
        }
        _ => return None,
    })
}

/// A direction in the plane of a disk or rectangle, or tangent to a sphere, from a point of it.
fn grazing(rng: &mut Pcg32, s: &Shape) -> Option<Ray> {
    let mut u = || 2.0 * rng.next_f32() - 1.0;
    let (m, ..) = match &s.kind {
        ShapeKind::Rectangle { to_world } => (to_world, ()),
        ShapeKind::Disk { hit_to_world, .. } => (hit_to_world, ()),
        ShapeKind::Sphere { center, radius, .. } => {
            let n = Vec3::new(u(), u(), u()).normalize_or(Vec3::Z);
            let p = *center + n * *radius;
            let d = n
                .cross(Vec3::new(u(), u(), u()))
                .normalize_or(n.any_orthonormal_vector());
            return Some(Ray::new(p - d * 3.0, d));
        }
        _ => return None,
    };
    let p = m.transform_point3(Vec3::new(2.0 * u(), 2.0 * u(), 0.0));
    let d = m
        .transform_vector3(Vec3::new(u(), u(), 0.0))
        .normalize_or(Vec3::X);
    Some(Ray::new(p - d * 3.0, d))
}

/// The test rays of one scene (`embree` gives the hits that place rays on surfaces and cut
/// tmax and tmin).
fn rays(loaded: &Loaded, embree: &Accel, seed: u64) -> Vec<Ray> {
    let (c, r) = loaded.scene.bsphere();
    let shapes = loaded.scene.shapes();
    let mut rng = Pcg32::new(seed, 9);
    let mut out = Vec::with_capacity(RAYS);
    while out.len() < RAYS {
        let shape = &shapes[(rng.next_u32() as usize) % shapes.len().max(1)];
        let mut u = || 2.0 * rng.next_f32() - 1.0;
        let outside = c + Vec3::new(u(), u(), u()).normalize_or(Vec3::Z) * 2.0 * r;
        let inside = c + Vec3::new(u(), u(), u()) * 0.6 * r;
        let toward = |p: Vec3, o: Vec3| Ray::new(o, (p - o).normalize_or(Vec3::Z));
        let base = toward(inside, outside);
        let kind = out.len() % 8;
        let ray = match kind {
            0 => base,
            1 => toward(c + Vec3::new(u(), u(), u()) * r, inside),
            2 | 3 => {
                // From the surface point the base ray hits, in any direction.
                let Some(h) = embree.intersect(&base) else {
                    continue;
                };
                let d = Vec3::new(u(), u(), u()).normalize_or(Vec3::Y);
                Ray::new(base.at(h.t), d)
            }
            4 => match edge_point(&mut rng, shape, outside) {
                Some(p) => toward(p, outside),
                None => continue,
            },
            5 => match grazing(&mut rng, shape) {
                Some(r) => r,
                None => continue,
            },
            _ => {
                // tmax or tmin exactly at, just before or just after the nearest hit.
                let Some(h) = embree.intersect(&base) else {
                    continue;
                };
                let mut r = base;
                match rng.next_u32() % 6 {
                    0 => r.tmax = h.t,
                    1 => r.tmax = f32::from_bits(h.t.to_bits() - 1),
                    2 => r.tmax = f32::from_bits(h.t.to_bits() + 1),
                    3 => r.tmin = h.t,
                    4 => r.tmin = f32::from_bits(h.t.to_bits() - 1),
                    _ => r.tmax = h.t * 0.5,
                }
                r
            }
        };
        out.push(ray);
    }
    out
}

/// Every query of tier A against Embree's on `loaded`, Embree tracing the rectangles as user
/// geometries (as it does in a scene of analytic shapes) and as filtered slabs of triangles
/// (as in a scene of meshes and rectangles); returns (hits, ties and cut-offs) of the latter.
fn compare(name: &str, loaded: &Loaded, seed: u64) -> (usize, usize) {
    let shapes = loaded.scene.shapes();
    let embree = Accel::build_tiered(shapes, &[], &[], Tier::Embree).unwrap();
    let brute = Accel::build_tiered(shapes, &[], &[], Tier::Brute).unwrap();
    assert_eq!((embree.tier(), brute.tier()), (Tier::Embree, Tier::Brute));
    let all = rays(loaded, &embree, seed);
    sixteen_consistent(name, &brute, &all);
    compare_rays(name, &embree, &brute, &all);
    let slabs = Accel::build_embree_rect_slabs(shapes).unwrap();
    compare_rays(&format!("{name}, rectangle slabs"), &slabs, &brute, &all)
}

/// Every query of tier A (`brute`) against Embree's (`embree`) for the rays `all`.
fn compare_rays(name: &str, embree: &Accel, brute: &Accel, all: &[Ray]) -> (usize, usize) {
    let (mut hits, mut start, mut k) = (0, 0, 0);
    let mut counts = [0usize; 4];
    while start < all.len() {
        // Packets of 8 mostly, 1..7 every few.
        let n = if k % 4 == 3 { 1 + k % 7 } else { 8 };
        let lanes = &all[start..(start + n).min(all.len())];
        let mut packet = [None; 8];
        brute.intersect8(lanes, k % 2 == 0, &mut packet);
        in_place_equal(brute, lanes, k % 2 == 0, &packet);
        let blocked = brute.occluded8(lanes);
        assert_eq!(u32::from(blocked) >> lanes.len(), 0, "{name}: lanes past n");
        assert!(packet[lanes.len()..].iter().all(Option::is_none));
        for (i, r) in lanes.iter().enumerate() {
            let (want, got) = (embree.intersect(r), brute.intersect(r));
            assert_eq!(
                bits(&got),
                bits(&packet[i]),
                "{name}: ray {r:?}: one ray {got:?}, packet {:?}",
                packet[i]
            );
            let occluded = brute.occluded(r);
            assert_eq!(
                occluded,
                got.is_some(),
                "{name}: tier A's two queries, {r:?}"
            );
            assert_eq!(
                blocked >> i & 1 == 1,
                occluded,
                "{name}: packet occlusion {r:?}"
            );
            let diff = classify(r, &want, &got);
            assert!(
                diff != Diff::Other,
                "{name}: ray {r:?}: Embree {want:?}, tier A {got:?}"
            );
            let embree_occluded = embree.occluded(r);
            assert_eq!(
                embree_occluded,
                want.is_some(),
                "{name}: Embree's two queries {r:?}"
            );
            assert!(
                embree_occluded == occluded || diff == Diff::Cut,
                "{name}: occlusion of {r:?}"
            );
            counts[diff as usize] += 1;
            hits += usize::from(want.is_some());
        }
        start += lanes.len();
        k += 1;
    }
    println!(
        "{name}: {} rays, {hits} hits; differ: {} ties, {} cut-offs",
        all.len(),
        counts[Diff::Tie as usize],
        counts[Diff::Cut as usize]
    );
    assert!(hits > all.len() / 3, "{name}: only {hits} hits");
    // Ties need a ray aimed at an edge two shapes share; cut-offs a tmin or tmax placed within
    // ulps of a hit, which only the test's own cut rays do (renders cut shadow rays 1e-4 short).
    let (ties, cuts) = (counts[Diff::Tie as usize], counts[Diff::Cut as usize]);
    assert!(ties * 1000 <= all.len(), "{name}: {ties} ties");
    assert!(cuts * 50 <= all.len(), "{name}: {cuts} cut-offs");
    let differ = ties + cuts;
    (hits, differ)
}

/// How tier A's answer to a ray differs from Embree's.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Diff {
    /// Not at all (bit for bit).
    Same,
    /// Two shapes at exactly the same t: tier A takes the lower index; Embree does too when it
    /// calls both callbacks (`tie_tfar` in `embree.rs`), but its box test (own rounding) may
    /// cull the second box, whose entry is that same t.
    Tie,
    /// Tier A hits at a t within 4 ulps of tmin or tmax where Embree reports nothing (or a
    /// farther hit): Embree's ray–box test, rounded its own way, culled the shape's box. The
    /// callbacks' own test (which tier A repeats) accepts the hit.
    Cut,
    Other,
}

fn classify(r: &Ray, want: &Option<Hit>, got: &Option<Hit>) -> Diff {
    let ulps =
        |a: f32, b: f32| (i64::from(a.to_bits() as i32) - i64::from(b.to_bits() as i32)).abs();
    match (want, got) {
        _ if bits(want) == bits(got) => Diff::Same,
        (Some(w), Some(g)) if w.t.to_bits() == g.t.to_bits() && w.geom != g.geom => Diff::Tie,
        (w, Some(g))
            if !w.is_some_and(|w| w.t <= g.t)
                && (ulps(g.t, r.tmin) <= 4 || ulps(g.t, r.tmax) <= 4) =>
        {
            Diff::Cut
        }
        _ => Diff::Other,
    }
}

#[test]
fn tier_a_hits_equal_embree_on_the_bench_scenes() {
    note_width("bench scenes");
    for name in ["metal_plastic", "glass", "strong"] {
        let loaded = load_file(&format!("scenes/bench/{name}.xml"));
        compare(name, &loaded, 3);
    }
}

#[test]
fn tier_a_hits_equal_embree_on_random_primitive_sets() {
    for (seed, n) in [(1, 1), (2, 5), (3, 12), (4, 40)] {
        compare(
            &format!("random set {seed} ({n} shapes)"),
            &random_set(seed, n),
            seed,
        );
    }
}

/// The automatic choice: a few analytic shapes take tier A, many or any mesh take Embree, and
/// forcing tier A on a scene with a mesh is an error that says why.
#[test]
fn the_tier_is_chosen_by_kind_and_count() {
    let few = random_set(5, 4);
    let shapes = few.scene.shapes();
    let auto = Accel::build_tiered(shapes, &[], &[], Tier::Auto).unwrap();
    assert_eq!(auto.tier(), Tier::Brute);
    let many = random_set(6, groove::accel::BRUTE_MAX_SHAPES);
    let auto = Accel::build_tiered(many.scene.shapes(), &[], &[], Tier::Auto).unwrap();
    assert_eq!(
        auto.tier(),
        Tier::Embree,
        "{} shapes",
        many.scene.shapes().len()
    );
    // A few triangles beside a sphere take tier A; a cylinder needs Embree, and forcing tier A
    // on it is an error that says why.
    let mesh = load_text(&format!(
        r#"<shape type="sphere"/><shape type="obj"><string name="filename" value="{}/tests/data/geometry/quad.obj"/></shape>"#,
        env!("CARGO_MANIFEST_DIR")
    ));
    let auto = Accel::build_tiered(mesh.scene.shapes(), &[], &[], Tier::Auto).unwrap();
    assert_eq!(auto.tier(), Tier::Brute);
    let cylinder = load_text(r#"<shape type="sphere"/><shape type="cylinder"/>"#);
    let auto = Accel::build_tiered(cylinder.scene.shapes(), &[], &[], Tier::Auto).unwrap();
    assert_eq!(auto.tier(), Tier::Embree);
    let forced = Accel::build_tiered(cylinder.scene.shapes(), &[], &[], Tier::Brute);
    let err = forced
        .err()
        .expect("a cylinder cannot take tier A")
        .to_string();
    assert!(err.contains("needs Embree"), "{err}");
    // The budget: analytic shapes and triangles share it.
    use groove::accel::{within_brute_budget, BRUTE_MAX_SHAPES, BRUTE_MAX_TRIANGLES};
    assert!(within_brute_budget(BRUTE_MAX_SHAPES, 0));
    assert!(within_brute_budget(0, BRUTE_MAX_TRIANGLES));
    assert!(within_brute_budget(
        BRUTE_MAX_SHAPES / 2,
        BRUTE_MAX_TRIANGLES / 2
    ));
    assert!(!within_brute_budget(
        BRUTE_MAX_SHAPES / 2 + 1,
        BRUTE_MAX_TRIANGLES / 2
    ));
    assert!(!within_brute_budget(0, BRUTE_MAX_TRIANGLES + 1));
}

/// The three Cornell boxes (8 OBJ meshes, 38 triangles) take tier A.
#[test]
fn the_cornell_boxes_take_tier_a() {
    let Some(dir) = crate::common::shared_cbox().parent().map(Path::to_path_buf) else {
        panic!("no shared directory")
    };
    for name in ["cbox.xml", "cbox-rgb.xml", "cbox-spectral.xml"] {
        let loaded = groove::load::load_scene(&dir.join(name), &Default::default())
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(loaded.scene.accel().tier(), Tier::Brute, "{name}");
    }
}

/// One triangle of a mesh shape, as a shape/triangle pair.
fn corners(shapes: &[Shape], geom: u32, prim: u32) -> [Vec3; 3] {
    let ShapeKind::Mesh(m) = &shapes[geom as usize].kind else {
        panic!("shape {geom} is not a mesh")
    };
    m.indices[prim as usize].map(|i| m.positions[i as usize])
}

/// The distance from `p` (in the triangle's plane) to the nearest edge of the triangle.
fn edge_distance(c: [Vec3; 3], p: Vec3) -> f32 {
    (0..3)
        .map(|k| {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            let ab = b - a;
            let s = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            (a + ab * s - p).length()
        })
        .fold(f32::INFINITY, f32::min)
}

/// Mesh triangles in tier A (Möller–Trumbore, `src/accel/triangle.rs`) against Embree's on the
/// Cornell box (38 triangles), over 40,000 rays: from outside, from inside, from surface points, aimed at
/// triangle interiors and at triangle edges. Tier A's forms (one ray, packets of 1..8, both
/// occlusion queries) agree bit for bit among themselves.
///
/// The bound: both tiers round each of c = p0 − o, the triple products and the division once
/// per operation; c carries an absolute error of ε(|p0| + |o|), each 3-term dot product ≤ 3ε of
/// its terms' magnitude, so t's error is at most about 8ε(|p0| + |o| + t)/cos θ in each tier
/// (θ between the ray and the normal; grazing rays amplify it), and likewise for the hit point
/// from the barycentrics. Two tiers and Embree's refined reciprocal: `TOL` = 64ε on that scale.
/// Within that distance of a triangle edge either tier may take the neighbouring triangle, or
/// (at a silhouette) miss where the other hits; such rays are counted and must stay rare. Where
/// two faces coincide (the boxes' bottoms on the floor) either may be reported at the same t.
#[test]
fn cbox_triangles_agree_with_embree() {
    const TOL: f32 = 64.0 * f32::EPSILON / 2.0;
    let loaded = groove::load::load_scene(&crate::common::shared_cbox(), &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let shapes = loaded.scene.shapes();
    let embree = Accel::build_tiered(shapes, &[], &[], Tier::Embree).unwrap();
    let brute = Accel::build_tiered(shapes, &[], &[], Tier::Brute).unwrap();
    let (c, r) = loaded.scene.bsphere();
    let tris: Vec<(u32, u32)> = shapes
        .iter()
        .enumerate()
        .flat_map(|(g, s)| match &s.kind {
            ShapeKind::Mesh(m) => (0..m.indices.len() as u32).map(|p| (g as u32, p)).collect(),
            _ => Vec::new(),
        })
        .collect();
    assert_eq!(tris.len(), 38);
    let mut rng = Pcg32::new(17, 3);
    let mut all = Vec::with_capacity(40_000);
    while all.len() < 40_000 {
        let x: [f32; 14] = std::array::from_fn(|_| rng.next_f32());
        let v3 = |k: usize| Vec3::new(2.0 * x[k] - 1.0, 2.0 * x[k + 1] - 1.0, 2.0 * x[k + 2] - 1.0);
        let outside = c + v3(0).normalize_or(Vec3::Z) * 2.0 * r;
        let inside = c + v3(3) * 0.5 * r;
        let dir = v3(6).normalize_or(Vec3::Y);
        let (g, p) = tris[(rng.next_u32() as usize) % tris.len()];
        let [a, b, d] = corners(shapes, g, p);
        let (s, t) = (x[9], x[10]);
        let (s, t) = if s + t > 1.0 {
            (1.0 - s, 1.0 - t)
        } else {
            (s, t)
        };
        let from = if x[11] < 0.5 { inside } else { outside };
        let toward = |target: Vec3, o: Vec3| Ray::new(o, (target - o).normalize_or(Vec3::Z));
        let ray = match all.len() % 5 {
            0 => toward(inside, outside),
            1 => Ray::new(inside, dir),
            2 => {
                // From a surface point, as the renderer's bounces (tmin a little above 0).
                let Some(h) = embree.intersect(&toward(inside, outside)) else {
                    continue;
                };
                let o = outside + (inside - outside).normalize() * h.t;
                let mut ray = Ray::new(o, dir);
                ray.tmin = 1e-4 * r;
                ray
            }
            3 => toward(a + (b - a) * s + (d - a) * t, from),
            // A point on an edge, give or take a few ulps.
            _ => toward(a + (b - a) * s, from),
        };
        all.push(ray);
    }
    note_width("cbox");
    sixteen_consistent("cbox", &brute, &all);
    let (mut hits, mut edges, mut coincident, mut k, mut start) = (0, 0, 0, 0, 0);
    while start < all.len() {
        let n = if k % 4 == 3 { 1 + k % 7 } else { 8 };
        let lanes = &all[start..(start + n).min(all.len())];
        let got_all = self_consistent(&brute, lanes, k % 2 == 0);
        for (ray, got) in lanes.iter().zip(got_all) {
            let want = embree.intersect(ray);
            let scale = |h: &Hit| {
                let [p0, p1, p2] = corners(shapes, h.geom, h.prim);
                let nrm = (p1 - p0).cross(p2 - p0).normalize();
                let cos = nrm.dot(ray.d).abs() / ray.d.length();
                TOL * (p0.length() + ray.o.length() + h.t * ray.d.length()) / cos
            };
            let near_edge = |h: &Hit| {
                let cs = corners(shapes, h.geom, h.prim);
                let p = cs[0] * (1.0 - h.u - h.v) + cs[1] * h.u + cs[2] * h.v;
                edge_distance(cs, p) <= 4.0 * scale(h)
            };
            let cut = |h: &Hit| (h.t - ray.tmin).abs() <= scale(h);
            match (&want, &got) {
                (None, None) => {}
                (Some(w), Some(g)) => {
                    hits += 1;
                    if (w.geom, w.prim) != (g.geom, g.prim) {
                        if near_edge(w) || near_edge(g) || cut(w) || cut(g) {
                            edges += 1;
                            continue;
                        }
                        // Else only coincident surfaces (the boxes stand on the floor): the same
                        // point on two parallel triangles.
                        let normal = |h: &Hit| {
                            let [p0, p1, p2] = corners(shapes, h.geom, h.prim);
                            (p1 - p0).cross(p2 - p0).normalize()
                        };
                        let cos = normal(w).dot(normal(g)).abs();
                        assert!(
                            cos > 0.9999 && (w.t - g.t).abs() <= scale(w),
                            "ray {ray:?}: Embree {want:?}, tier A {got:?}, away from edges"
                        );
                        coincident += 1;
                        continue;
                    }
                    let tol = scale(w);
                    assert!((w.t - g.t).abs() <= tol, "ray {ray:?}: t {w:?} vs {g:?}");
                    let [p0, p1, p2] = corners(shapes, w.geom, w.prim);
                    let at = |h: &Hit| p0 * (1.0 - h.u - h.v) + p1 * h.u + p2 * h.v;
                    assert!(
                        (at(w) - at(g)).length() <= tol,
                        "ray {ray:?}: point {} vs {} ({w:?}, {got:?})",
                        at(w),
                        at(g)
                    );
                }
                (Some(h), None) | (None, Some(h)) => {
                    assert!(
                        near_edge(h) || cut(h),
                        "ray {ray:?}: Embree {want:?}, tier A {got:?}: one hit, away from edges"
                    );
                    edges += 1;
                }
            }
        }
        start += lanes.len();
        k += 1;
    }
    println!(
        "cbox: {} rays, {hits} hits, {edges} at edges, {coincident} on coincident faces",
        all.len()
    );
    // Only rays aimed at the 4 triangles of the boxes' bottoms (4/38 of two fifths of the rays,
    // 4.2 %) can meet the floor at their t.
    assert!(coincident * 20 <= all.len(), "{coincident} coincident");
    assert!(hits > all.len() / 2, "only {hits} hits");
    // Only the edge-aimed fifth of the rays can land within a few ulps of an edge.
    assert!(edges * 20 <= all.len(), "{edges} rays differ at edges");
}

/// Rays parallel to an axis (that direction component +0 or −0) whose origin lies exactly on a
/// plane of a mesh's padded bounding box, tier A's cull (`mesh_bounds` in
/// `src/accel/brute.rs`: padded by 10⁻⁴ of the largest extent plus the largest coordinate
/// magnitude, recomputed here): its slab test takes 1/d = ±∞ for that axis and the plane's
/// parameter is 0·∞ = NaN. The slab test keeps such rays since issue 18
/// (`triangle::tests::the_slab_test_keeps_rays_on_a_box_plane`); before, the box was dropped
/// when the origin lay on a low plane. Such a ray lies outside the mesh by the padding, so no
/// hit was lost either way: tier A's four queries agree bit for bit with each other and find
/// what Embree finds (nothing, or the other mesh the ray meets on its plane), for every plane,
/// both zeros, and rays that run along the plane into and across the box.
#[test]
fn rays_on_a_mesh_box_plane_parallel_to_it() {
    use groove::geometry::TriMesh;
    // An octahedron (8 triangles, box [−1, 1]³) and a big quad crossing it at z = 0.1.
    let mut positions = vec![
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ];
    let mut indices = Vec::new();
    for (a, b) in [(0, 2), (2, 1), (1, 3), (3, 0)] {
        indices.push([a, b, 4]);
        indices.push([b, a, 5]);
    }
    let octa = TriMesh {
        positions: positions.clone(),
        normals: None,
        uvs: None,
        indices,
    };
    positions = [(-3.0, -3.0), (3.0, -3.0), (3.0, 3.0), (-3.0, 3.0)]
        .map(|(x, y)| Vec3::new(x, y, 0.1))
        .to_vec();
    let quad = TriMesh {
        positions,
        normals: None,
        uvs: None,
        indices: vec![[0, 1, 2], [0, 2, 3]],
    };
    let padded = |m: &TriMesh| {
        let (lo, hi) = m
            .positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| {
                (lo.min(p), hi.max(p))
            });
        let pad = 1e-4 * ((hi - lo).max_element() + lo.abs().max(hi.abs()).max_element());
        (lo - Vec3::splat(pad), hi + Vec3::splat(pad))
    };
    let boxes = [padded(&octa), padded(&quad)];
    let shapes = vec![
        Shape::from_mesh(octa, false, true).unwrap(),
        Shape::from_mesh(quad, false, true).unwrap(),
    ];
    let embree = Accel::build_tiered(&shapes, &[], &[], Tier::Embree).unwrap();
    let brute = Accel::build_tiered(&shapes, &[], &[], Tier::Brute).unwrap();
    let mut rng = Pcg32::new(18, 4);
    let mut all = Vec::new();
    for (lo, hi) in boxes {
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                for zero in [0.0f32, -0.0] {
                    for _ in 0..64 {
                        let mut u = || 2.0 * rng.next_f32() - 1.0;
                        // On the plane, anywhere over (and around) the box's face.
                        let mut o = Vec3::new(u(), u(), u()) * 4.0;
                        o[axis] = side;
                        let mut d = Vec3::new(u(), u(), u());
                        d[axis] = zero;
                        all.push(Ray::new(o, d.normalize_or(Vec3::X)));
                    }
                }
            }
        }
    }
    sixteen_consistent("mesh box planes", &brute, &all);
    let (mut hits, mut start) = (0, 0);
    while start < all.len() {
        // Full packets and partial ones (8, 7, 6 rays).
        let lanes = &all[start..(start + 8 - start % 3).min(all.len())];
        start += lanes.len();
        let got_all = self_consistent(&brute, lanes, false);
        for (ray, got) in lanes.iter().zip(got_all) {
            let want = embree.intersect(ray);
            assert!(ray.d.to_array().contains(&0.0), "{ray:?}");
            assert_eq!(
                want.map(|h| (h.geom, h.prim)),
                got.map(|h| (h.geom, h.prim)),
                "ray {ray:?}: Embree {want:?}, tier A {got:?}"
            );
            if let (Some(w), Some(g)) = (want, got) {
                assert!((w.t - g.t).abs() <= 1e-5 * w.t.max(1.0), "{w:?} {g:?}");
                hits += 1;
            }
        }
    }
    // The quad's padded planes z = 0.1 ± pad lie inside the octahedron's box: rays there meet
    // the octahedron, and rays on the octahedron's planes x, y = ±(1 + pad) meet the quad.
    assert!(hits > 100, "{hits} hits");
}

/// Tier A's 16-ray packets equal its 8-ray packets and single rays bit for bit on hostile rays,
/// over the bench scenes, a random primitive set and the Cornell box: directions along the axes
/// (the other components +0 or −0) from origins on the planes of the shapes' bounding boxes,
/// subnormal and huge components, tmin = tmax, tmin = −0, tmax = ∞, origins at ±∞ and NaN in
/// any field.
#[test]
fn sixteen_ray_packets_on_hostile_rays() {
    note_width("hostile rays");
    let specials = [
        0.0f32,
        -0.0,
        1.0,
        -1.0,
        1e-40,
        -1e-40,
        f32::MIN_POSITIVE,
        3e38,
        -3e38,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];
    let mut scenes = vec![
        (
            "metal_plastic".to_string(),
            load_file("scenes/bench/metal_plastic.xml"),
        ),
        ("random set".to_string(), random_set(7, 12)),
    ];
    let cbox = groove::load::load_scene(&crate::common::shared_cbox(), &Default::default())
        .unwrap_or_else(|e| panic!("{e}"));
    scenes.push(("cbox".to_string(), cbox));
    for (name, loaded) in &scenes {
        let brute = Accel::build_tiered(loaded.scene.shapes(), &[], &[], Tier::Brute).unwrap();
        let (c, r) = loaded.scene.bsphere();
        let mut rng = Pcg32::new(21, 5);
        let mut all = Vec::new();
        // The planes of every shape's box (from tier A's own hits: the points where rays from
        // outside enter), as origins of axis-parallel rays.
        let mut planes = Vec::new();
        for _ in 0..64 {
            let mut u = || 2.0 * rng.next_f32() - 1.0;
            let o = c + Vec3::new(u(), u(), u()).normalize_or(Vec3::Z) * 2.0 * r;
            let ray = Ray::new(o, (c + Vec3::new(u(), u(), u()) * 0.5 * r - o).normalize());
            if let Some(h) = brute.intersect(&ray) {
                planes.push(ray.at(h.t));
            }
        }
        for (k, p) in planes.iter().enumerate() {
            for axis in 0..3 {
                for sign in [1.0f32, -1.0] {
                    for zero in [0.0f32, -0.0] {
                        let mut d = Vec3::splat(zero);
                        d[axis] = sign;
                        let mut o = *p;
                        // Every other ray starts a little back along its axis.
                        if k % 2 == 1 {
                            o[axis] -= sign * 0.25 * r;
                        }
                        all.push(Ray::new(o, d));
                    }
                }
            }
        }
        // Special values in one field at a time, over ordinary rays.
        for k in 0..2048 {
            let mut u = || 2.0 * rng.next_f32() - 1.0;
            let o = c + Vec3::new(u(), u(), u()) * 1.5 * r;
            let mut ray = Ray::new(o, Vec3::new(u(), u(), u()).normalize_or(Vec3::X));
            let x = specials[k % specials.len()];
            match (k / specials.len()) % 9 {
                f @ 0..=2 => ray.o[f] = x,
                f @ 3..=5 => ray.d[f - 3] = x,
                6 => ray.tmin = x,
                7 => ray.tmax = x,
                _ => {
                    // tmin = tmax at the ray's hit (or at x).
                    let t = brute.intersect(&ray).map_or(x, |h| h.t);
                    (ray.tmin, ray.tmax) = (t, t);
                }
            }
            all.push(ray);
        }
        sixteen_consistent(name, &brute, &all);
    }
}

/// The packets test the meshes smallest first and cull a row by the nearest hit so far; neither
/// may change the answer of the tie rule (the lower shape index at equal t) or drop a lane's
/// hit. Three quads: shape 0 large at z = 0, shape 1 small at z = 0 over its middle (tested
/// first, equal t, higher key: shape 0 must win), shape 2 smaller at z = 0.5 (tested first,
/// nearer). Rays straight down from z = 1 meet the planes at t = 1 and 0.5 exactly. Packets
/// of 16 and 8 rays (all over the tie, all over shape 2, and mixed with misses) and single rays
/// must report the expected shape and t, and occlusion must follow.
#[test]
fn packets_keep_the_tie_rule_across_meshes_tested_smallest_first() {
    use groove::geometry::TriMesh;
    let quad = |x0: f32, x1: f32, z: f32| {
        let positions = [(x0, x0), (x1, x0), (x1, x1), (x0, x1)]
            .map(|(x, y)| Vec3::new(x, y, z))
            .to_vec();
        let m = TriMesh {
            positions,
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2], [0, 2, 3]],
        };
        Shape::from_mesh(m, false, true).unwrap()
    };
    let shapes = vec![
        quad(-3.0, 3.0, 0.0),
        quad(-0.5, 0.5, 0.0),
        quad(0.2, 0.4, 0.5),
    ];
    let brute = Accel::build_tiered(&shapes, &[], &[], Tier::Brute).unwrap();
    // (x, y) of a ray's origin and what it must hit: (shape, t), or None.
    let expect = |x: f32, y: f32| -> Option<(u32, f32)> {
        let inside = |a: f32, b: f32| (a..=b).contains(&x) && (a..=b).contains(&y);
        if inside(0.2, 0.4) {
            Some((2, 0.5))
        } else if inside(-3.0, 3.0) {
            Some((0, 1.0))
        } else {
            None
        }
    };
    let down = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 1.0), Vec3::NEG_Z);
    // Away from every edge, so that the expectation is exact.
    let tie: Vec<(f32, f32)> = (0..16).map(|k| (-0.45 + 0.05 * k as f32, -0.1)).collect();
    let near: Vec<(f32, f32)> = (0..16)
        .map(|k| (0.21 + 0.01 * (k % 8) as f32, 0.25 + 0.1 * (k / 8) as f32))
        .collect();
    let mixed: Vec<(f32, f32)> = (0..16)
        .map(|k| match k % 4 {
            0 => (0.3, 0.3),
            1 => (-0.25, 0.1),
            2 => (2.0, -2.5),
            _ => (5.0 + k as f32, 0.0),
        })
        .collect();
    let one_hit: Vec<(f32, f32)> = (0..16)
        .map(|k| if k == 11 { (0.0, 0.0) } else { (9.0, 9.0) })
        .collect();
    for set in [tie, near, mixed, one_hit] {
        let rays: Vec<Ray> = set.iter().map(|&(x, y)| down(x, y)).collect();
        let want: Vec<_> = set.iter().map(|&(x, y)| expect(x, y)).collect();
        let check = |got: &Option<Hit>, k: usize, form: &str| {
            assert_eq!(
                got.map(|h| (h.geom, h.t)),
                want[k],
                "{form}: ray {:?}",
                rays[k]
            );
        };
        let mut wide = [None; 16];
        brute.intersect16(&rays, false, &mut wide);
        in_place_equal(&brute, &rays, false, &wide);
        let blocked = brute.occluded16(&rays);
        for (k, ray) in rays.iter().enumerate() {
            check(&wide[k], k, "16");
            check(&brute.intersect(ray), k, "one ray");
            assert_eq!(blocked >> k & 1 == 1, want[k].is_some(), "occluded16");
        }
        for (h, half) in rays.chunks(8).enumerate() {
            let hits = self_consistent(&brute, half, h == 0);
            for (i, got) in hits.iter().enumerate() {
                check(got, 8 * h + i, "8");
            }
        }
        sixteen_consistent("tie rule", &brute, &rays);
    }
}
