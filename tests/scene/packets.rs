//! Embree's 8-wide packets (`Accel::intersect8`, `Accel::occluded8`) give every lane the hit a
//! single ray gives, for every kind of surface groove hands to Embree: triangles, the user
//! geometries (sphere, disk, rectangle, exact box, cylinder), round curves (with their backface
//! filter) and instances of a shape group; for full and partial packets, coherent or not; and
//! on triangle meshes, packets and streams equal single rays bit for bit.

use glam::Vec3;
use groove::geometry::{Hit, Ray};
use groove::load::Loaded;
use groove::math::Pcg32;
use std::path::Path;

const GEOMETRY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/geometry");

fn scene() -> Loaded {
    let body = format!(
        r#"<shape type="obj"><string name="filename" value="{GEOMETRY}/octahedron.obj"/>
             <transform name="to_world"><scale value="0.7"/><translate x="-1.5"/></transform></shape>
           <shape type="sphere"><point name="center" x="0.2" y="0.1" z="1.1"/><float name="radius" value="0.35"/></shape>
           <shape type="disk"><transform name="to_world"><scale value="0.4"/><rotate x="1" angle="-60"/><translate y="1.3" z="0.4"/></transform></shape>
           <shape type="rectangle"><transform name="to_world"><scale x="0.5" y="0.3"/><translate y="-1.2"/></transform></shape>
           <shape type="cube"><transform name="to_world"><scale value="0.3"/><rotate x="1" angle="30"/><translate x="1.1" y="0.4"/></transform></shape>
           <shape type="cylinder"><float name="radius" value="0.2"/><transform name="to_world"><rotate x="1" angle="70"/><translate x="1.0" y="-1.0" z="-0.8"/></transform></shape>
           <shape type="linearcurve"><string name="filename" value="{GEOMETRY}/curves_linear.txt"/>
             <transform name="to_world"><translate z="-1.5"/></transform></shape>
           <shape type="shapegroup" id="g">
             <shape type="sphere"><float name="radius" value="0.3"/></shape>
             <shape type="obj"><string name="filename" value="{GEOMETRY}/quad.obj"/>
               <transform name="to_world"><scale value="0.4"/><translate x="0.5"/></transform></shape>
           </shape>
           <shape type="instance"><ref id="g"/><transform name="to_world"><translate x="-0.5" y="1.5" z="-0.5"/></transform></shape>
           <shape type="instance"><ref id="g"/><transform name="to_world"><rotate z="1" angle="45"/><translate x="0.3" y="-1.8" z="0.9"/></transform></shape>"#
    );
    let text =
        format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n");
    let doc = groove::scene::xml::parse::load_str(&text, Path::new("mem.xml"), &[]).unwrap();
    groove::load::instantiate(&doc, Path::new("mem.xml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Rays from a sphere of radius 4 toward points in the scene's box, and (every third) from
/// inside it; a few with a finite `tmax` so that some lanes stop short.
fn rays(rng: &mut Pcg32, n: usize) -> Vec<Ray> {
    let mut unit = || 2.0 * rng.next_f32() - 1.0;
    (0..n)
        .map(|k| {
            let o = if k % 3 == 0 {
                Vec3::new(unit(), unit(), unit()) * 1.5
            } else {
                Vec3::new(unit(), unit(), unit()).normalize_or(Vec3::Z) * 4.0
            };
            let target = Vec3::new(unit() * 1.8, unit() * 2.0, unit() * 1.6);
            let mut r = Ray::new(o, (target - o).normalize());
            if k % 5 == 0 {
                r.tmax = 3.0;
            }
            r
        })
        .collect()
}

fn same_hit(a: &Option<Hit>, b: &Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            // Embree's packet triangle test may round differently from the single-ray one.
            let close = |x: f32, y: f32, tol: f32| (x - y).abs() <= tol * x.abs().max(1.0);
            a.geom == b.geom
                && a.prim == b.prim
                && a.inst == b.inst
                && close(a.t, b.t, 1e-5)
                && close(a.u, b.u, 1e-4)
                && close(a.v, b.v, 1e-4)
        }
        _ => false,
    }
}

#[test]
fn every_lane_of_a_packet_gets_the_single_ray_hit() {
    let loaded = scene();
    let accel = loaded.scene.accel();
    let mut rng = Pcg32::new(7, 3);
    let all = rays(&mut rng, 8 * 4000);
    let (mut hits, mut instanced, mut mismatches) = (0, 0, Vec::new());
    for (c, chunk) in all.chunks(8).enumerate() {
        // Partial packets too: 8 lanes mostly, 1..7 every few chunks.
        let n = if c % 4 == 3 { 1 + c % 7 } else { 8 };
        let lanes = &chunk[..n];
        let mut got = [None; 8];
        accel.intersect8(lanes, c % 2 == 0, &mut got);
        let blocked = accel.occluded8(lanes);
        for (i, r) in lanes.iter().enumerate() {
            let want = accel.intersect(r);
            if !same_hit(&got[i], &want) {
                mismatches.push((c, i, got[i], want));
            }
            assert_eq!(
                blocked >> i & 1 == 1,
                accel.occluded(r),
                "packet {c} lane {i}: occlusion differs"
            );
            hits += want.is_some() as usize;
            instanced += want.is_some_and(|h| h.inst != groove::geometry::NO_INSTANCE) as usize;
        }
        assert!(
            got[n..].iter().all(Option::is_none),
            "lanes past n stay empty"
        );
        assert_eq!(u32::from(blocked) >> n, 0, "lanes past n are not blocked");
    }
    // A ray grazing a triangle edge may go either way between the two traversals.
    assert!(
        mismatches.len() <= 2,
        "{} of {} lanes differ, e.g. {:?}",
        mismatches.len(),
        all.len(),
        &mismatches[..mismatches.len().min(3)]
    );
    // The scene is hit, instances included, so the comparison has content.
    assert!(hits > all.len() / 8, "{hits} hits");
    assert!(instanced > 100, "{instanced} instanced hits");
}

/// The lane counters of `groove bench --rays` on a made-up log: 8 paths of lengths 1..=8, the
/// even ones' first bounce hitting the sphere (a second material kind beside the misses).
#[test]
fn lane_stats_count_alive_lanes_and_material_kinds_per_depth() {
    use groove::integrator::LoggedRay;
    let loaded = scene();
    let miss = Ray::new(Vec3::new(0.0, 0.0, 10.0), Vec3::Z);
    let sphere = Ray::new(Vec3::new(0.2, 0.1, 3.0), -Vec3::Z);
    assert!(loaded.scene.accel().intersect(&miss).is_none());
    assert!(loaded.scene.accel().intersect(&sphere).is_some());
    let mut log = Vec::new();
    for len in 1..=8usize {
        for d in 0..len {
            let ray = if d == 1 && len % 2 == 0 { sphere } else { miss };
            log.push(LoggedRay {
                ray,
                shadow: false,
                camera: d == 0,
            });
            // Shadow rays in between do not count as path vertices.
            log.push(LoggedRay {
                ray: sphere,
                shadow: true,
                camera: false,
            });
        }
    }
    let stats = groove::bench::ceiling::lanes(&loaded.scene, &log);
    assert_eq!(stats.len(), 8);
    for (d, s) in stats.iter().enumerate() {
        assert_eq!(s.depth as usize, d);
        assert_eq!(s.packets, 1);
        // Paths of length > d are alive at depth d: 8 − d of them.
        assert_eq!(s.active_fraction, (8 - d) as f64 / 8.0);
        // At depth 1 the even-length paths hit the sphere, the odd ones miss.
        let kinds = if d == 1 { 2.0 } else { 1.0 };
        assert_eq!(s.distinct_materials, kinds, "depth {d}");
    }
}

/// The stream renderer's image equals the scalar renderer's only if every grouped query gives
/// the single ray's hit to the bit: on a scene of triangle meshes (a UV sphere, an octahedron,
/// a quad and the same sphere twice in one instanced group), 8-wide packets (coherent or not,
/// full and partial) and streams (`Accel::intersect_stream`/`occluded_stream`, coherent or
/// not, of 1 to 1,024 rays) equal `rtcIntersect1`/`rtcOccluded1` exactly: geometry, primitive,
/// t, u and v bits, instance. No grazing-edge tolerance: the single-ray and the packet/stream
/// triangle tests are the same arithmetic per lane.
#[test]
fn packet_and_stream_hits_on_meshes_are_the_single_ray_hits_bit_for_bit() {
    let body = format!(
        r#"<shape type="obj"><string name="filename" value="{GEOMETRY}/ball.obj"/>
             <transform name="to_world"><scale value="0.9"/><translate x="0.3" y="0.2" z="0.4"/></transform></shape>
           <shape type="obj"><string name="filename" value="{GEOMETRY}/octahedron.obj"/>
             <transform name="to_world"><scale value="0.7"/><translate x="-1.5"/></transform></shape>
           <shape type="obj"><string name="filename" value="{GEOMETRY}/quad.obj"/>
             <transform name="to_world"><scale value="3"/><rotate x="1" angle="80"/><translate y="-1.3"/></transform></shape>
           <shape type="shapegroup" id="g">
             <shape type="obj"><string name="filename" value="{GEOMETRY}/ball.obj"/>
               <transform name="to_world"><scale value="0.3"/></transform></shape>
           </shape>
           <shape type="instance"><ref id="g"/><transform name="to_world"><translate x="1.2" y="1.1" z="-0.6"/></transform></shape>
           <shape type="instance"><ref id="g"/><transform name="to_world"><translate x="-0.9" y="-1.0" z="1.0"/></transform></shape>"#
    );
    let text =
        format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n");
    let doc = groove::scene::xml::parse::load_str(&text, Path::new("mem.xml"), &[]).unwrap();
    let loaded =
        groove::load::instantiate(&doc, Path::new("mem.xml")).unwrap_or_else(|e| panic!("{e}"));
    let accel = loaded.scene.accel();
    let mut rng = Pcg32::new(19, 5);
    let all = rays(&mut rng, 8 * 3000);
    use crate::tier_a::bits;
    let single: Vec<Option<Hit>> = all.iter().map(|r| accel.intersect(r)).collect();
    let blocked: Vec<bool> = all.iter().map(|r| accel.occluded(r)).collect();
    // Packets.
    for (c, chunk) in all.chunks(8).enumerate() {
        let n = if c % 4 == 3 { 1 + c % 7 } else { 8 };
        let mut got = [None; 8];
        accel.intersect8(&chunk[..n], c % 2 == 0, &mut got);
        let occ = accel.occluded8(&chunk[..n]);
        for (i, g) in got.iter().enumerate().take(n) {
            let k = 8 * c + i;
            assert_eq!(bits(g), bits(&single[k]), "packet {c} lane {i}");
            assert_eq!(
                occ >> i & 1 == 1,
                blocked[k],
                "packet {c} lane {i}: occlusion"
            );
        }
    }
    // Streams of several lengths, both flags.
    let mut buf = groove::accel::RayBuf::default();
    let mut start = 0;
    for (s, len) in [1usize, 7, 8, 9, 31, 32, 33, 100, 1024, 5000]
        .into_iter()
        .cycle()
        .enumerate()
    {
        if start >= all.len() {
            break;
        }
        let part = &all[start..(start + len).min(all.len())];
        let coherent = s % 2 == 1;
        let mut seen = 0;
        accel.intersect_stream(part.iter(), coherent, &mut buf, |k, h| {
            assert_eq!(
                bits(&h.get()),
                bits(&single[start + k]),
                "stream {s} ray {k}"
            );
            seen += 1;
        });
        accel.occluded_stream(part.iter(), coherent, &mut buf, |k, b| {
            assert_eq!(b, blocked[start + k], "stream {s} ray {k}: occlusion");
            seen += 1;
        });
        assert_eq!(seen, 2 * part.len());
        start += part.len();
    }
    // The stream renderer's forms: packets read through an index map and written through a
    // callback (`Accel::intersect8_with`), and streams filled in a step of their own from
    // iterators of unknown length (`RayBuf::fill`: an upper bound, as the shadow stage's
    // filter gives, or none, which takes the slow path past the buffer's slots), then traced
    // (`Accel::intersect_filled`, `Accel::occluded_filled`).
    // One buffer for every packet: its packet is kept from query to query (full packets and
    // partial ones after them, whose lanes past `n` held the last packet's rays).
    let order: Vec<usize> = (0..all.len()).map(|k| (k * 7919) % all.len()).collect();
    let mut pbuf = groove::accel::RayBuf::default();
    for (c, ids) in order.chunks(8).enumerate() {
        let n = if c % 4 == 3 { 1 + c % 7 } else { ids.len() };
        let mut seen = 0;
        accel.intersect8_with(
            &mut pbuf,
            n,
            c % 2 == 0,
            |k| &all[ids[k]],
            |k, h| {
                assert_eq!(
                    bits(&h.get()),
                    bits(&single[ids[k]]),
                    "packet {c} lane {k} (with)"
                );
                seen += 1;
            },
        );
        assert_eq!(seen, n);
    }
    // Full packets of consecutive rays whose rows are stored in place
    // (`Accel::intersect8_rows`: the stream renderer's camera packets), instances mapped.
    use groove::accel::HitRow;
    for (c, (r, want)) in all.chunks_exact(8).zip(single.chunks_exact(8)).enumerate() {
        let mut rows = [HitRow([7; 8]); 8];
        accel.intersect8_rows(&mut pbuf, c % 2 == 0, r.try_into().unwrap(), &mut rows);
        for (k, (row, w)) in rows.iter().zip(want).enumerate() {
            assert_eq!(*row, HitRow::new(*w), "packet {c} lane {k} (rows)");
        }
    }
    let mut buf = groove::accel::RayBuf::default();
    for (s, len) in [3usize, 700, 1024, 2000, 5].into_iter().enumerate() {
        let part = &order[..len];
        let keep = |k: &&usize| **k % 3 != 1;
        let kept: Vec<usize> = part.iter().filter(keep).copied().collect();
        let n = if s % 2 == 0 {
            buf.fill(part.iter().filter(keep).map(|&k| &all[k]))
        } else {
            let mut it = kept.iter();
            buf.fill(std::iter::from_fn(|| it.next().map(|&k| &all[k])))
        };
        assert_eq!((n, buf.len()), (kept.len(), kept.len()), "stream {s}");
        let mut seen = 0;
        accel.intersect_filled(s % 2 == 1, &mut buf, |k, h| {
            assert_eq!(
                bits(&h.get()),
                bits(&single[kept[k]]),
                "filled stream {s} ray {k}"
            );
            seen += 1;
        });
        // In place (`Accel::intersect_filled_into`: the stream renderer's bounce rays): ray
        // `k`'s row at `kept[k]`, instances mapped; the rows of the rays left out kept.
        buf.fill(kept.iter().map(|&k| &all[k]));
        let ids: Vec<u32> = kept.iter().map(|&k| k as u32).collect();
        let mut rows = vec![HitRow([7; 8]); all.len()];
        accel.intersect_filled_into(s % 2 == 1, &mut buf, &ids, &mut rows);
        let mut stored = vec![false; all.len()];
        for &k in &kept {
            stored[k] = true;
        }
        for (j, row) in rows.iter().enumerate() {
            let want = if stored[j] {
                HitRow::new(single[j])
            } else {
                HitRow([7; 8])
            };
            assert_eq!(*row, want, "filled stream {s} row {j} (in place)");
        }
        // The query changed tfar: fill again before the occlusion query.
        buf.fill(kept.iter().map(|&k| &all[k]));
        accel.occluded_filled(false, &mut buf, |k, b| {
            assert_eq!(b, blocked[kept[k]], "filled stream {s} ray {k}: occlusion");
            seen += 1;
        });
        assert_eq!(seen, 2 * kept.len());
    }
    let hits = single.iter().flatten().count();
    let instanced = single
        .iter()
        .flatten()
        .filter(|h| h.inst != groove::geometry::NO_INSTANCE)
        .count();
    assert!(hits > all.len() / 4, "{hits} hits of {}", all.len());
    assert!(instanced > 200, "{instanced} instanced hits");
}
