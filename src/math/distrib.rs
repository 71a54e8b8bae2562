//! A discrete distribution sampled by inverting its CDF (light selection, triangle picking).

#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    /// Normalised CDF, `cdf[0] = 0`, `cdf[n] = 1`.
    cdf: Vec<f32>,
    pmf: Vec<f32>,
}

impl Distribution1D {
    /// From non-negative weights; `None` when they are all zero, negative or not finite.
    pub fn new(weights: &[f32]) -> Option<Distribution1D> {
        if weights.is_empty() || weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        if !(total > 0.0) {
            return None;
        }
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        cdf.push(0.0f32);
        let mut acc = 0.0f64;
        for &w in weights {
            acc += w as f64;
            cdf.push((acc / total) as f32);
        }
        *cdf.last_mut().unwrap() = 1.0;
        let pmf = weights.iter().map(|&w| (w as f64 / total) as f32).collect();
        Some(Distribution1D { cdf, pmf })
    }

    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    /// Probability of index `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }

    /// Pick an index with `u ∈ [0,1)`; returns (index, probability, `u` rescaled to [0,1) within
    /// the chosen bin so it can be reused).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        // Largest i with cdf[i] <= u, restricted to bins with non-zero mass.
        let n = self.pmf.len();
        let mut i = self.cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n - 1);
        while self.pmf[i] == 0.0 && i + 1 < n {
            i += 1;
        }
        while self.pmf[i] == 0.0 && i > 0 {
            i -= 1;
        }
        let width = self.cdf[i + 1] - self.cdf[i];
        let ur = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
        } else {
            0.5
        };
        (i, self.pmf[i], ur)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn samples_follow_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]).unwrap();
        let mut counts = [0usize; 3];
        let n = 40_000;
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, p, ur) = d.sample(u);
            assert!((0.0..1.0).contains(&ur));
            assert_eq!(p, d.pmf(i));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        assert!((counts[0] as f32 / n as f32 - 0.25).abs() < 1e-3);
        assert!(Distribution1D::new(&[0.0, 0.0]).is_none());
        assert!(Distribution1D::new(&[f32::NAN]).is_none());
    }
}
