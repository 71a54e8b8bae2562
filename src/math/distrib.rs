//! Discrete distributions sampled by inverting their CDFs: `Distribution1D` (light selection,
//! triangle picking) and the piecewise-constant 2-D density `Distribution2D` (environment maps).

use glam::Vec2;

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
        if total.is_nan() || total <= 0.0 {
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

    /// Up to this many bins, [`Self::sample`] counts the CDF entries <= u instead of searching.
    const COUNTED: usize = 8;

    /// The normalised CDF (`len() + 1` entries, from 0 to 1).
    #[inline]
    pub fn cdf(&self) -> &[f32] {
        &self.cdf
    }

    /// Whether [`Self::sample`] counts the CDF entries `<= u` (few bins) rather than searching
    /// (the count and the search give the same `prefix`).
    #[inline]
    pub fn is_counted(&self) -> bool {
        self.len() <= Self::COUNTED
    }

    /// The bin [`Self::sample`] picks when `prefix` CDF entries are `<= u`: the last bin
    /// starting at or below `u`, moved to the next bin of non-zero mass (up, then down). The
    /// 8-wide light selection looks it up per count (`stream::kernels::light`).
    #[inline]
    pub fn bin_of_prefix(&self, prefix: usize) -> usize {
        let n = self.pmf.len();
        let mut i = prefix.saturating_sub(1).min(n - 1);
        while self.pmf[i] == 0.0 && i + 1 < n {
            i += 1;
        }
        while self.pmf[i] == 0.0 && i > 0 {
            i -= 1;
        }
        i
    }

    /// Pick an index with `u ∈ [0,1)`; returns (index, probability, `u` rescaled to [0,1) within
    /// the chosen bin so it can be reused).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32, f32) {
        // Largest i with cdf[i] <= u, restricted to bins with non-zero mass. The CDF does not
        // decrease, so the entries <= u are a prefix: its length is the partition point, and a
        // count for a few bins (light selection: one per emitter) is cheaper than the search
        // and gives the same index.
        let n = self.pmf.len();
        let prefix = if n <= Self::COUNTED {
            self.cdf.iter().map(|&c| (c <= u) as usize).sum()
        } else {
            self.cdf.partition_point(|&c| c <= u)
        };
        let i = self.bin_of_prefix(prefix);
        let width = self.cdf[i + 1] - self.cdf[i];
        let ur = if width > 0.0 {
            ((u - self.cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
        } else {
            0.5
        };
        (i, self.pmf[i], ur)
    }
}

/// A piecewise-constant density on the unit square over an `nx` × `ny` grid of cells, sampled by
/// a marginal distribution over rows and a conditional distribution within the chosen row
/// (pbrt 3rd ed., §13.6.7). Densities are with respect to area on \[0,1\]².
#[derive(Clone, Debug)]
pub struct Distribution2D {
    nx: usize,
    ny: usize,
    /// Which row (y index) to sample, by row total.
    marginal: Distribution1D,
    /// Column distribution of each row (`None` for rows of zero weight, never picked).
    rows: Vec<Option<Distribution1D>>,
}

impl Distribution2D {
    /// From `nx * ny` non-negative cell weights, row-major (`w[y * nx + x]`). `None` when the
    /// weights are all zero, negative or not finite, or the size does not match.
    pub fn new(weights: &[f32], nx: usize, ny: usize) -> Option<Distribution2D> {
        if nx == 0 || ny == 0 || weights.len() != nx.checked_mul(ny)? {
            return None;
        }
        if weights.iter().any(|w| !(w.is_finite() && *w >= 0.0)) {
            return None;
        }
        let rows: Vec<Option<Distribution1D>> =
            weights.chunks_exact(nx).map(Distribution1D::new).collect();
        let totals: Vec<f32> = weights
            .chunks_exact(nx)
            .map(|r| r.iter().map(|&w| w as f64).sum::<f64>() as f32)
            .collect();
        let marginal = Distribution1D::new(&totals)?;
        Some(Distribution2D {
            nx,
            ny,
            marginal,
            rows,
        })
    }

    /// Grid size (nx, ny).
    pub fn size(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Probability of the cell (x, y).
    #[inline]
    pub fn cell_pmf(&self, x: usize, y: usize) -> f32 {
        match &self.rows[y] {
            Some(r) => self.marginal.pmf(y) * r.pmf(x),
            None => 0.0,
        }
    }

    /// A point of [0,1)² and its density, from `u ∈ [0,1)²`.
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (y, py, fy) = self.marginal.sample(u.y);
        // The marginal only picks rows of non-zero total, which have a column distribution.
        let Some(row) = self.rows[y].as_ref() else {
            return (Vec2::ZERO, 0.0);
        };
        // The rescaled randoms place the point uniformly within the chosen cell.
        let (x, px, fx) = row.sample(u.x);
        let p = Vec2::new(
            ((x as f32 + fx) / self.nx as f32).min(1.0 - f32::EPSILON / 2.0),
            ((y as f32 + fy) / self.ny as f32).min(1.0 - f32::EPSILON / 2.0),
        );
        (p, py * px * (self.nx * self.ny) as f32)
    }

    /// Density of the point `p` ∈ \[0,1\]² (the value `sample` reports for points it returns).
    #[inline]
    pub fn pdf(&self, p: Vec2) -> f32 {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return 0.0;
        }
        let x = ((p.x * self.nx as f32) as usize).min(self.nx - 1);
        let y = ((p.y * self.ny as f32) as usize).min(self.ny - 1);
        self.cell_pmf(x, y) * (self.nx * self.ny) as f32
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

    /// The counted prefix of [`Distribution1D::sample`] (up to `COUNTED` bins) is the
    /// partition point: the same bin for every `u`, at bin edges, outside [0, 1) and for NaN.
    #[test]
    fn counting_equals_the_search() {
        let weights: [&[f32]; 6] = [
            &[1.0],
            &[1.0, 3.0],
            &[0.0, 2.0, 0.0],
            &[0.5, 0.0, 0.0, 1e-30, 7.0, 0.0, 2.0, 1.0],
            &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            &[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        ];
        for w in weights {
            let d = Distribution1D::new(w).unwrap();
            assert!(d.len() <= Distribution1D::COUNTED);
            let mut us: Vec<f32> = d
                .cdf
                .iter()
                .flat_map(|&c| [c, c.next_down(), c.next_up()])
                .collect();
            us.extend((0..1000).map(|k| k as f32 / 1000.0));
            us.extend([-1.0, 2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY]);
            for u in us {
                let searched = d.cdf.partition_point(|&c| c <= u);
                let counted: usize = d.cdf.iter().map(|&c| (c <= u) as usize).sum();
                assert_eq!(counted, searched, "{w:?} u = {u}");
            }
        }
    }

    #[test]
    fn distribution2d_pdf_integrates_to_one_and_matches_weights() {
        let w = [1.0, 0.0, 2.0, 0.5, 0.0, 0.0, 3.0, 1.5];
        let d = Distribution2D::new(&w, 4, 2).unwrap();
        let total: f32 = w.iter().sum();
        for y in 0..2 {
            for x in 0..4 {
                let c = Vec2::new((x as f32 + 0.5) / 4.0, (y as f32 + 0.5) / 2.0);
                let expect = w[y * 4 + x] / total * 8.0;
                assert!((d.pdf(c) - expect).abs() < 1e-5, "cell {x},{y}");
            }
        }
        assert!(Distribution2D::new(&[0.0; 4], 2, 2).is_none());
        assert!(Distribution2D::new(&[1.0; 3], 2, 2).is_none());
        assert!(Distribution2D::new(&[1.0, f32::NAN], 2, 1).is_none());
    }
}
