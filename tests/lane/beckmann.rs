//! The f32 visible-Beckmann sampler of `lane::microfacet` (the scalar renderer runs it at width
//! one) against the f64 reference it replaced (`beckmann_ref.rs`), over a grid: the sampled
//! normal's error, inside the sample square and in its outer rim where f32 resolves the CDF's
//! remaining mass coarsely.

use crate::beckmann_ref;
use groove::bsdf::MicrofacetType;
use groove::lane::microfacet::Microfacet;
use groove::lane::vec::{V2, V3};

/// The largest and the summed |m_f32 − m_f64| of one region of the sample square.
#[derive(Default)]
struct Errors {
    max: f64,
    at: String,
    sum: f64,
    n: usize,
}

impl Errors {
    fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }
}

#[test]
fn visible_normals_match_the_f64_reference() {
    // (α_u, α_v): smooth, rough, very rough, anisotropic both ways.
    let alphas = [
        (0.05f32, 0.05f32),
        (0.3, 0.3),
        (1.0, 1.0),
        (0.1, 0.6),
        (0.8, 0.2),
    ];
    let (nt, nu, nv) = (101, 400, 7);
    let (mut inner, mut rim) = (Errors::default(), Errors::default());
    for &(au, av) in &alphas {
        let d = Microfacet::new(MicrofacetType::Beckmann, au, av, true);
        for i in 0..nt {
            // cos θ from grazing (1e-4) to normal incidence, azimuth varying with i.
            let ct = (i as f32 / (nt - 1) as f32).max(1e-4);
            let st = (1.0 - ct * ct).sqrt();
            let phi = 0.7 + 2.3 * i as f32;
            let wi = [st * phi.cos(), st * phi.sin(), ct];
            for j in 0..nu {
                // u.x on a grid refined toward both ends (down to 1e-6 of them).
                let t = (j as f64 + 0.5) / nu as f64;
                let ux = (0.5 - 0.5 * (std::f64::consts::PI * t).cos()) as f32;
                for k in 0..nv {
                    let uy = [1e-5, 0.01, 0.2, 0.5, 0.77, 0.99, 0.99999][k] as f32;
                    let m =
                        d.sample_visible_beckmann(V3::new(wi[0], wi[1], wi[2]), V2::new(ux, uy));
                    let r = beckmann_ref::visible_normal(
                        au as f64,
                        av as f64,
                        wi.map(|w| w as f64),
                        [ux as f64, uy as f64],
                    );
                    let e = ((m.x as f64 - r[0]).powi(2)
                        + (m.y as f64 - r[1]).powi(2)
                        + (m.z as f64 - r[2]).powi(2))
                    .sqrt();
                    let inside = |u: f32| (1e-3..=1.0 - 1e-3).contains(&u);
                    let w = if inside(ux) && inside(uy) {
                        &mut inner
                    } else {
                        &mut rim
                    };
                    w.sum += e;
                    w.n += 1;
                    if e > w.max || e.is_nan() {
                        w.max = e;
                        w.at = format!(
                            "α ({au}, {av}), wi {wi:?}, u ({ux:e}, {uy:e}): {m:?} vs {r:?}"
                        );
                    }
                }
            }
        }
    }
    eprintln!(
        "beckmann visible normals, |Δm|: u in [1e-3, 1 − 1e-3]²: {} samples, mean {:.2e}, max {:.2e} ({}); rim: {} samples, mean {:.2e}, max {:.2e} ({})",
        inner.n,
        inner.mean(),
        inner.max,
        inner.at,
        rim.n,
        rim.mean(),
        rim.max,
        rim.at
    );
    // Bounds: f32 resolves each CDF to ~2⁻²⁴ of its total, so where the remaining mass is
    // 1e-3 of it a slope is known to ~1e-4 (relative); toward u → 0 or 1 the error grows as
    // the density falls (the Gaussian slope's erf⁻¹(2u − 1) likewise). The inner mean is the
    // f32 rounding of the whole chain (a few ulps).
    assert!(inner.mean() <= 1e-6, "mean error {:e}", inner.mean());
    assert!(inner.max <= 1e-4, "{:e} at {}", inner.max, inner.at);
    assert!(rim.max <= 3e-3, "{:e} at {}", rim.max, rim.at);
}
