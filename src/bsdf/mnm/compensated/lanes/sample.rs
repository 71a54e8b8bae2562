//! The nested BSDF's samples of a stream chunk's shading points in one lane call (issue 18,
//! `sample_x8`'s first-order draws): every point that chose the first order and an entry asks
//! the nested BSDF for one sample in its facet's frame; those asks are collected with the
//! random numbers each point drew from its own sampler ([`Asks::push`], the numbers and order
//! of [`crate::bsdf::Bsdf::sample`] for the kind) and answered by one call of the kind's lane
//! form `sample_lanes` (`src/bsdf/lanes.rs`) at width 8 under the [`crate::lane::Avx2`] token, or ask by ask
//! at width 1 on a CPU without AVX2. The scalar `sample` of `diffuse`, `roughconductor` and
//! `roughplastic` is the width-1 form of the same code (the lane rule of [`crate::lane`]), and
//! [`Answered::get`] applies `Bsdf::sample`'s rejection of non-finite samples, so each answer
//! is the scalar `nested.sample` of that point bit for bit (`super::tests`).

use super::super::super::lane_cols::Cols;
use super::super::Nested;
use crate::bsdf::diffuse::Diffuse;
use crate::bsdf::lanes::LaneBsdfSample;
use crate::bsdf::roughconductor::RoughConductor;
use crate::bsdf::roughplastic::RoughPlastic;
use crate::lane::vec::{V2, V3};
#[cfg(target_arch = "x86_64")]
use crate::lane::F32x8;
use crate::lane::Lane;
use crate::sampler::Draw;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// A nested BSDF whose `Bsdf::sample` is its lane form's width 1 (the `bsdf::lanes`
/// convention), with the random numbers that `Bsdf::sample` draws for it.
trait LaneSample {
    /// Whether `Bsdf::sample` draws the lobe number `u1` (before `u2`) for this kind.
    const DRAWS_U1: bool;
    fn sample_lanes<L: Lane>(&self, wi: V3<L>, u1: L, u2: V2<L>) -> LaneBsdfSample<L>;
}

impl LaneSample for Diffuse {
    const DRAWS_U1: bool = false;
    #[inline(always)]
    fn sample_lanes<L: Lane>(&self, wi: V3<L>, u1: L, u2: V2<L>) -> LaneBsdfSample<L> {
        Diffuse::sample_lanes(self, wi, u1, u2)
    }
}

impl LaneSample for RoughConductor {
    const DRAWS_U1: bool = false;
    #[inline(always)]
    fn sample_lanes<L: Lane>(&self, wi: V3<L>, u1: L, u2: V2<L>) -> LaneBsdfSample<L> {
        RoughConductor::sample_lanes(self, wi, u1, u2)
    }
}

impl LaneSample for RoughPlastic {
    const DRAWS_U1: bool = true;
    #[inline(always)]
    fn sample_lanes<L: Lane>(&self, wi: V3<L>, u1: L, u2: V2<L>) -> LaneBsdfSample<L> {
        RoughPlastic::sample_lanes(self, wi, u1, u2)
    }
}

/// Whether `Bsdf::sample` of `nested` (a kind with a lane form) draws the lobe number `u1`
/// before `u2`.
#[inline(always)]
pub(in crate::bsdf::mnm::compensated) fn draws_u1(nested: Nested) -> bool {
    match nested {
        Nested::Diffuse(_) => Diffuse::DRAWS_U1,
        Nested::Conductor(_) => RoughConductor::DRAWS_U1,
        Nested::Plastic(_) => RoughPlastic::DRAWS_U1,
        Nested::Other(_) => unreachable!("a point's nested BSDF has a lane form"),
    }
}

/// Up to 8 asks for a nested sample, by lane (structure of arrays): the incident direction in
/// the facet's frame and the random numbers drawn for it. Lanes without an ask hold +z and
/// zeros (valid inputs whose answers are never read).
pub(in crate::bsdf::mnm::compensated) struct Asks {
    wi: [[f32; 8]; 3],
    u1: [f32; 8],
    u2: [[f32; 8]; 2],
    used: u8,
}

impl Asks {
    pub(in crate::bsdf::mnm::compensated) fn new() -> Self {
        Asks {
            wi: [[0.0; 8], [0.0; 8], [1.0; 8]],
            u1: [0.0; 8],
            u2: [[0.0; 8]; 2],
            used: 0,
        }
    }

    /// Lane `k` asks for a sample of `nested` from `wi`: draws from `s` what `Bsdf::sample`
    /// draws for that kind, in its order (`u1` then `u2` for `roughplastic`, `u2` for the
    /// others). `nested` must have a lane form.
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn push(
        &mut self,
        nested: Nested,
        k: usize,
        wi: Vec3,
        s: &mut impl Draw,
    ) {
        if draws_u1(nested) {
            self.u1[k] = s.next_1d();
        }
        let u2 = s.next_2d();
        for c in 0..3 {
            self.wi[c][k] = wi[c];
        }
        self.u2[0][k] = u2.x;
        self.u2[1][k] = u2.y;
        self.used |= 1 << k;
    }

    /// The lanes `on` (bit k: lane k) ask for a sample from `wi` with the numbers `u1` (read
    /// where [`draws_u1`]) and `u2` drawn for them (the sampler's draws in lanes,
    /// `super::draws`), the other lanes kept: [`Self::push`] of each such lane, from lanes.
    /// Call inside [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn set_lanes(
        &mut self,
        avx: crate::lane::Avx2,
        on: crate::lane::M8,
        wi: V3<F32x8>,
        u1: F32x8,
        u2: V2<F32x8>,
    ) {
        // A plain function, not a closure: a closure may be compiled out of the SIMD
        // function, and its loads become calls.
        #[inline(always)]
        fn blend(avx: crate::lane::Avx2, on: crate::lane::M8, v: F32x8, col: &mut [f32; 8]) {
            F32x8::select(on, v, avx.load(col)).store(col);
        }
        blend(avx, on, wi.x, &mut self.wi[0]);
        blend(avx, on, wi.y, &mut self.wi[1]);
        blend(avx, on, wi.z, &mut self.wi[2]);
        blend(avx, on, u1, &mut self.u1);
        blend(avx, on, u2.x, &mut self.u2[0]);
        blend(avx, on, u2.y, &mut self.u2[1]);
        self.used |= on.bits() as u8;
    }

    /// Whether no lane asked.
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn is_empty(&self) -> bool {
        self.used == 0
    }

    /// Every ask answered by `nested` (the points' shared nested BSDF).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn answer(&self, cols: Cols, nested: Nested) -> Answered {
        match nested {
            Nested::Diffuse(d) => self.answer_with(cols, d),
            Nested::Conductor(c) => self.answer_with(cols, c),
            Nested::Plastic(p) => self.answer_with(cols, p),
            Nested::Other(_) => unreachable!("a point's nested BSDF has a lane form"),
        }
    }

    /// One 8-wide call when the CPU has AVX2 and FMA, else ask by ask at width 1 (the same
    /// numbers).
    #[inline(always)]
    fn answer_with<B: LaneSample>(&self, cols: Cols, b: &B) -> Answered {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = cols.avx() {
            return avx.run(
                #[inline(always)]
                || {
                    let wi = V3::<F32x8>::new(
                        avx.load(&self.wi[0]),
                        avx.load(&self.wi[1]),
                        avx.load(&self.wi[2]),
                    );
                    let u2 = V2::new(avx.load(&self.u2[0]), avx.load(&self.u2[1]));
                    let s = b.sample_lanes(wi, avx.load(&self.u1), u2);
                    let mut out = Answered::zero();
                    out.ok = accepted(&s).bits() as u8;
                    s.wo.x.store(&mut out.wo[0]);
                    s.wo.y.store(&mut out.wo[1]);
                    s.wo.z.store(&mut out.wo[2]);
                    s.pdf.store(&mut out.pdf);
                    s.weight.x.store(&mut out.weight[0]);
                    s.weight.y.store(&mut out.weight[1]);
                    s.weight.z.store(&mut out.weight[2]);
                    out
                },
            );
        }
        self.answer_width1(b)
    }

    /// [`Self::answer_with`] ask by ask at width 1 (a CPU without AVX2).
    #[inline(always)]
    fn answer_width1<B: LaneSample>(&self, b: &B) -> Answered {
        let mut out = Answered::zero();
        for k in (0..8).filter(|&k| self.used & (1 << k) != 0) {
            let wi = Vec3::new(self.wi[0][k], self.wi[1][k], self.wi[2][k]);
            let u2 = glam::Vec2::new(self.u2[0][k], self.u2[1][k]);
            let s = b.sample_lanes::<f32>(wi.into(), self.u1[k], u2.into());
            out.ok |= u8::from(accepted(&s)) << k;
            let (wo, w): (Vec3, Vec3) = (s.wo.into(), s.weight.into());
            for c in 0..3 {
                out.wo[c][k] = wo[c];
                out.weight[c][k] = w[c];
            }
            out.pdf[k] = s.pdf;
        }
        out
    }
}

/// Where a lane form's sample is one that `Bsdf::sample` returns: sampled (`ok`), ωo and the
/// weight finite and the density not negative (`Bsdf::sample`'s test, `accept_sample`: a NaN
/// density fails `pdf >= 0` as it does here), in lanes (8-wide in [`Asks::answer_with`], so
/// [`Answered::get`] tests one bit instead of seven numbers per lane).
#[inline(always)]
pub(in crate::bsdf::mnm::compensated) fn accepted<L: Lane>(s: &LaneBsdfSample<L>) -> L::Mask {
    s.ok & s.wo.x.is_finite()
        & s.wo.y.is_finite()
        & s.wo.z.is_finite()
        & s.pdf.ge(s.pdf.splat(0.0))
        & s.weight.x.is_finite()
        & s.weight.y.is_finite()
        & s.weight.z.is_finite()
}

/// The nested samples of [`Asks::answer`], by lane.
pub(in crate::bsdf::mnm::compensated) struct Answered {
    /// Bit k: lane k's sample is kept ([`accepted`]).
    ok: u8,
    wo: [[f32; 8]; 3],
    pdf: [f32; 8],
    weight: [[f32; 8]; 3],
}

impl Answered {
    fn zero() -> Self {
        Answered {
            ok: 0,
            wo: [[0.0; 8]; 3],
            pdf: [0.0; 8],
            weight: [[0.0; 8]; 3],
        }
    }

    /// The sampled directions by component (lanes without a sample: any value): what
    /// `first::Points8::leave_dirs` turns to the shading frame for all lanes at once.
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn wo(&self) -> &[[f32; 8]; 3] {
        &self.wo
    }

    /// The samples' densities by lane (lanes without a sample: any value).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn pdf(&self) -> &[f32; 8] {
        &self.pdf
    }

    /// The samples' weights by channel, by lane (lanes without a sample: any value).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn weight(&self) -> &[[f32; 8]; 3] {
        &self.weight
    }

    /// The lanes whose nested sample is kept (bit k: lane k; [`Self::get`] is `Some`).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn ok(&self) -> u8 {
        self.ok
    }

    /// Lane `k`'s sample as `Bsdf::sample` returns it: (ωo, pdf, weight), `None` where the
    /// model sampled nothing or the sample is degenerate (non-finite ωo or weight, negative
    /// pdf: `Bsdf::sample`'s test).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn get(&self, k: usize) -> Option<(Vec3, f32, Spectrum)> {
        if self.ok & (1 << k) == 0 {
            return None;
        }
        let wo = Vec3::new(self.wo[0][k], self.wo[1][k], self.wo[2][k]);
        let w = Vec3::new(self.weight[0][k], self.weight[1][k], self.weight[2][k]);
        Some((wo, self.pdf[k], w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::{direction, same, same3};
    use crate::bsdf::{BsdfArena, BsdfContext, BsdfNode};
    use crate::math::Pcg32;
    use crate::sampler::Sampler;

    /// The nested samples of a chunk (8-wide on this machine, and at width 1) equal the
    /// scalar `Bsdf::sample` of the same nested BSDF lane by lane, bit for bit (`None` where
    /// it is `None`), and leave each lane's sampler where the scalar call leaves it: the rough
    /// conductors and the rough plastic of the model's tests and a diffuse BSDF, random ωi over
    /// both hemispheres (near-horizon and non-unit ones mixed in), random samplers, every
    /// count of asking lanes.
    #[test]
    fn nested_samples_equal_the_scalar_ones() {
        let ctx = BsdfContext::default();
        let mut rng = Pcg32::new(12, 1);
        let mut arena = BsdfArena::new();
        let mut nested = super::super::super::tests::push_reflectors(&mut arena).to_vec();
        nested.push(arena.push(BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::new(0.7, 0.5, 0.2),
        })));
        let (mut some, mut none) = (0, 0);
        for &n in &nested {
            let b = arena.bsdf(n);
            let kind = Nested::of(&b);
            for round in 0..1500 {
                let mut asks = Asks::new();
                let mut wi = [Vec3::Z; 8];
                let seeds: [u64; 8] = std::array::from_fn(|_| rng.next_u32() as u64);
                let mut samplers: Vec<Sampler> =
                    seeds.iter().map(|&s| Sampler::from_seed(s, 3)).collect();
                let used = (round % 9) as u32; // 0..=8 asking lanes, at random places
                let mut lanes: Vec<usize> = (0..8).collect();
                for i in 0..8 {
                    lanes.swap(i, i + (rng.next_u32() as usize) % (8 - i));
                }
                lanes.truncate(used as usize);
                for &k in &lanes {
                    wi[k] = direction(&mut rng);
                    asks.push(kind, k, wi[k], &mut samplers[k]);
                }
                let wide = asks.answer(Cols::detect(), kind);
                let one = match kind {
                    Nested::Diffuse(d) => asks.answer_width1(d),
                    Nested::Conductor(c) => asks.answer_width1(c),
                    Nested::Plastic(p) => asks.answer_width1(p),
                    Nested::Other(_) => unreachable!(),
                };
                for &k in &lanes {
                    let mut s = Sampler::from_seed(seeds[k], 3);
                    let want = b.sample(&ctx, wi[k], &mut s);
                    for got in [wide.get(k), one.get(k)] {
                        match (got, want) {
                            (None, None) => {}
                            (Some((wo, pdf, w)), Some(bs)) => {
                                assert!(same3(wo, bs.wo), "{n} {}", wi[k]);
                                assert!(same(pdf, bs.pdf), "{n} {}", wi[k]);
                                assert!(same3(w, bs.weight), "{n} {}", wi[k]);
                            }
                            (a, b) => panic!("{n} {}: {a:?} vs {b:?}", wi[k]),
                        }
                    }
                    some += usize::from(want.is_some());
                    none += usize::from(want.is_none());
                    assert_eq!(
                        samplers[k].next_1d().to_bits(),
                        s.next_1d().to_bits(),
                        "{n} {}",
                        wi[k]
                    );
                }
            }
        }
        // 4 × 1500 chunks of 4 asks on average, about half from below the surface.
        assert!(some > 8000 && none > 6000, "{some} samples, {none} none");
    }
}
