//! The power heuristic in lanes: `math::mis::power_heuristic` (Veach 1997, eq. 9.13 with
//! β = 2) with its branches as selects, equal bit for bit in every lane (tested below).

use crate::lane::Lane;

/// `a² / (a² + b²)`; 1 when `a` is infinite and the sum is not finite, else 0 when the sum is
/// not positive and finite.
#[inline(always)]
pub(crate) fn power_heuristic<L: Lane>(a: L, b: L) -> L {
    let k = |c: f32| a.splat(c);
    let a2 = a * a;
    let b2 = b * b;
    let s = a2 + b2;
    let ok = s.gt(k(0.0)) & s.is_finite();
    let inf = a.abs().eq(k(f32::INFINITY));
    L::select(ok, a2 / s, L::select(inf, k(1.0), k(0.0)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::mis::power_heuristic as scalar;

    #[test]
    fn lane_power_heuristic_equals_the_scalar_one() {
        let vals = [
            0.0,
            -0.0,
            1e-30,
            1e-20,
            0.3,
            1.0,
            7.5,
            1e18,
            1e20,
            3e38,
            f32::INFINITY,
            -f32::INFINITY,
            f32::NAN,
            -2.0,
        ];
        for &a in &vals {
            for &b in &vals {
                let (w, s) = (power_heuristic(a, b), scalar(a, b));
                assert!(w.to_bits() == s.to_bits(), "({a}, {b}): {w} vs {s}");
                #[cfg(target_arch = "x86_64")]
                if let Some(avx) = crate::lane::Avx2::detect() {
                    let w8 = avx.run(|| power_heuristic(avx.splat(a), avx.splat(b)));
                    assert!(w8.lane(3).to_bits() == s.to_bits(), "({a}, {b}) at width 8");
                }
            }
        }
    }
}
