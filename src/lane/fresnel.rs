//! The Fresnel equations of `bsdf::fresnel` per lane, with selects instead of branches and the
//! same operation order, so width 1 equals `bsdf::fresnel` bit for bit: the smooth dielectric
//! (Hecht, "Optics", ch. 4) and the conductor with complex index η + ik (PBR 3rd ed. §8.2.1).

use super::vec::V3;
use super::Lane;

/// Result of [`dielectric`]: as `bsdf::fresnel::DielectricFresnel`.
#[derive(Clone, Copy, Debug)]
pub struct Dielectric<L> {
    /// Unpolarised reflectance (1 under total internal reflection).
    pub r: L,
    /// Cosine of the refracted direction, with the sign of the side it leaves on; 0 under TIR.
    pub cos_theta_t: L,
    /// η_t / η_i.
    pub eta_it: L,
    /// η_i / η_t.
    pub eta_ti: L,
}

/// Fresnel reflectance of a smooth dielectric interface; `eta` is inside over outside, a
/// negative `cos_theta_i` arrives from inside.
#[inline(always)]
pub fn dielectric<L: Lane>(cos_theta_i: L, eta: L) -> Dielectric<L> {
    let k = |c: f32| eta.splat(c);
    let outside = cos_theta_i.ge(k(0.0));
    let inv = k(1.0) / eta;
    let eta_it = L::select(outside, eta, inv);
    let eta_ti = L::select(outside, inv, eta);
    let ci = cos_theta_i.abs();
    let ct2 = k(1.0) - eta_ti * eta_ti * (k(1.0) - ci * ci).max(k(0.0));
    let tir = ct2.lt(k(0.0));
    let ct = ct2.sqrt();
    let rs = (ci - eta_it * ct) / (ci + eta_it * ct);
    let rp = (ct - eta_it * ci) / (ct + eta_it * ci);
    let r = k(0.5) * (rs * rs + rp * rp);
    let r = L::select(ci.eq(k(0.0)), k(1.0), r);
    let r = L::select(eta.eq(k(1.0)), k(0.0), r);
    let cos_t = L::select(outside, -ct, ct);
    Dielectric {
        r: L::select(tir, k(1.0), r),
        cos_theta_t: L::select(tir, k(0.0), cos_t),
        eta_it,
        eta_ti,
    }
}

/// Conductor reflectance for one channel with complex relative index `eta + i k`.
#[inline(always)]
pub fn conductor_1<L: Lane>(cos_theta_i: L, eta: L, k_: L) -> L {
    let k = |c: f32| eta.splat(c);
    conductor_1_of(
        cos_theta_i,
        eta * eta - k_ * k_,
        k(4.0) * eta * eta * k_ * k_,
    )
}

/// [`conductor_1`] from the two terms of the index that do not depend on the angle, η² − k²
/// and 4η²k² (computed in that order: `(η·η − k·k)` and `((4η)η·k)k`), so that a caller whose
/// index is the same for every lane and every call (a material's constant) computes them once.
#[inline(always)]
pub fn conductor_1_of<L: Lane>(cos_theta_i: L, eta2_minus_k2: L, four_eta2_k2: L) -> L {
    let k = |c: f32| cos_theta_i.splat(c);
    let safe_sqrt = |x: L| x.max(k(0.0)).sqrt();
    let c2 = (cos_theta_i * cos_theta_i).min(k(1.0));
    let s2 = k(1.0) - c2;
    let s4 = s2 * s2;
    let t0 = eta2_minus_k2 - s2;
    let a2pb2 = safe_sqrt(t0 * t0 + four_eta2_k2);
    let a = safe_sqrt(k(0.5) * (a2pb2 + t0));
    let t1 = a2pb2 + c2;
    let t2 = k(2.0) * cos_theta_i * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = a2pb2 * c2 + s4;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    let r = k(0.5) * (rs + rp);
    L::select(r.is_finite(), r, k(1.0))
}

/// [`conductor_1`] per RGB channel.
#[inline(always)]
pub fn conductor<L: Lane>(cos_theta_i: L, eta: V3<L>, k: V3<L>) -> V3<L> {
    V3::new(
        conductor_1(cos_theta_i, eta.x, k.x),
        conductor_1(cos_theta_i, eta.y, k.y),
        conductor_1(cos_theta_i, eta.z, k.z),
    )
}

/// A conductor's complex index η + ik per RGB channel with the angle-free terms of
/// [`conductor_1`] (η² − k², 4η²k²) computed once: [`ConductorIndex::reflectance`] is
/// [`conductor`] bit for bit (the same operations; the terms' are exact IEEE products and
/// differences whether done on `f32` or in lanes).
#[derive(Clone, Copy, Debug)]
pub struct ConductorIndex {
    eta2_minus_k2: [f32; 3],
    four_eta2_k2: [f32; 3],
}

impl ConductorIndex {
    /// The terms of index `eta + i k` (per channel).
    #[inline(always)]
    pub fn new(eta: [f32; 3], k: [f32; 3]) -> Self {
        ConductorIndex {
            eta2_minus_k2: core::array::from_fn(|c| eta[c] * eta[c] - k[c] * k[c]),
            four_eta2_k2: core::array::from_fn(|c| 4.0 * eta[c] * eta[c] * k[c] * k[c]),
        }
    }

    /// The terms in lanes of `like`'s width, for many evaluations at this index
    /// ([`ConductorTerms::eval`]).
    #[inline(always)]
    pub fn lanes<L: Lane>(&self, like: L) -> ConductorTerms<L> {
        // A function, not a closure: a closure called twice may stay out of line, and its
        // splats with it (`tests/cli/simd_calls.rs`).
        #[inline(always)]
        fn s<L: Lane>(like: L, x: [f32; 3]) -> V3<L> {
            V3::new(like.splat(x[0]), like.splat(x[1]), like.splat(x[2]))
        }
        ConductorTerms {
            d: s(like, self.eta2_minus_k2),
            c4: s(like, self.four_eta2_k2),
        }
    }

    /// [`conductor`] at `cos_theta_i` with this index.
    #[inline(always)]
    pub fn reflectance<L: Lane>(&self, cos_theta_i: L) -> V3<L> {
        self.lanes(cos_theta_i).eval(cos_theta_i)
    }
}

/// A [`ConductorIndex`]'s terms broadcast to the lanes ([`ConductorIndex::lanes`]), for many
/// evaluations with one index (the compensated first order evaluates a `roughconductor` four
/// times per query, issue 18): [`ConductorTerms::eval`] is [`conductor`] bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct ConductorTerms<L> {
    /// η² − k² (`conductor_1`'s `eta * eta - k * k`, before `- s2`).
    d: V3<L>,
    /// 4η²k² (`conductor_1`'s `4 * eta * eta * k * k`, in that order).
    c4: V3<L>,
}

impl<L: Lane> ConductorTerms<L> {
    /// [`conductor`]`(cos_theta_i, eta, k)` of the index these terms came from
    /// ([`ConductorIndex::lanes`]).
    #[inline(always)]
    pub fn eval(&self, cos_theta_i: L) -> V3<L> {
        V3::new(
            conductor_1_of(cos_theta_i, self.d.x, self.c4.x),
            conductor_1_of(cos_theta_i, self.d.y, self.c4.y),
            conductor_1_of(cos_theta_i, self.d.z, self.c4.z),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    /// Values that reach the conductor's operations: zeros of both signs, subnormals, huge
    /// values, infinities, NaN, and ordinary indices and cosines.
    const EDGES: [f32; 16] = [
        0.0,
        -0.0,
        1e-40,
        -1e-40,
        f32::MIN_POSITIVE,
        1e30,
        3e38,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        0.5,
        1.0,
        -1.0,
        0.2,
        3.9,
        -0.7,
    ];

    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    /// The index with its terms computed once equals [`conductor`] bit for bit, at width 1
    /// and 8, over random and edge indices and cosines.
    #[test]
    fn the_index_terms_once_equal_the_conductor() {
        let mut r = Pcg32::new(3, 17);
        let v = |r: &mut Pcg32| {
            if r.next_u32() & 1 == 0 {
                EDGES[(r.next_u32() % EDGES.len() as u32) as usize]
            } else {
                4.0 * r.next_f32() - 1.0
            }
        };
        for _ in 0..20_000 {
            let eta = [v(&mut r), v(&mut r), v(&mut r)];
            let k = [v(&mut r), v(&mut r), v(&mut r)];
            let ix = ConductorIndex::new(eta, k);
            let cos: [f32; 8] = core::array::from_fn(|_| v(&mut r));
            let e = V3::new(eta[0], eta[1], eta[2]);
            let kk = V3::new(k[0], k[1], k[2]);
            for &c in &cos {
                let (a, b) = (ix.reflectance(c), conductor(c, e, kk));
                for (x, y) in [(a.x, b.x), (a.y, b.y), (a.z, b.z)] {
                    assert!(same(x, y), "{eta:?} {k:?} {c}: {x} vs {y}");
                }
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                let got = avx.run(|| {
                    let c8 = avx.load(&cos);
                    let a = ix.reflectance(c8);
                    [a.x.to_array(), a.y.to_array(), a.z.to_array()]
                });
                for (j, &c) in cos.iter().enumerate() {
                    let b = conductor(c, e, kk);
                    for (ch, y) in [b.x, b.y, b.z].into_iter().enumerate() {
                        assert!(same(got[ch][j], y), "{eta:?} {k:?} lane {j}");
                    }
                }
            }
        }
    }
}
