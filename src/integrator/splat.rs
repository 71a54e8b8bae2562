//! The light tracer's image: contributions splatted at arbitrary film positions through the
//! reconstruction filter, as Mitsuba 3's `ImageBlock::put` does for its adjoint integrators
//! (`AdjointIntegrator::render` creates its blocks with `normalize = true`, no border, and
//! develops without a weight division):
//! - the box filter (radius ½) adds the value to the one pixel that contains the position;
//! - any other filter spreads it over the pixels whose centres lie within its radius with the
//!   tabulated separable weights, divided by the sum of those weights over the full footprint
//!   (so every splat carries its value exactly once, wherever it lands), and drops the weight of
//!   pixels outside the crop window.
//!
//! The buffers are allocated once per render (one per worker and one for the slice being
//! summed); a splat allocates nothing.

use crate::film::{FilmDesc, Filter};
use crate::math::Vec2;
use crate::spectrum::Spectrum;

/// Resolution of Mitsuba's tabulated filter (`MI_FILTER_RESOLUTION`); the table holds the filter
/// at x = radius·i/31 (left ends of the bins), then 0 (`eval_discretized`).
const FILTER_RESOLUTION: usize = 31;

/// Sums of splatted values over the crop window, row-major.
#[derive(Clone, Debug)]
pub struct SplatImage {
    /// Crop window in full-film pixels: x0, y0, w, h.
    crop: (u32, u32, u32, u32),
    is_box: bool,
    radius: f32,
    table: [f32; FILTER_RESOLUTION + 1],
    table_scale: f32,
    /// Filter taps per axis of the normalisation (Mitsuba's `count_max` = ⌈2·radius⌉).
    count_max: usize,
    /// Scratch weights per axis (allocated once; a footprint has at most `count_max` + 1 taps).
    wx: Vec<f32>,
    wy: Vec<f32>,
    data: Vec<[f32; 3]>,
}

/// The crop window of `desc` clamped to the film (as the film clamps it).
pub fn crop_of(desc: &FilmDesc) -> (u32, u32, u32, u32) {
    let x0 = desc.crop_offset.0.min(desc.width);
    let y0 = desc.crop_offset.1.min(desc.height);
    let w = desc.crop_size.0.min(desc.width - x0);
    let h = desc.crop_size.1.min(desc.height - y0);
    (x0, y0, w, h)
}

/// Most filter taps per axis a splat evaluates (a larger radius is refused by the caller).
pub const MAX_TAPS: usize = 4096;

impl SplatImage {
    /// An empty image for `desc`'s crop window and filter. The caller has checked that the
    /// filter's radius is finite and its footprint below [`MAX_TAPS`] taps.
    pub fn new(desc: &FilmDesc) -> SplatImage {
        let crop = crop_of(desc);
        let filter: Filter = desc.filter;
        let r = filter.radius();
        let mut table = [0.0f32; FILTER_RESOLUTION + 1];
        for (i, v) in table.iter_mut().take(FILTER_RESOLUTION).enumerate() {
            *v = filter.eval(r * i as f32 / FILTER_RESOLUTION as f32);
        }
        let count_max = ((2.0 * r).ceil() as usize).clamp(1, MAX_TAPS);
        SplatImage {
            crop,
            is_box: r == 0.5,
            radius: r,
            table,
            table_scale: FILTER_RESOLUTION as f32 / r,
            count_max,
            wx: vec![0.0; count_max + 1],
            wy: vec![0.0; count_max + 1],
            data: vec![[0.0; 3]; crop.2 as usize * crop.3 as usize],
        }
    }

    /// Bytes an image for `desc` takes (for the memory budget).
    pub fn bytes(desc: &FilmDesc) -> u64 {
        let (_, _, w, h) = crop_of(desc);
        w as u64 * h as u64 * 12
    }

    /// Zero every pixel (keeps the allocation).
    pub fn clear(&mut self) {
        self.data.iter_mut().for_each(|p| *p = [0.0; 3]);
    }

    /// Adds `other`'s pixel sums (an image of the same film) to this one's.
    pub fn add(&mut self, other: &SplatImage) {
        debug_assert_eq!(self.crop, other.crop);
        for (p, q) in self.data.iter_mut().zip(&other.data) {
            for c in 0..3 {
                p[c] += q[c];
            }
        }
    }

    /// The pixel sums of the crop window, row-major.
    pub fn pixels(&self) -> &[[f32; 3]] {
        &self.data
    }

    #[inline]
    fn tap(&self, x: f32) -> f32 {
        let i = ((x * self.table_scale).abs() as usize).min(FILTER_RESOLUTION);
        self.table[i]
    }

    /// Adds `value` at the full-film position `pos` (see the module comment). Non-finite
    /// positions are ignored.
    pub fn put(&mut self, pos: Vec2, value: Spectrum) {
        if !pos.is_finite() {
            return;
        }
        let (cx, cy, cw, ch) = self.crop;
        let v = value.to_array();
        if self.is_box {
            let px = crate::math::floor(pos.x) as i64 - cx as i64;
            let py = crate::math::floor(pos.y) as i64 - cy as i64;
            if px >= 0 && py >= 0 && px < cw as i64 && py < ch as i64 {
                let p = &mut self.data[py as usize * cw as usize + px as usize];
                for c in 0..3 {
                    p[c] += v[c];
                }
            }
            return;
        }
        let r = self.radius;
        let fx = pos.x - cx as f32 - 0.5;
        let fy = pos.y - cy as f32 - 0.5;
        let (x0f, y0f) = ((fx - r).ceil(), (fy - r).ceil());
        // Normalisation over the whole footprint, clipped or not (Mitsuba's `factor`).
        let (mut sx, mut sy) = (0.0f32, 0.0f32);
        for i in 0..self.count_max {
            sx += self.tap(x0f + i as f32 - fx);
            sy += self.tap(y0f + i as f32 - fy);
        }
        let norm = sx * sy;
        if !(norm > 0.0 && norm.is_finite()) {
            return;
        }
        let inv = 1.0 / norm;
        let x_lo = (x0f as i64).max(0);
        let y_lo = (y0f as i64).max(0);
        let x_hi = (crate::math::floor(fx + r) as i64).min(cw as i64 - 1);
        let y_hi = (crate::math::floor(fy + r) as i64).min(ch as i64 - 1);
        if x_lo > x_hi || y_lo > y_hi {
            return;
        }
        let nx = ((x_hi - x_lo + 1) as usize).min(self.wx.len());
        let ny = ((y_hi - y_lo + 1) as usize).min(self.wy.len());
        for i in 0..nx {
            self.wx[i] = self.tap(x_lo as f32 + i as f32 - fx) * inv;
        }
        for j in 0..ny {
            self.wy[j] = self.tap(y_lo as f32 + j as f32 - fy);
        }
        let w = cw as usize;
        for j in 0..ny {
            let row = (y_lo as usize + j) * w + x_lo as usize;
            let wyj = self.wy[j];
            for i in 0..nx {
                let k = self.wx[i] * wyj;
                let p = &mut self.data[row + i];
                for c in 0..3 {
                    p[c] += v[c] * k;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn desc(filter: Filter) -> FilmDesc {
        FilmDesc {
            width: 16,
            height: 12,
            crop_offset: (2, 1),
            crop_size: (10, 8),
            filter,
            second_moments: true,
        }
    }

    fn total(img: &SplatImage) -> f32 {
        img.pixels().iter().map(|p| p[0]).sum()
    }

    #[test]
    fn an_interior_splat_keeps_its_value_under_every_filter() {
        for f in [
            Filter::Box,
            Filter::Tent { radius: 1.0 },
            Filter::gaussian(0.5),
            Filter::Tent { radius: 1.7 },
        ] {
            let mut img = SplatImage::new(&desc(f));
            img.put(Vec2::new(7.3, 5.8), Spectrum::splat(2.0));
            assert!((total(&img) - 2.0).abs() < 1e-5, "{f:?}: {}", total(&img));
        }
    }

    #[test]
    fn box_splats_land_in_their_pixel_and_outside_the_crop_vanish() {
        let mut img = SplatImage::new(&desc(Filter::Box));
        img.put(Vec2::new(2.0, 1.0), Spectrum::splat(1.0));
        img.put(Vec2::new(11.99, 8.5), Spectrum::splat(3.0));
        img.put(Vec2::new(1.9, 4.0), Spectrum::splat(5.0));
        img.put(Vec2::new(12.0, 4.0), Spectrum::splat(5.0));
        img.put(Vec2::new(f32::NAN, 4.0), Spectrum::splat(5.0));
        assert_eq!(img.pixels()[0][0], 1.0);
        assert_eq!(img.pixels()[7 * 10 + 9][0], 3.0);
        assert_eq!(total(&img), 4.0);
    }

    #[test]
    fn a_splat_at_the_crop_edge_loses_the_part_outside() {
        // A tent of radius 1 centred on the left crop edge: half of its weight is outside.
        let mut img = SplatImage::new(&desc(Filter::Tent { radius: 1.0 }));
        img.put(Vec2::new(2.0, 5.5), Spectrum::splat(1.0));
        assert!((total(&img) - 0.5).abs() < 0.05, "{}", total(&img));
        assert!(total(&img) < 1.0);
    }
}
