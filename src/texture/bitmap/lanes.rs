//! The lane form of [`BitmapTexture::eval`] (issue 18): texel coordinates, wrapping and the
//! bilinear (or nearest) weights in lanes, the texel fetches as gathers ([`Lane::gather3`] for
//! f32 texels; [`LaneI32::gather_bytes4`] and the decoding table for 8-bit codes), the
//! interpolation in lanes, in the scalar code's operations and order, so that every lane equals
//! `eval` bit for bit (the `lanes_equal_eval_*` tests).
//!
//! The wrap modes run in floats on integer-valued texel coordinates, exact while every term
//! stays below 2²⁴: coordinates within ±2²², sides up to 2²¹ texels, fewer than 2²⁴ texels. A
//! lookup outside that (huge or non-finite uvs, a huge texture) makes
//! [`BitmapTexture::try_eval_lanes`] return `None`, and [`BitmapTexture::eval_x8`] then calls
//! the scalar `eval` lane by lane.

use super::{BitmapTexture, FilterType, Texels, WrapMode};
use crate::lane::vec::{V2, V3};
use crate::lane::{Lane, LaneI32, LaneMask};

/// Texel coordinates (after `floor`) the lane form takes: |x| < 2²².
const COORD_LIMIT: f32 = 4_194_304.0;
/// Largest side the lane form takes (so that a mirror period 2n is at most 2²²).
const SIDE_LIMIT: u32 = 1 << 21;

/// `crate::math::floor` per lane (the same operations: truncate, step down where above `x`;
/// `x` itself where |x| ≥ 2²³ or NaN).
#[inline(always)]
fn floor<L: Lane>(x: L) -> L {
    let t = x.trunc_i32().to_f32();
    let f = L::select(t.gt(x), t - x.splat(1.0), t);
    L::select(x.abs().lt(x.splat(8_388_608.0)), f, x)
}

/// `i` mod `n` in [0, n) for integer-valued |i| ≤ 2²² + 1 and n ≤ 2²²: i − n·⌊i/n⌋, where
/// every term is an integer below 2²⁴ (exact); the rounded quotient's floor is off by at most
/// one, which the two selects correct. Equals `i64::rem_euclid`.
#[inline(always)]
fn rem<L: Lane>(i: L, n: L) -> L {
    let q = floor(i / n);
    let r = i - n * q;
    let zero = i.splat(0.0);
    let r = L::select(r.lt(zero), r + n, r);
    L::select(r.ge(n), r - n, r)
}

/// [`WrapMode::apply`] on integer-valued float coordinates (|i| ≤ 2²² + 1, n ≤ 2²¹).
#[inline(always)]
fn wrap<L: Lane>(mode: WrapMode, i: L, n: f32) -> L {
    let nn = i.splat(n);
    match mode {
        WrapMode::Repeat => rem(i, nn),
        WrapMode::Clamp => i.max(i.splat(0.0)).min(i.splat(n - 1.0)),
        WrapMode::Mirror => {
            // Period 2n: 0..n-1 forwards, then n-1..0.
            let m = rem(i, i.splat(2.0 * n));
            L::select(m.lt(nn), m, i.splat(2.0 * n - 1.0) - m)
        }
    }
}

/// [`wrap`] of `i + 1` from `a`, the wrapped `i` (`wrap(mode, i, n)`): under `Repeat`,
/// `(a + 1) mod n` is `a + 1` below `n` and 0 at `n` (`a` is an integer in [0, n), so both
/// are exact and equal [`rem`] of `i + 1`), an add, a compare and a select instead of a
/// second remainder; the other modes wrap `i + 1` themselves.
#[inline(always)]
fn wrap_next<L: Lane>(mode: WrapMode, i: L, a: L, n: f32) -> L {
    let one = i.splat(1.0);
    match mode {
        WrapMode::Repeat => {
            let b = a + one;
            L::select(b.ge(i.splat(n)), i.splat(0.0), b)
        }
        _ => wrap(mode, i + one, n),
    }
}

/// Whether every lane's floored coordinates are within [`COORD_LIMIT`] (false for NaN).
#[inline(always)]
fn tame<L: Lane>(x: L, y: L) -> bool {
    let lim = x.splat(COORD_LIMIT);
    (x.abs().lt(lim) & y.abs().lt(lim)).all()
}

impl BitmapTexture {
    /// Whether the lane form covers this texture's size.
    #[inline(always)]
    fn lanes_exact(&self) -> bool {
        self.width <= SIDE_LIMIT
            && self.height <= SIDE_LIMIT
            && (self.width as u64 * self.height as u64) < 1 << 24
    }

    /// The texels at the row-major indices `idx` (integer-valued floats): gathers.
    #[inline(always)]
    fn fetch<L: Lane>(&self, idx: L) -> V3<L> {
        let i = idx.round_i32();
        match &self.texels {
            Texels::F32(t) => {
                let [r, g, b] = L::gather3(t, i);
                V3::new(r, g, b)
            }
            Texels::U8 { codes, lut } => {
                let c = L::I32::gather_bytes4(codes, i);
                let m = c.splat(0xff);
                let lut: &[f32; 256] = lut;
                V3::new(
                    L::gather(lut, c.and(m)),
                    L::gather(lut, c.shr::<8>().and(m)),
                    L::gather(lut, c.shr::<16>().and(m)),
                )
            }
        }
    }

    /// [`BitmapTexture::eval`] at the lanes of `uv`, each lane equal to `eval` bit for bit; `None`
    /// when some lane's texel coordinates leave the exact range (see the module doc), where the
    /// caller looks each lane up with `eval` instead.
    #[inline(always)]
    pub fn try_eval_lanes<L: Lane>(&self, uv: V2<L>) -> Option<V3<L>> {
        if !self.lanes_exact() {
            return None;
        }
        let k = uv.x;
        let (u, v) = if self.identity_uv {
            (uv.x, uv.y)
        } else {
            // glam's `transform_point2`: (a·u + c·v) + e per row.
            let a = &self.to_uv;
            (
                uv.x * k.splat(a.x_axis.x) + uv.y * k.splat(a.y_axis.x) + k.splat(a.z_axis.x),
                uv.x * k.splat(a.x_axis.y) + uv.y * k.splat(a.y_axis.y) + k.splat(a.z_axis.y),
            )
        };
        let (w, h) = (self.width as f32, self.height as f32);
        match self.filter {
            FilterType::Nearest => {
                let x = floor(u * k.splat(w));
                let y = floor(v * k.splat(h));
                if !tame(x, y) {
                    return None;
                }
                let (x, y) = (wrap(self.wrap, x, w), wrap(self.wrap, y, h));
                Some(self.fetch(y * k.splat(w) + x))
            }
            FilterType::Bilinear => {
                // Texel centres sit at integer + 0.5 (Dr.Jit's `tex_eval`).
                let x = u * k.splat(w) - k.splat(0.5);
                let y = v * k.splat(h) - k.splat(0.5);
                let (xf, yf) = (floor(x), floor(y));
                if !tame(xf, yf) {
                    return None;
                }
                let (wx1, wy1) = (x - xf, y - yf);
                let one = k.splat(1.0);
                let (wx0, wy0) = (one - wx1, one - wy1);
                let xa = wrap(self.wrap, xf, w);
                let xb = wrap_next(self.wrap, xf, xa, w);
                let ya = wrap(self.wrap, yf, h);
                let ra = ya * k.splat(w);
                let rb = wrap_next(self.wrap, yf, ya, h) * k.splat(w);
                let (t00, t10) = (self.fetch(ra + xa), self.fetch(ra + xb));
                let (t01, t11) = (self.fetch(rb + xa), self.fetch(rb + xb));
                Some(
                    t00.scale(wx0 * wy0)
                        + t10.scale(wx1 * wy0)
                        + t01.scale(wx0 * wy1)
                        + t11.scale(wx1 * wy1),
                )
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x8 {
    use super::*;
    use crate::lane::{ToArray, Wide};
    use glam::Vec2;

    impl BitmapTexture {
        /// [`BitmapTexture::eval`] at `W` uvs (8 or 16): [`BitmapTexture::try_eval_lanes`], or
        /// `eval` lane by lane where that declines. Call inside [`Wide::run`].
        #[inline(always)]
        pub fn eval_x8<T: Wide<W>, const W: usize>(&self, avx: T, uv: V2<T::F>) -> V3<T::F> {
            if let Some(c) = self.try_eval_lanes(uv) {
                return c;
            }
            let (u, v) = (uv.x.to_array(), uv.y.to_array());
            let mut out = [[0.0f32; W]; 3];
            for k in 0..W {
                let c = self.eval(Vec2::new(u[k], v[k]));
                (out[0][k], out[1][k], out[2][k]) = (c.x, c.y, c.z);
            }
            V3::new(avx.load(&out[0]), avx.load(&out[1]), avx.load(&out[2]))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::BitmapOptions;
    use super::*;
    use glam::{Mat3, Vec2, Vec3};

    /// A small xorshift stream (fixed seed) for test inputs.
    struct Rng(u32);
    impl Rng {
        fn next(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 17;
            self.0 ^= self.0 << 5;
            (self.0 >> 8) as f32 / (1u32 << 24) as f32
        }
    }

    /// Textures of every storage, channel count, filter, wrap and `to_uv` kind, of odd and even
    /// sizes (and a 1-pixel image, up-sampled).
    fn textures() -> Vec<BitmapTexture> {
        let mut out = Vec::new();
        let mut rng = Rng(0x1234_5678);
        for (w, h) in [(5u32, 3u32), (4, 7), (1, 1), (16, 2)] {
            for grey in [false, true] {
                let n = (w * h) as usize;
                let codes: Vec<[u8; 4]> = (0..n)
                    .map(|_| {
                        let c = [rng.next(), rng.next(), rng.next()].map(|x| (x * 255.0) as u8);
                        if grey {
                            [c[0], c[0], c[0], 0]
                        } else {
                            [c[0], c[1], c[2], 0]
                        }
                    })
                    .collect();
                let floats: Vec<Vec3> = codes
                    .iter()
                    .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * 0.37 - 3.0)
                    .collect();
                for filter in [FilterType::Bilinear, FilterType::Nearest] {
                    for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
                        for to_uv in [
                            Mat3::IDENTITY,
                            Mat3::from_scale_angle_translation(
                                Vec2::new(3.3, -1.7),
                                0.4,
                                Vec2::new(0.25, -2.5),
                            ),
                        ] {
                            let opts = BitmapOptions {
                                filter,
                                wrap,
                                to_uv,
                                ..Default::default()
                            };
                            out.push(BitmapTexture::from_texels(
                                w,
                                h,
                                floats.clone(),
                                grey,
                                &opts,
                            ));
                            let lut = Box::new(std::array::from_fn(|c| {
                                super::super::srgb_to_linear(c as f64 / 255.0) as f32
                            }));
                            let store = Texels::U8 {
                                codes: codes.clone(),
                                lut,
                            };
                            out.push(BitmapTexture::from_storage(w, h, store, grey, &opts));
                        }
                    }
                }
            }
        }
        out
    }

    /// Random uvs in [−3, 4]² (outside the unit square too), texel centres and edges, and the
    /// values that must decline the lane form (huge, infinite, NaN).
    fn uvs(t: &BitmapTexture) -> Vec<Vec2> {
        let mut rng = Rng(0x9e37_79b9);
        let mut out: Vec<Vec2> = (0..2000)
            .map(|_| Vec2::new(rng.next() * 7.0 - 3.0, rng.next() * 7.0 - 3.0))
            .collect();
        let (w, h) = (t.width as f32, t.height as f32);
        for i in -3..=(2 * t.width as i32 + 3) {
            for j in [-1, 0, 1, t.height as i32, t.height as i32 + 1] {
                out.push(Vec2::new(i as f32 / w, j as f32 / h));
                out.push(Vec2::new((i as f32 + 0.5) / w, (j as f32 + 0.5) / h));
            }
        }
        out.extend([
            Vec2::ZERO,
            Vec2::ONE,
            Vec2::new(-0.0, -0.0),
            Vec2::new(1e5, -1e5),
            Vec2::new(3e6, 0.5),
            Vec2::new(1e30, -1e30),
            Vec2::new(f32::INFINITY, 0.5),
            Vec2::new(0.5, f32::NEG_INFINITY),
            Vec2::new(f32::NAN, 0.5),
        ]);
        out
    }

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    #[test]
    fn lanes_equal_eval_at_width_1() {
        let mut declined = 0;
        for t in textures() {
            for uv in uvs(&t) {
                match t.try_eval_lanes(V2::new(uv.x, uv.y)) {
                    Some(c) => {
                        let c = Vec3::new(c.x, c.y, c.z);
                        assert_eq!(bits(c), bits(t.eval(uv)), "{t:?} at {uv}: {c}");
                    }
                    None => declined += 1,
                }
            }
        }
        // Only the non-finite and huge uvs decline (6 per texture, a few more under to_uv).
        assert!(
            declined > 0 && declined < 10 * textures().len(),
            "{declined}"
        );
    }

    /// [`wrap_next`] from the wrapped `i` equals [`wrap`] of `i + 1`, bit for bit, in every
    /// mode: sides 1 to 2²¹, coordinates around 0, around multiples of the side, and at the
    /// lane form's limits (±2²²).
    #[test]
    fn the_next_texel_wraps_as_wrap() {
        let lim = COORD_LIMIT as i64;
        for n in [1u32, 2, 3, 5, 7, 64, 1000, 4097, SIDE_LIMIT - 1, SIDE_LIMIT] {
            let n64 = n as i64;
            let mut is: Vec<i64> = (-70..70).collect();
            for m in [-3i64, -2, -1, 1, 2, 3] {
                is.extend((-2..=2).map(|d| m * n64 + d));
            }
            is.extend([-lim + 1, -lim + 2, lim - 2, lim - 1, -lim / 2, lim / 2]);
            for i in is.into_iter().filter(|i| i.abs() < lim) {
                for mode in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
                    let (i, nf) = (i as f32, n as f32);
                    let a = wrap(mode, i, nf);
                    let want = wrap(mode, i + 1.0, nf);
                    let got = wrap_next(mode, i, a, nf);
                    assert_eq!(got.to_bits(), want.to_bits(), "{mode:?} n {n} i {i}");
                }
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn lanes_equal_eval_at_width_8() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            eprintln!("no AVX2: the width-8 form is not reachable on this CPU");
            return;
        };
        for t in textures() {
            let uv = uvs(&t);
            for chunk in uv.chunks(8) {
                let mut u = [0.5f32; 8];
                let mut v = [0.5f32; 8];
                for (k, p) in chunk.iter().enumerate() {
                    (u[k], v[k]) = (p.x, p.y);
                }
                let c = t.eval_x8(avx, V2::new(avx.load(&u), avx.load(&v)));
                let (x, y, z) = (c.x.to_array(), c.y.to_array(), c.z.to_array());
                for k in 0..chunk.len() {
                    let c = Vec3::new(x[k], y[k], z[k]);
                    let p = Vec2::new(u[k], v[k]);
                    assert_eq!(bits(c), bits(t.eval(p)), "{t:?} at {p}: {c}");
                }
            }
        }
    }
}
