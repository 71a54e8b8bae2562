//! Unit tests of the film: filters (Mitsuba's values are quoted as Python printed them), block
//! splats and merges, development, extra channels.
#![allow(clippy::excessive_precision)]

use super::*;
use crate::math::Pcg32;

fn desc(w: u32, h: u32, filter: Filter) -> FilmDesc {
    FilmDesc {
        width: w,
        height: h,
        crop_offset: (0, 0),
        crop_size: (w, h),
        filter,
        second_moments: true,
    }
}

#[test]
fn gaussian_matches_mitsuba() {
    // GaussianFilter.eval / eval_discretized from Mitsuba 3.9.1 scalar_rgb (stddev 0.5).
    let g = Filter::default();
    assert_eq!(g.radius(), 2.0);
    for (x, m) in [
        (0.0, 0.999247133731842),
        (0.3, 0.8350478410720825),
        (1.0, 0.13496048748493195),
    ] {
        assert!((g.eval(x) - m).abs() < 2e-6, "eval({x}) = {}", g.eval(x));
    }
    let t = FilterTable::new(&g);
    for (x, m) in [
        (0.0, 0.999247133731842),
        (0.3, 0.8749833106994629),
        (1.0, 0.15326131880283356),
        (1.99, 0.00022078714391682297),
    ] {
        assert!((t.eval(x) - m).abs() < 1e-5, "table({x}) = {}", t.eval(x));
    }
    // Near the cut-off Mitsuba's f32 polynomial cancels to ~1e-5 absolute; we evaluate in f64.
    assert!((g.eval(1.99) - 2.9737495424342342e-05).abs() < 1e-5);
    assert!(g.eval(2.0).abs() < 1e-5);
    assert_eq!(g.eval(2.5), 0.0);
    assert_eq!(Filter::Tent { radius: 1.0 }.eval(0.25), 0.75);
    assert_eq!(Filter::Box.eval(0.49), 1.0);
    assert_eq!(Filter::Box.eval(0.5), 0.0);
    assert_eq!(Filter::Box.eval(-0.5), 1.0);
}

/// `FilterTable::eval8` equals `FilterTable::eval` lane by lane: on bin edges and their
/// neighbours, ±0, the table's end and past it, huge values, ±∞, NaN and random offsets, for
/// filters of several radii (a tiny radius makes the scale huge, so products overflow).
#[cfg(target_arch = "x86_64")]
#[test]
fn filter_table_eval8_equals_eval() {
    let Some(avx) = crate::lane::Avx2::detect() else {
        eprintln!("no AVX2: eval8 not tested");
        return;
    };
    let mut rng = Pcg32::new(5, 9);
    for filter in [
        Filter::gaussian(0.5),
        Filter::gaussian(1.0),
        Filter::Tent { radius: 1.0 },
        Filter::Tent { radius: 3.5 },
        Filter::Tent { radius: 1e-30 },
        Filter::Gaussian {
            stddev: f32::NAN,
            radius: f32::NAN,
        },
    ] {
        let t = FilterTable::new(&filter);
        let mut xs = vec![
            0.0f32,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
            -f32::MAX,
            1e-45,
            3e9,
            -3e9,
        ];
        let r = filter.radius();
        for i in 0..=40 {
            let x = if r.is_finite() {
                r * i as f32 / 31.0
            } else {
                i as f32
            };
            for x in [x, x.next_up(), x.next_down()] {
                xs.extend([x, -x]);
            }
        }
        for _ in 0..4000 {
            xs.push((rng.next_f32() - 0.5) * 6.0);
        }
        for c in xs.chunks(8) {
            let a: [f32; 8] = core::array::from_fn(|k| c[k % c.len()]);
            let got = avx.run(|| t.eval8(avx, avx.load(&a)).to_array());
            for (g, &x) in got.iter().zip(&a) {
                assert_eq!(g.to_bits(), t.eval(x).to_bits(), "{filter:?} at {x:e}");
            }
        }
    }
}

/// The footprint tables of `Block::splat_lanes` visit every pixel of every footprint of up to
/// 8×8 pixels exactly once, in their first nx·ny entries.
#[test]
fn footprint_tables_cover_each_pixel_once() {
    for nx in 1..=8 {
        for ny in 1..=8 {
            let mut seen = [[0u32; 8]; 8];
            for p in 0..nx * ny {
                let (i, j) = (FOOT_I[nx - 1][p / 8][p % 8], FOOT_J[nx - 1][p / 8][p % 8]);
                assert!((0..nx as i32).contains(&i) && (0..ny as i32).contains(&j));
                seen[j as usize][i as usize] += 1;
            }
            for (j, row) in seen.iter().enumerate() {
                for (i, &n) in row.iter().enumerate() {
                    assert_eq!(n, (i < nx && j < ny) as u32, "{nx}×{ny}: ({i}, {j})");
                }
            }
        }
    }
}

/// `Block::footprint_lanes` equals `Block::footprint` (the pixels, cut to the storage, and the
/// offsets' bits) on blocks at several origins and filters, for positions on and next to pixel
/// edges and centres, negative ones, ones far off the block, near and past 2²³ (where the lanes
/// form hands over to the scalar one) and random ones.
#[cfg(target_arch = "x86_64")]
#[test]
fn footprint_lanes_equals_footprint() {
    let Some(avx) = crate::lane::Avx2::detect() else {
        eprintln!("no AVX2: footprint_lanes not tested");
        return;
    };
    let key = |f: Option<Footprint>| {
        f.map(|f| {
            (
                f.x_lo,
                f.y_lo,
                f.nx,
                f.ny,
                f.rel_x.to_bits(),
                f.rel_y.to_bits(),
            )
        })
    };
    let mut xs = vec![
        0.0f32, -0.0, 0.5, 1.0, 2.5, 3.0, -1.0, -2.5, 7.25, 1e4, -1e4,
    ];
    for b in [
        8_388_606.0f32,
        8_388_608.0,
        16_777_216.0,
        3e9,
        1e30,
        f32::MAX,
    ] {
        for x in [
            b,
            -b,
            f32::from_bits(b.to_bits() - 1),
            f32::from_bits(b.to_bits() + 1),
        ] {
            xs.push(x);
        }
    }
    for x in xs.clone() {
        for d in [-1, 1] {
            xs.push(f32::from_bits((x.to_bits() as i32 + d) as u32));
        }
    }
    let mut rng = Pcg32::new(7, 11);
    for _ in 0..2000 {
        xs.push((rng.next_f32() - 0.3) * 40.0);
    }
    let filters = [
        Filter::gaussian(0.5),
        Filter::gaussian(1.3),
        Filter::Tent { radius: 1.0 },
        Filter::Tent { radius: 2.75 },
    ];
    let mut checked = 0;
    for filter in filters {
        for (x0, y0) in [(0, 0), (5, 3), (17, 40)] {
            let b = Block::new(&desc(64, 64, filter), x0, y0, 9, 7);
            for (k, &x) in xs.iter().enumerate() {
                let y = xs[(k * 7 + 3) % xs.len()];
                let pos = Vec2::new(x, y);
                let lanes = avx.run(
                    #[inline(always)]
                    || b.footprint_lanes(avx, pos),
                );
                let hit = lanes.is_some();
                assert_eq!(
                    key(lanes),
                    key(b.footprint(pos)),
                    "{filter:?} ({x0}, {y0}) at {pos}"
                );
                checked += hit as u32;
            }
        }
    }
    assert!(checked > 1000, "only {checked} positions reached a block");
}

/// The sums are stored biased (`sum::LOW_BIAS`) and read unbiased: an empty pixel reads 0
/// and gives the zero `RawPixel`, and raw sums go in and come out unchanged, extremes included.
#[test]
fn biased_sums_read_and_convert_unbiased() {
    let a = Acc::default();
    assert_eq!((a.w(), a.w2(), a.wv(0), a.wv2(2)), (0, 0, 0, 0));
    assert_eq!(RawPixel::from(&a), RawPixel::default());
    let r = RawPixel {
        sums: [
            i128::MIN,
            -1,
            1 << 63,
            i128::MAX,
            0,
            (1 << 63) - 1,
            1,
            1 << 64,
        ],
        bad: 5,
    };
    let a = Acc::from(&r);
    assert_eq!(RawPixel::from(&a), r);
    // The layout: low words biased, high words as they are, sum i in slot `SLOT[i]` (the first
    // moments and Σw in slots 0 to 3); the size that of eight `i128`s and the flags.
    assert_eq!(SLOT, [0, 1, 2, 4, 5, 6, 3, 7]);
    for (i, &v) in r.sums.iter().enumerate() {
        assert_eq!(a.words[0][SLOT[i]], v as u64 ^ 1 << 63, "sum {i}");
        assert_eq!(a.words[1][SLOT[i]], (v >> 64) as u64, "sum {i}");
        assert_eq!(a.sum(i), v);
    }
    assert_eq!(PIXEL_BYTES, 144);
    assert_eq!(
        (a.wv(0), a.wv2(0), a.w(), a.w2()),
        (i128::MIN, i128::MAX, 1, 1 << 64)
    );
    let mut f = Film::new(desc(1, 1, Filter::Box));
    f.add_raw(0, &r, &[]);
    f.add_raw(0, &r, &[]);
    let twice = f.raw_pixel(0);
    for (i, (&t, &s)) in twice.sums.iter().zip(&r.sums).enumerate() {
        let want = if (3..8).contains(&i) {
            let mut x = s;
            sum::add_unsigned(&mut x, s);
            x
        } else {
            s.wrapping_add(s)
        };
        assert_eq!(t, want, "sum {i}");
    }
}

#[test]
fn block_matches_mitsuba_imageblock() {
    // Raw block contents (border included) from Mitsuba 3.9.1's ImageBlock::put, see the file.
    let text = include_str!("../tests/data/output/mitsuba_imageblock.txt");
    let mut samples = Vec::new();
    for line in text.lines().filter_map(|l| l.strip_prefix("# sample ")) {
        let f: Vec<f32> = line.split(' ').map(|t| t.parse().unwrap()).collect();
        samples.push((Vec2::new(f[0], f[1]), Spectrum::new(f[2], f[3], f[4])));
    }
    assert_eq!(samples.len(), 5);
    for (name, filter) in [
        ("gaussian", Filter::default()),
        ("tent", Filter::Tent { radius: 1.0 }),
    ] {
        let mut b = Block::new(&desc(16, 16, filter), 3, 2, 8, 6);
        for &(p, v) in &samples {
            b.put(p, v);
        }
        let mut expected = vec![[0.0f32; 4]; b.data.len()];
        for line in text.lines().filter(|l| l.starts_with(name)) {
            let t: Vec<&str> = line.split(' ').collect();
            let (y, x): (usize, usize) = (t[1].parse().unwrap(), t[2].parse().unwrap());
            let v: Vec<f32> = t[3..7].iter().map(|s| s.parse().unwrap()).collect();
            expected[y * b.sw as usize + x] = [v[0], v[1], v[2], v[3]];
        }
        for (k, (a, e)) in b.data.iter().zip(&expected).enumerate() {
            let got = [a.wv(0), a.wv(1), a.wv(2), a.w()].map(|x| sum::to_f64(x) as f32);
            for c in 0..4 {
                // Mitsuba's f32 polynomial differs from ours by up to ~1e-5 near the cut-off.
                assert!(
                    (got[c] - e[c]).abs() < 2e-5 * e[c].abs().max(1.0),
                    "{name} pixel {k} channel {c}: {} vs Mitsuba {}",
                    got[c],
                    e[c]
                );
            }
        }
    }
}

#[test]
fn box_filter_is_plain_average() {
    let d = desc(4, 3, Filter::Box);
    let mut film = Film::new(d.clone());
    let mut b = Block::new(&d, 0, 0, 4, 3);
    let mut rng = Pcg32::new(7, 1);
    let mut sums = [[0.0f64; 3]; 12];
    let mut n = [0u32; 12];
    for _ in 0..2000 {
        let p = Vec2::new(rng.next_f32() * 4.0, rng.next_f32() * 3.0);
        let v = Spectrum::new(rng.next_f32(), 2.0 * rng.next_f32(), 1.0);
        b.put(p, v);
        let k = p.y as usize * 4 + p.x as usize;
        n[k] += 1;
        for c in 0..3 {
            sums[k][c] += v[c] as f64;
        }
    }
    film.merge(&b);
    let img = film.develop();
    for k in 0..12 {
        let got = img.data[k];
        assert_eq!(sum::to_f64(film.data[k].w()), n[k] as f64);
        for c in 0..3 {
            assert!((got[c] as f64 - sums[k][c] / n[k] as f64).abs() < 1e-5);
        }
    }
}

#[test]
fn weights_of_interior_pixels_count_the_samples() {
    // A regular grid of samples: every interior pixel sees the same footprint pattern, and
    // its summed weight is the samples per pixel times the (discrete) filter integral.
    for filter in [Filter::Box, Filter::Tent { radius: 1.0 }, Filter::default()] {
        let d = desc(12, 12, filter);
        let mut b = Block::new(&d, 0, 0, 12, 12);
        let k = 8;
        for y in 0..12 * k {
            for x in 0..12 * k {
                let p = Vec2::new((x as f32 + 0.5) / k as f32, (y as f32 + 0.5) / k as f32);
                b.put(p, Spectrum::ONE);
            }
        }
        let mut film = Film::new(d);
        film.merge(&b);
        let t = FilterTable::new(&filter);
        let mut integral1 = 0.0f32;
        for s in 0..k * 8 {
            integral1 += t.eval((s as f32 + 0.5) / k as f32 - 4.0);
        }
        let expect = if filter.is_box() {
            (k * k) as f32
        } else {
            integral1 * integral1
        };
        for y in 3..9 {
            for x in 3..9 {
                let w = sum::to_f64(film.data[y * 12 + x].w()) as f32;
                assert!(
                    (w - expect).abs() < 1e-3 * expect,
                    "{filter:?}: {w} vs {expect}"
                );
            }
        }
        let img = film.develop();
        assert!(img.data.iter().all(|p| (p[0] - 1.0).abs() < 1e-6));
    }
}

#[test]
fn gaussian_constant_develops_to_constant_everywhere() {
    let d = FilmDesc {
        width: 9,
        height: 7,
        crop_offset: (1, 2),
        crop_size: (7, 4),
        filter: Filter::default(),
        second_moments: true,
    };
    let mut film = Film::new(d.clone());
    let mut b = Block::new(&d, 1, 2, 7, 4);
    let mut rng = Pcg32::new(3, 5);
    for _ in 0..500 {
        let p = Vec2::new(1.0 + 7.0 * rng.next_f32(), 2.0 + 4.0 * rng.next_f32());
        b.put(p, Spectrum::new(0.25, 0.5, 3.0));
    }
    film.merge(&b);
    let img = film.develop();
    assert_eq!((img.width, img.height), (7, 4));
    for p in &img.data {
        assert!((p[0] - 0.25).abs() < 1e-6 && (p[1] - 0.5).abs() < 1e-6);
        assert!((p[2] - 3.0).abs() < 1e-5);
    }
}

fn render(d: &FilmDesc, tiles: &[(u32, u32, u32, u32)], spp: u32) -> (Film, Image) {
    let mut film = Film::new(d.clone());
    let mut block = Block::new(d, 0, 0, 1, 1);
    for &(x0, y0, w, h) in tiles {
        block.clear(x0, y0, w, h);
        for y in y0..y0 + h {
            for x in x0..x0 + w {
                let mut rng = Pcg32::new(((y * 1000 + x) as u64) << 8, 11);
                for _ in 0..spp {
                    let p = Vec2::new(x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                    let v = Spectrum::new(rng.next_f32(), (x as f32) * 0.1, (y as f32) * 0.2);
                    block.put(p, v);
                }
            }
        }
        film.merge(&block);
    }
    let img = film.develop();
    (film, img)
}

#[test]
fn partition_does_not_change_the_result() {
    // Exact sums: any partition into blocks, and any merge order, gives the same bits.
    for filter in [Filter::Box, Filter::Tent { radius: 1.0 }, Filter::default()] {
        let d = desc(10, 7, filter);
        let (f1, one) = render(&d, &[(0, 0, 10, 7)], 4);
        let tiles: Vec<_> = (0..7).flat_map(|y| [(0, y, 3, 1), (3, y, 7, 1)]).collect();
        let (fm, many) = render(&d, &tiles, 4);
        assert_eq!(one, many, "{filter:?}");
        assert_eq!(f1.data, fm.data, "{filter:?}");
        let rev: Vec<_> = tiles.iter().rev().copied().collect();
        let (_, back) = render(&d, &rev, 4);
        assert_eq!(one, back, "{filter:?}");
        // Non-square crop with a block larger than the crop at the edge.
        let mut dc = d.clone();
        dc.crop_offset = (2, 1);
        dc.crop_size = (5, 5);
        let (_, a) = render(&dc, &[(2, 1, 5, 5)], 3);
        let (_, b) = render(&dc, &[(2, 1, 4, 2), (6, 1, 1, 2), (2, 3, 5, 3)], 3);
        assert_eq!(a, b, "{filter:?}");
    }
}

#[test]
fn a_crop_with_its_border_equals_the_full_film() {
    // Sampling the crop plus a border of ceil(radius) pixels gives the crop's pixels of the
    // full film bit for bit.
    for filter in [Filter::Box, Filter::Tent { radius: 1.0 }, Filter::default()] {
        let d = desc(11, 9, filter);
        let (_, full) = render(&d, &[(0, 0, 11, 9)], 3);
        let b = filter.radius().ceil() as u32;
        let (x, y, w, h) = (3u32, 2u32, 5u32, 4u32);
        let mut dc = d.clone();
        dc.crop_offset = (x, y);
        dc.crop_size = (w, h);
        let (_, crop) = render(&dc, &[(x - b, y - b, w + 2 * b, h + 2 * b)], 3);
        for j in 0..h {
            for i in 0..w {
                assert_eq!(crop.get(i, j), full.get(x + i, y + j), "{filter:?} {i},{j}");
            }
        }
    }
}

#[test]
fn raw_sums_add_like_blocks() {
    let d = desc(6, 5, Filter::default());
    let (a, _) = render(&d, &[(0, 0, 6, 2)], 2);
    let (b, _) = render(&d, &[(0, 2, 6, 3)], 2);
    let (full, img) = render(&d, &[(0, 0, 6, 5)], 2);
    let mut m = Film::new(d.clone());
    for f in [&b, &a] {
        for i in 0..30 {
            m.add_raw(i, &f.raw_pixel(i), &[]);
        }
    }
    assert_eq!(m.data, full.data);
    assert_eq!(m.develop(), img);
}

#[test]
fn non_finite_values_show_in_the_developed_pixel() {
    let d = desc(4, 1, Filter::Box);
    let mut b = Block::new(&d, 0, 0, 4, 1);
    b.put(
        Vec2::new(0.5, 0.5),
        Spectrum::new(f32::INFINITY, f32::NAN, 1.0),
    );
    b.put(Vec2::new(1.5, 0.5), Spectrum::new(f32::INFINITY, 1.0, 1.0));
    b.put(
        Vec2::new(1.5, 0.5),
        Spectrum::new(f32::NEG_INFINITY, 1.0, 1.0),
    );
    b.put(
        Vec2::new(2.5, 0.5),
        Spectrum::new(f32::NEG_INFINITY, 2.0, 1.0),
    );
    let mut film = Film::new(d);
    film.merge(&b);
    let img = film.develop();
    assert_eq!(img.get(0, 0)[0], f32::INFINITY);
    assert!(img.get(0, 0)[1].is_nan());
    assert_eq!(img.get(0, 0)[2], 1.0);
    assert!(img.get(1, 0)[0].is_nan());
    assert_eq!(img.get(2, 0), [f32::NEG_INFINITY, 2.0, 1.0]);
    assert_eq!(img.get(3, 0), [0.0; 3]);
}

#[test]
fn variance_matches_for_iid_samples() {
    // Uniform values: σ² = 1/12. Box filter: exactly s²/n. Gaussian: within statistics.
    for filter in [Filter::Box, Filter::default()] {
        let d = desc(16, 16, filter);
        let mut b = Block::new(&d, 0, 0, 16, 16);
        let mut rng = Pcg32::new(1234, 9);
        let n = 64;
        let mut samples = vec![Vec::new(); 256];
        for y in 0..16u32 {
            for x in 0..16u32 {
                for _ in 0..n {
                    let p = Vec2::new(x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                    let v = rng.next_f32();
                    b.put(p, Spectrum::splat(v));
                    samples[(y * 16 + x) as usize].push(v as f64);
                }
            }
        }
        let mut film = Film::new(d);
        film.merge(&b);
        let var = film.develop_variance().unwrap();
        if filter.is_box() {
            for (k, s) in samples.iter().enumerate() {
                let m = s.iter().sum::<f64>() / n as f64;
                let s2 = s.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1) as f64;
                let got = var.data[k][0] as f64;
                assert!((got - s2 / n as f64).abs() < 1e-4 * s2 / n as f64);
            }
        }
        // Average over interior pixels: E[Var(μ)·W²/W₂] = σ², so compare σ² estimates.
        let mut sum = 0.0;
        let mut cnt = 0.0;
        for y in 2..14 {
            for x in 2..14 {
                let a = film.data[y * 16 + x];
                let w = sum::to_f64(a.w());
                let w2 = sum::to_f64(a.w2());
                sum += var.data[y * 16 + x][0] as f64 * w * w / w2;
                cnt += 1.0;
            }
        }
        let est = sum / cnt;
        let sigma2 = 1.0 / 12.0;
        // Var of the sample variance of uniforms ≈ (μ4 − σ⁴)/n_eff; μ4 = 1/80. Neighbouring
        // pixels share samples with the gaussian, so use the per-pixel n (conservative).
        let sd = ((1.0 / 80.0 - sigma2 * sigma2) / (n as f64 * cnt)).sqrt();
        let tol = if filter.is_box() {
            4.0 * sd
        } else {
            4.0 * sd * 4.0
        };
        assert!(
            (est - sigma2).abs() < tol,
            "{filter:?}: {est} vs {sigma2} ± {tol}"
        );
    }
}

/// A film without second moments develops the same image, bit for bit, as one with them
/// (blocks filled by `put`, merged), for the box and a Gaussian filter; its variance (and an
/// extra channel's) is an error, not zeros.
#[test]
fn film_without_second_moments_develops_the_same_image() {
    let mut rng = Pcg32::new(21, 9);
    for filter in [Filter::Box, Filter::default()] {
        let d = desc(12, 9, filter);
        let d1 = FilmDesc {
            second_moments: false,
            ..d.clone()
        };
        let (mut both, mut first) = (
            Film::with_channels(d.clone(), 1),
            Film::with_channels(d1.clone(), 1),
        );
        for (x0, y0) in [(0, 0), (6, 0), (0, 5), (6, 5)] {
            let (mut b, mut b1) = (Block::new(&d, x0, y0, 6, 5), Block::new(&d1, x0, y0, 6, 5));
            for _ in 0..600 {
                let p = Vec2::new(
                    x0 as f32 + 6.0 * rng.next_f32(),
                    y0 as f32 + 5.0 * rng.next_f32(),
                );
                let v = Spectrum::new(rng.next_f32(), 3.0 * rng.next_f32(), rng.next_f32() - 0.5);
                b.put(p, v);
                b1.put(p, v);
            }
            both.merge(&b);
            first.merge(&b1);
        }
        let (a, b) = (both.develop(), first.develop());
        assert!(a.data.iter().any(|p| p[0] != 0.0));
        let bits =
            |i: &Image| -> Vec<[u32; 3]> { i.data.iter().map(|p| p.map(f32::to_bits)).collect() };
        assert_eq!(bits(&a), bits(&b), "{filter:?}");
        assert!(both.has_second_moments() && !first.has_second_moments());
        assert!(both.develop_variance().is_ok());
        let e = first.develop_variance().unwrap_err().to_string();
        assert!(e.contains("second moments"), "{e}");
        assert!(first.develop_channel_variance(0).is_err());
    }
}

#[test]
fn variance_edge_cases_and_junk_input() {
    let d = desc(3, 1, Filter::Box);
    let mut film = Film::new(d.clone());
    let mut b = Block::new(&d, 0, 0, 3, 1);
    b.put(Vec2::new(0.5, 0.5), Spectrum::ONE);
    b.put(Vec2::new(f32::NAN, 0.5), Spectrum::ONE);
    b.put(Vec2::new(1e30, -1e30), Spectrum::ONE);
    b.put(Vec2::new(1.5, 0.5), Spectrum::ONE);
    b.put(Vec2::new(1.5, 0.5), Spectrum::ONE);
    film.merge(&b);
    let v = film.develop_variance().unwrap();
    assert_eq!(v.get(0, 0)[0], f32::INFINITY);
    assert_eq!(v.get(1, 0)[0], 0.0);
    assert_eq!(v.get(2, 0)[0], 0.0);
    assert_eq!(film.develop().get(2, 0), [0.0; 3]);
    // A crop window sticking out of the film is cut instead of panicking.
    let bad = FilmDesc {
        width: 4,
        height: 4,
        crop_offset: (3, 9),
        crop_size: (10, 10),
        filter: Filter::default(),
        second_moments: true,
    };
    let f = Film::new(bad);
    assert_eq!(f.develop().data.len(), 0);
    let mut g = Block::new(&desc(4, 4, Filter::default()), 0, 0, 4, 4);
    g.put(Vec2::new(-1e9, 3.0), Spectrum::ONE);
    g.put(Vec2::new(f32::INFINITY, 3.0), Spectrum::ONE);
}

#[test]
fn storage_index_matches_floor_and_bounds() {
    // The box splat's fast pixel lookup against floor(x) − origin ∈ [0, size).
    let mut rng = Pcg32::new(7, 3);
    for (origin, size) in [(-1i64, 18u32), (0, 1), (37, 34), (-3, 5), (8_000_000, 40)] {
        let exact = exact_bounds(origin, size);
        assert!(exact.is_some());
        let mut xs = vec![f32::MIN, -1e30, -0.0, 0.0, 1e30, f32::MAX];
        for k in origin - 2..origin + size as i64 + 2 {
            let k = k as f32;
            xs.extend([k, k.next_down(), k.next_up(), k + 0.5, k - 0.5]);
            xs.push(k + rng.next_f32());
        }
        for x in xs {
            let p = (crate::math::floor(x) as i64).saturating_sub(origin);
            let want = (p >= 0 && p < size as i64).then_some(p as usize);
            assert_eq!(
                storage_index(x, origin, size, exact),
                want,
                "{x} {origin} {size}"
            );
            assert_eq!(
                storage_index(x, origin, size, None),
                want,
                "{x} {origin} {size}"
            );
        }
    }
    assert!(exact_bounds(1 << 25, 4).is_none());
}

/// `Block::put8` and `Block::put` give the same sums, to the bit, as the scalar splat of each
/// sample, for every filter (footprints of up to 8 pixels a side laid out in lanes, up to 16
/// with weights one by one, wider ones by the scalar splat): runs of samples on one pixel
/// (short ones and whole chunks), positions on pixel edges and centres, outside the block and
/// non-finite, negative values, signed zeros, subnormals, values below the fixed-point grid's
/// exact range, values whose square is near the clamp or overflows and ±f32::MAX, into blocks
/// that start empty or with sums near their limits (saturation and wrapping); chunks
/// with a non-finite value take `put` (the non-finite flags). `Block::put8_finite` equals
/// `put` of the values with the non-finite ones zeroed, and counts them.
#[cfg(target_arch = "x86_64")]
#[test]
fn put8_equals_put_one_by_one() {
    let Some(avx) = crate::lane::Avx2::detect() else {
        eprintln!("no AVX2: put8 not tested");
        return;
    };
    let mut rng = Pcg32::new(11, 5);
    for filter in [
        Filter::Box,
        Filter::Tent { radius: 1.0 },
        Filter::gaussian(0.5),
        // Footprints of 7 or 8 pixels a side (in lanes), 8 or 9 (in lanes, or weights one by
        // one), 16 or 17 (one by one, or the scalar splat).
        Filter::Tent { radius: 3.5 },
        Filter::gaussian(1.0),
        Filter::gaussian(2.0),
        // A footprint wider than 16 pixels (`splat_lanes` hands it to the scalar splat).
        Filter::gaussian(5.0),
    ] {
        let d = desc(9, 7, filter);
        // Runs of samples on one pixel, as a renderer's samples of a pixel come in turn: of up
        // to 4 samples, and of 15 (whole chunks of 8 on one pixel).
        for run in [5, 16] {
            let mut samples = Vec::new();
            let mut pixel = (0, 0);
            for k in 0..4000u32 {
                if k % run < 2 {
                    pixel = (rng.next_u32() % 11, rng.next_u32() % 9);
                }
                let (x, y) = pixel;
                let u = match k % 7 {
                    0 => Vec2::new(1.0f32.next_down(), 0.0),
                    1 => Vec2::new(0.0, 1.0f32.next_down()),
                    // On pixel centres: footprints one pixel wider.
                    2 => Vec2::new(0.5, 0.5),
                    3 => Vec2::new(0.5, rng.next_f32()),
                    _ => Vec2::new(rng.next_f32(), rng.next_f32()),
                };
                let pos = Vec2::new(x as f32 - 1.0, y as f32 - 1.0) + u;
                let c = |r: &mut Pcg32| (r.next_f32() - 0.1) * 3.0;
                let v = match rng.next_u32() % 1000 {
                    0 => Spectrum::new(f32::NAN, 1.0, 0.5),
                    1 => Spectrum::new(0.25, f32::INFINITY, -f32::INFINITY),
                    2..=40 => Spectrum::new(3e19, 1e-30, -2e-7),
                    // Subnormal, below the grid's exact range (w·v² rounds), signed zeros,
                    // squares near and past the clamp at 2⁶².
                    41..=50 => Spectrum::new(1e-40, -1e-13, 2e-21),
                    51..=55 => Spectrum::new(-0.0, 2.1e9, -3e9),
                    56..=60 => Spectrum::new(-4e18, 0.0, 7e-12),
                    61..=90 => Spectrum::ZERO,
                    91..=100 => Spectrum::new(f32::MAX, -f32::MAX, 1.0),
                    _ => Spectrum::new(c(&mut rng), c(&mut rng), c(&mut rng)),
                };
                let pos = match rng.next_u32() % 200 {
                    0 => Vec2::new(f32::NAN, pos.y),
                    1 => Vec2::new(pos.x, f32::INFINITY),
                    _ => pos,
                };
                samples.push((pos, v));
            }
            // Blocks that start from sums near their limits (so that the saturating sums,
            // weights included, saturate and the wrapping ones wrap), or from zero.
            let start = |b: &mut Block, near: bool| {
                if near {
                    for (i, a) in b.data.iter_mut().enumerate().filter(|(i, _)| i % 3 != 1) {
                        let i = i as i128;
                        let sums = core::array::from_fn(|c| {
                            if c < 3 {
                                i128::MAX - (i << 62) - c as i128
                            } else {
                                i128::MAX - (i << 58) - (c as i128) * (1 << 60)
                            }
                        });
                        *a = Acc::from_sums(sums, a.bad);
                    }
                }
            };
            for ((x0, y0, w, h), near) in [
                ((0, 0, 9, 7), false),
                ((2, 3, 4, 2), false),
                ((8, 6, 1, 1), false),
                ((0, 0, 9, 7), true),
                ((2, 3, 4, 2), true),
            ] {
                let mut one = Block::new(&d, x0, y0, w, h);
                start(&mut one, near);
                // The scalar splat, the reference of `put` (which splats in lanes with AVX2)
                // and of `put8`.
                for &(p, v) in &samples {
                    one.splat::<false>(p, v, &[]);
                }
                let mut via_put = Block::new(&d, x0, y0, w, h);
                start(&mut via_put, near);
                for &(p, v) in &samples {
                    via_put.put(p, v);
                }
                assert!(
                    one.data == via_put.data,
                    "put, {filter:?} block {:?}",
                    (x0, y0, w, h)
                );
                let mut eight = Block::new(&d, x0, y0, w, h);
                start(&mut eight, near);
                for c in samples.chunks_exact(8) {
                    let pos: [Vec2; 8] = core::array::from_fn(|k| c[k].0);
                    let v: [Spectrum; 8] = core::array::from_fn(|k| c[k].1);
                    eight.put8(avx, &pos, &v);
                }
                // Some pixel has weight and no flag (under the other filters a footprint is
                // wide enough that every pixel may meet a non-finite sample, so only the
                // weight is asked there; the sums are compared whatever the flags).
                let wide = !filter.is_box();
                assert!(one.data.iter().any(|a| a.w() != 0 && (wide || a.bad == 0)));
                if near {
                    assert!(one.data.iter().any(|a| a.w() == i128::MAX));
                    assert!(one.data.iter().any(|a| a.wv(0) < 0));
                }
                assert!(
                    one.data == eight.data,
                    "{filter:?} block {:?}",
                    (x0, y0, w, h)
                );
                // `put8_finite`: `put` of the values with the non-finite ones zeroed, and their count.
                let (mut zeroed, mut bad) = (Block::new(&d, x0, y0, w, h), 0);
                start(&mut zeroed, near);
                for &(p, v) in &samples {
                    let finite = crate::spectrum::is_finite(v);
                    bad += !finite as u32;
                    zeroed.splat::<false>(p, if finite { v } else { Spectrum::ZERO }, &[]);
                }
                let (mut fin, mut counted) = (Block::new(&d, x0, y0, w, h), 0);
                start(&mut fin, near);
                for c in samples.chunks_exact(8) {
                    let pos: [Vec2; 8] = core::array::from_fn(|k| c[k].0);
                    let v: [Spectrum; 8] = core::array::from_fn(|k| c[k].1);
                    counted += fin.put8_finite(avx, &pos, &v);
                }
                assert!(bad > 0);
                assert_eq!(counted, bad);
                assert!(
                    zeroed.data == fin.data,
                    "put8_finite, {filter:?} block {:?}",
                    (x0, y0, w, h)
                );
                // Without second moments: the same first moments, weights and flags by every
                // path (`put`, `put8`, `put8_finite`).
                let d1 = FilmDesc {
                    second_moments: false,
                    ..d.clone()
                };
                let first = |b: &Block| -> Vec<_> {
                    b.data
                        .iter()
                        .map(|a| ([a.wv(0), a.wv(1), a.wv(2)], a.w(), a.bad))
                        .collect()
                };
                let (mut p1, mut e1, mut f1) = (
                    Block::new(&d1, x0, y0, w, h),
                    Block::new(&d1, x0, y0, w, h),
                    Block::new(&d1, x0, y0, w, h),
                );
                for b in [&mut p1, &mut e1, &mut f1] {
                    assert!(!b.second);
                    start(b, near);
                }
                for &(p, v) in &samples {
                    p1.put(p, v);
                }
                for c in samples.chunks_exact(8) {
                    let pos: [Vec2; 8] = core::array::from_fn(|k| c[k].0);
                    let v: [Spectrum; 8] = core::array::from_fn(|k| c[k].1);
                    e1.put8(avx, &pos, &v);
                    f1.put8_finite(avx, &pos, &v);
                }
                let what = |p: &str| format!("{p} without second moments, {filter:?} {x0},{y0}");
                assert!(first(&p1) == first(&one), "{}", what("put"));
                assert!(first(&e1) == first(&one), "{}", what("put8"));
                assert!(first(&f1) == first(&zeroed), "{}", what("put8_finite"));
            }
        }
    }
}

/// A merge's row add in lanes equals [`Acc::add`] pixel by pixel: signed sums that wrap,
/// weights and second moments that saturate at `i128::MAX` (alone or several at once), zeros,
/// and the flags; without second moments, on the first moments and Σw only.
#[cfg(target_arch = "x86_64")]
#[test]
fn merge_rows_in_lanes_equal_acc_add() {
    let Some(avx) = crate::lane::Avx2::detect() else {
        eprintln!("no AVX2: only the scalar add runs");
        return;
    };
    let mut rng = Pcg32::new(77, 5);
    let word = |rng: &mut Pcg32| {
        (rng.next_u32() as u128) << 96
            | (rng.next_u32() as u128) << 64
            | (rng.next_u32() as u128) << 32
            | rng.next_u32() as u128
    };
    let edge = [
        0i128,
        1,
        -1,
        i128::MAX,
        i128::MIN,
        i128::MAX - 1,
        1 << 63,
        (1 << 64) - 1,
        -(1 << 63),
    ];
    let acc = |rng: &mut Pcg32| {
        let mut sums = [0i128; 8];
        for (i, s) in sums.iter_mut().enumerate() {
            let v = match rng.next_u32() % 4 {
                0 => edge[(rng.next_u32() % edge.len() as u32) as usize],
                1 => (word(rng) >> (rng.next_u32() % 128)) as i128,
                _ => word(rng) as i128,
            };
            // The saturating sums are never negative (part files are checked for it).
            *s = if i >= 3 { v & i128::MAX } else { v };
        }
        Acc::from_sums(
            sums,
            (rng.next_u32() % 512) as u16 * (rng.next_u32() >> 30 == 0) as u16,
        )
    };
    for _ in 0..200 {
        let n = 1 + (rng.next_u32() % 40) as usize;
        let d: Vec<Acc> = (0..n).map(|_| acc(&mut rng)).collect();
        let s: Vec<Acc> = (0..n).map(|_| acc(&mut rng)).collect();
        let mut want = d.clone();
        for (w, s) in want.iter_mut().zip(&s) {
            w.add(s);
        }
        let mut got = d.clone();
        add_row(Some(avx), true, &mut got, &s);
        assert_eq!(got, want);
        // Without second moments: the first moments and Σw as above, the rest as they were.
        let mut got = d.clone();
        add_row(Some(avx), false, &mut got, &s);
        for ((g, w), d) in got.iter().zip(&want).zip(&d) {
            let (g, w, d) = (g.sums(), w.sums(), d.sums());
            assert_eq!([g[0], g[1], g[2], g[6]], [w[0], w[1], w[2], w[6]]);
            assert_eq!([g[3], g[4], g[5], g[7]], [d[3], d[4], d[5], d[7]]);
        }
        assert!(got.iter().zip(&want).all(|(g, w)| g.bad == w.bad));
    }
}

/// `Block::splat8_grouped` (eight samples' footprints taken together, each union pixel's
/// eight weights in lanes) gives the per-sample scalar splat's sums to the bit, pixel by
/// pixel: chunks of eight samples in one pixel (the renderers' order at 8 or more samples a
/// pixel) and in two neighbouring pixels, at positions on pixel edges and centres (footprints
/// one pixel wider) and random ones, near and across the storage's edges (footprints cut, or
/// some samples reaching no pixel), with values down to below the fixed-point grid's common
/// range (a pixel's addends one by one) and zeros. A wrong weight, a weight at the wrong
/// pixel, or a footprint pixel lost or added changes some sum. Asks that the grouped form
/// took most chunks, and that it declines a film with second moments.
#[cfg(target_arch = "x86_64")]
#[test]
fn grouped_splat_equals_the_scalar_splat() {
    let Some(avx) = crate::lane::Avx2::detect() else {
        eprintln!("no AVX2: splat8_grouped not tested");
        return;
    };
    let mut rng = Pcg32::new(43, 5);
    for filter in [
        Filter::gaussian(0.5),
        Filter::Tent { radius: 1.0 },
        Filter::Tent { radius: 1.5 },
    ] {
        let d = FilmDesc {
            second_moments: false,
            ..desc(12, 10, filter)
        };
        for (x0, y0, w, h) in [(0, 0, 12, 10), (3, 2, 5, 4), (11, 9, 1, 1)] {
            let mut one = Block::new(&d, x0, y0, w, h);
            let mut grouped = Block::new(&d, x0, y0, w, h);
            let (mut taken, mut chunks) = (0, 0);
            for _ in 0..1500 {
                let px = (rng.next_u32() % 14) as f32 - 1.0;
                let py = (rng.next_u32() % 12) as f32 - 1.0;
                let two = rng.next_u32().is_multiple_of(4);
                let pos: [Vec2; 8] = core::array::from_fn(|k| {
                    let u = match rng.next_u32() % 6 {
                        0 => Vec2::new(0.5, 0.5),
                        1 => Vec2::new(0.0, 1.0f32.next_down()),
                        _ => Vec2::new(rng.next_f32(), rng.next_f32()),
                    };
                    Vec2::new(px + (two && k % 2 == 1) as u32 as f32, py) + u
                });
                let v: [Spectrum; 8] = core::array::from_fn(|_| match rng.next_u32() % 20 {
                    0 => Spectrum::ZERO,
                    1 => Spectrum::new(1e-30, -2e-13, 5.0),
                    _ => Spectrum::new(
                        rng.next_f32() * 4.0 - 1.0,
                        rng.next_f32(),
                        rng.next_f32() * 9.0,
                    ),
                });
                for k in 0..8 {
                    one.splat::<false>(pos[k], v[k], &[]);
                }
                let rgb = [0, 1, 2].map(|c| avx.load(&core::array::from_fn(|k| v[k][c])));
                let done = avx.run(
                    #[inline(always)]
                    || grouped.splat8_grouped(avx, &pos, rgb),
                );
                if !done {
                    for k in 0..8 {
                        grouped.splat::<false>(pos[k], v[k], &[]);
                    }
                }
                taken += done as u32;
                chunks += 1;
            }
            let first = |b: &Block| -> Vec<_> {
                b.data
                    .iter()
                    .map(|a| ([a.wv(0), a.wv(1), a.wv(2)], a.w()))
                    .collect()
            };
            assert!(one.data.iter().any(|a| a.w() != 0));
            assert!(
                first(&one) == first(&grouped),
                "{filter:?} block {:?}",
                (x0, y0, w, h)
            );
            assert!(taken * 10 > chunks * 9, "{filter:?}: {taken} of {chunks}");
        }
    }
    // A film with second moments: declined, nothing added.
    let mut b = Block::new(&desc(12, 10, Filter::gaussian(0.5)), 0, 0, 12, 10);
    let before = b.data.clone();
    let rgb = [avx.splat(1.0); 3];
    let pos = [Vec2::new(4.5, 4.5); 8];
    assert!(!avx.run(
        #[inline(always)]
        || b.splat8_grouped(avx, &pos, rgb)
    ));
    assert!(b.data == before);
}
