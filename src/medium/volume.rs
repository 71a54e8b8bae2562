//! Volume data sources of heterogeneous media (Mitsuba 3's `Volume` plugins): `constvolume` and
//! `gridvolume`. A volume maps a world point to a value (1 or 3 channels, returned as RGB) through
//! `to_local` (the inverse of `to_world`) into its unit cube [0, 1]³; its world bounding box is the
//! axis-aligned box of that cube's eight corners (Mitsuba's `Volume::update_bbox`), which is where
//! a heterogeneous medium lives.
//!
//! # `gridvolume` XML parameters (Mitsuba 3.9.1 names and defaults)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `filename` | string | required | a Mitsuba `.vol` file ([`crate::geometry::volfile`]) of 1 or 3 float32 channels; Mitsuba's `grid` / `data` objects exist only from Python or C++ |
//! | `filter_type` | string | `trilinear` | `trilinear` or `nearest` |
//! | `wrap_mode` | string | `clamp` | `clamp`, `repeat` or `mirror`: which voxels a lookup outside [0, 1]³ (or in the outer half voxel) reads |
//! | `use_grid_bbox` | boolean | false | map the file's bounding box (instead of the unit cube) through `to_world` |
//! | `to_world` | transform | identity | places the volume's unit cube (or the file's box) in the scene |
//! | `max_value` | float | the grid's maximum | Mitsuba's fixed maximum, used for the majorant; groove rejects one below the grid's maximum (it would bias the tracking) |
//! | `raw` | boolean | false | no effect in RGB (Mitsuba's spectral upsampling switch) |
//! | `accel` | boolean | true | no effect on the CPU (Mitsuba's CUDA texture switch) |
//!
//! `constvolume` takes a float or rgb `value` (default 1) and `to_world`.
//!
//! Lookups follow Dr.Jit's `Texture::eval_nonaccel`, which Mitsuba's CPU variants use: voxel
//! centres sit at (i + ½)/n; trilinear reads the 2×2×2 voxels around p·n − ½ with weights from
//! its fractional part, nearest reads voxel ⌊p·n⌋; each index is wrapped by `wrap_mode`.

use crate::geometry::volfile::VolGrid;
use crate::spectrum::Spectrum;
use glam::{Mat4, Vec3};

/// How voxel values are interpolated (`filter_type`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    Trilinear,
    Nearest,
}

/// Which voxel an index outside the grid reads (`wrap_mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Clamp,
    Repeat,
    Mirror,
}

impl Filter {
    pub fn parse(s: &str) -> Option<Filter> {
        match s {
            "trilinear" => Some(Filter::Trilinear),
            "nearest" => Some(Filter::Nearest),
            _ => None,
        }
    }
}

impl Wrap {
    pub fn parse(s: &str) -> Option<Wrap> {
        match s {
            "clamp" => Some(Wrap::Clamp),
            "repeat" => Some(Wrap::Repeat),
            "mirror" => Some(Wrap::Mirror),
            _ => None,
        }
    }

    /// Index `i` of an axis of `n` voxels, wrapped into 0..n.
    #[inline]
    fn apply(self, i: i32, n: i32) -> i32 {
        match self {
            Wrap::Clamp => i.clamp(0, n - 1),
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - 1 - m
                } else {
                    m
                }
            }
        }
    }
}

/// A voxel grid of 1 or 3 channels with its lookup mode.
#[derive(Clone, Debug)]
pub struct Grid {
    /// Voxels along x, y, z.
    n: [i32; 3],
    /// 1 or 3.
    channels: usize,
    /// Values, channel fastest, then x, y, z (the file's order).
    data: Vec<f32>,
    filter: Filter,
    wrap: Wrap,
    /// Largest value over all voxels and channels (Mitsuba's `VolumeGrid::max`).
    max: f32,
}

impl Grid {
    /// A grid from a `.vol` file's contents. Errors: a channel count other than 1 or 3, a
    /// non-finite or negative value (with its voxel), a size beyond i32 indexing.
    pub fn new(g: VolGrid, filter: Filter, wrap: Wrap) -> Result<Grid, String> {
        if g.channels != 1 && g.channels != 3 {
            return Err(format!(
                "a medium's volume needs 1 or 3 channels, this grid has {}",
                g.channels
            ));
        }
        let mut n = [0i32; 3];
        for (k, s) in g.size.iter().enumerate() {
            n[k] = i32::try_from(*s).map_err(|_| format!("grid size {s} is too large"))?;
        }
        let ch = g.channels as usize;
        let mut max = 0.0f32;
        for (i, &v) in g.data.iter().enumerate() {
            if !(v.is_finite() && v >= 0.0) {
                let voxel = i / ch;
                let x = voxel % n[0] as usize;
                let y = voxel / n[0] as usize % n[1] as usize;
                let z = voxel / (n[0] as usize * n[1] as usize);
                return Err(format!(
                    "value {v} at voxel (x {x}, y {y}, z {z}), channel {}: values must be finite \
                     and >= 0",
                    i % ch
                ));
            }
            max = max.max(v);
        }
        Ok(Grid {
            n,
            channels: ch,
            data: g.data,
            filter,
            wrap,
            max,
        })
    }

    /// The largest value over all voxels and channels (or the `max_value` given instead).
    pub fn max(&self) -> f32 {
        self.max
    }

    /// Mitsuba's `max_value`: a fixed maximum instead of the grid's (the caller checks that it
    /// bounds the values).
    pub fn set_max(&mut self, m: f32) {
        self.max = m;
    }

    /// The value of voxel (x, y, z), indices already wrapped.
    #[inline]
    fn voxel(&self, x: usize, y: usize, z: usize) -> Spectrum {
        let i = ((z * self.n[1] as usize + y) * self.n[0] as usize + x) * self.channels;
        if self.channels == 1 {
            Spectrum::splat(self.data[i])
        } else {
            Vec3::new(self.data[i], self.data[i + 1], self.data[i + 2])
        }
    }

    /// Axis `k`'s index `i`, wrapped.
    #[inline]
    fn wrapped(&self, i: i32, k: usize) -> usize {
        self.wrap.apply(i, self.n[k]) as usize
    }

    /// The value at `p` in the grid's unit cube.
    #[inline]
    pub fn eval(&self, p: Vec3) -> Spectrum {
        let res = Vec3::new(self.n[0] as f32, self.n[1] as f32, self.n[2] as f32);
        match self.filter {
            Filter::Nearest => {
                let f = (p * res).floor();
                self.voxel(
                    self.wrapped(f.x as i32, 0),
                    self.wrapped(f.y as i32, 1),
                    self.wrapped(f.z as i32, 2),
                )
            }
            Filter::Trilinear => {
                let f = p * res - Vec3::splat(0.5);
                let i = f.floor();
                let w1 = f - i;
                let w0 = Vec3::ONE - w1;
                // The two wrapped indices per axis, computed once (not per corner).
                let (x, y, z) = (i.x as i32, i.y as i32, i.z as i32);
                let xs = [self.wrapped(x, 0), self.wrapped(x + 1, 0)];
                let ys = [self.wrapped(y, 1), self.wrapped(y + 1, 1)];
                let zs = [self.wrapped(z, 2), self.wrapped(z + 1, 2)];
                let wx = [w0.x, w1.x];
                let wy = [w0.y, w1.y];
                let wz = [w0.z, w1.z];
                let mut v = Spectrum::ZERO;
                for (&zi, &wzi) in zs.iter().zip(&wz) {
                    for (&yi, &wyi) in ys.iter().zip(&wy) {
                        let wyz = wyi * wzi;
                        for (&xi, &wxi) in xs.iter().zip(&wx) {
                            v += self.voxel(xi, yi, zi) * (wxi * wyz);
                        }
                    }
                }
                v
            }
        }
    }
}

/// What a volume holds.
#[derive(Clone, Debug)]
pub enum VolumeData {
    /// `constvolume`: one value everywhere.
    Const(Spectrum),
    /// `gridvolume`.
    Grid(Grid),
}

/// A volume placed in the scene.
#[derive(Clone, Debug)]
pub struct Volume {
    pub data: VolumeData,
    /// World → the volume's unit cube.
    pub to_local: Mat4,
    /// World bounding box (min, max) of the unit cube's corners under `to_world`.
    pub bbox: (Vec3, Vec3),
}

impl Volume {
    /// A volume of `data` whose unit cube `to_world` places; `to_local` is its inverse (Mitsuba's,
    /// which can differ from the true one, see `crate::scene::xml::transform`).
    pub fn new(data: VolumeData, to_world: &Mat4, to_local: Mat4) -> Volume {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for c in 0..8 {
            let corner = Vec3::new((c & 1) as f32, (c >> 1 & 1) as f32, (c >> 2 & 1) as f32);
            let q = to_world.transform_point3(corner);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        Volume {
            data,
            to_local,
            bbox: (lo, hi),
        }
    }

    /// A constant with the identity placement (what a `<float>`/`<rgb>` parameter becomes).
    pub fn constant(v: Spectrum) -> Volume {
        Volume::new(VolumeData::Const(v), &Mat4::IDENTITY, Mat4::IDENTITY)
    }

    /// The value at world point `p`.
    #[inline]
    pub fn eval(&self, p: Vec3) -> Spectrum {
        match &self.data {
            VolumeData::Const(v) => *v,
            VolumeData::Grid(g) => g.eval(self.to_local.transform_point3(p)),
        }
    }

    /// The largest value the volume takes, over its channels (Mitsuba's `Volume::max`).
    pub fn max(&self) -> f32 {
        match &self.data {
            VolumeData::Const(v) => v.max_element(),
            VolumeData::Grid(g) => g.max(),
        }
    }

    /// The parameter interval [t0, t1] ∩ [0, t_max] of the ray o + t·d inside the world bounding
    /// box (slab test), or `None` when it misses.
    #[inline]
    pub fn clip(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let inv = d.recip();
        let a = (self.bbox.0 - o) * inv;
        let b = (self.bbox.1 - o) * inv;
        // NaN (0·∞ for a ray in a slab's plane) is dropped by min/max: that axis does not clip.
        let t0 = a.min(b).max_element().max(0.0);
        let t1 = a.max(b).min_element().min(t_max);
        (t0 <= t1).then_some((t0, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: [u32; 3], channels: u32, data: Vec<f32>, filter: Filter, wrap: Wrap) -> Grid {
        Grid::new(
            VolGrid {
                size: n,
                channels,
                bbox: [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
                data,
            },
            filter,
            wrap,
        )
        .unwrap()
    }

    /// A 2×2×2 grid with value x + 2y + 4z at voxel (x, y, z): trilinear lookups at hand-computed
    /// points (voxel centres at 0.25 and 0.75 on each axis).
    #[test]
    fn trilinear_lookup_matches_hand_values() {
        let data: Vec<f32> = (0..8).map(|i| i as f32).collect();
        let g = grid([2, 2, 2], 1, data, Filter::Trilinear, Wrap::Clamp);
        // Voxel centres read their voxel.
        assert_eq!(g.eval(Vec3::new(0.25, 0.25, 0.25)).x, 0.0);
        assert_eq!(g.eval(Vec3::new(0.75, 0.75, 0.75)).x, 7.0);
        assert_eq!(g.eval(Vec3::new(0.75, 0.25, 0.75)).x, 5.0);
        // The centre of the grid: the mean of all eight, 3.5.
        assert!((g.eval(Vec3::splat(0.5)).x - 3.5).abs() < 1e-6);
        // x = 0.375 is a quarter of the way from centre 0.25 to 0.75: 0.25·1 + 2·0 + 4·0.
        assert!((g.eval(Vec3::new(0.375, 0.25, 0.25)).x - 0.25).abs() < 1e-6);
        // (0.6, 0.4, 0.3): weights x 0.7, y 0.3, z 0.1 → 0.7 + 2·0.3 + 4·0.1 = 1.7.
        assert!((g.eval(Vec3::new(0.6, 0.4, 0.3)).x - 1.7).abs() < 1e-5);
        // Clamp: the outer half voxel is constant along that axis.
        assert_eq!(g.eval(Vec3::new(0.1, 0.25, 0.25)).x, 0.0);
        assert_eq!(g.eval(Vec3::new(0.99, 0.25, 0.25)).x, 1.0);
    }

    #[test]
    fn nearest_lookup_wrap_modes_and_rgb_channels() {
        // 3 voxels along x, 1 along y and z, rgb = (i, 10 i, 100 i).
        let data = vec![0.0, 0.0, 0.0, 1.0, 10.0, 100.0, 2.0, 20.0, 200.0];
        let g = grid([3, 1, 1], 3, data.clone(), Filter::Nearest, Wrap::Clamp);
        assert_eq!(
            g.eval(Vec3::new(0.5, 0.5, 0.5)),
            Vec3::new(1.0, 10.0, 100.0)
        );
        assert_eq!(
            g.eval(Vec3::new(0.9, 0.5, 0.5)),
            Vec3::new(2.0, 20.0, 200.0)
        );
        assert_eq!(g.eval(Vec3::new(1.2, 0.5, 0.5)).x, 2.0);
        let r = grid([3, 1, 1], 3, data.clone(), Filter::Nearest, Wrap::Repeat);
        assert_eq!(r.eval(Vec3::new(1.1, 0.5, 0.5)).x, 0.0);
        assert_eq!(r.eval(Vec3::new(-0.1, 0.5, 0.5)).x, 2.0);
        let m = grid([3, 1, 1], 3, data, Filter::Nearest, Wrap::Mirror);
        assert_eq!(m.eval(Vec3::new(1.1, 0.5, 0.5)).x, 2.0);
        assert_eq!(m.eval(Vec3::new(1.5, 0.5, 0.5)).x, 1.0);
        assert_eq!(m.eval(Vec3::new(-0.1, 0.5, 0.5)).x, 0.0);
    }

    #[test]
    fn bad_values_and_channel_counts_are_refused() {
        let mk = |channels: u32, data: Vec<f32>| {
            Grid::new(
                VolGrid {
                    size: [2, 1, 1],
                    channels,
                    bbox: [0.0; 6],
                    data,
                },
                Filter::Trilinear,
                Wrap::Clamp,
            )
        };
        let e = mk(1, vec![1.0, f32::NAN]).unwrap_err();
        assert!(e.contains("voxel (x 1, y 0, z 0)"), "{e}");
        assert!(mk(1, vec![-1.0, 0.0]).is_err());
        assert!(mk(2, vec![1.0; 4]).unwrap_err().contains("1 or 3 channels"));
    }

    #[test]
    fn bounding_box_and_clipping() {
        let to_world = Mat4::from_scale_rotation_translation(
            Vec3::splat(2.0),
            glam::Quat::IDENTITY,
            Vec3::new(-1.0, 0.0, 0.0),
        );
        let v = Volume::new(
            VolumeData::Const(Spectrum::ONE),
            &to_world,
            to_world.inverse(),
        );
        assert_eq!(
            v.bbox,
            (Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 2.0, 2.0))
        );
        let (t0, t1) = v
            .clip(Vec3::new(-5.0, 1.0, 1.0), Vec3::X, f32::INFINITY)
            .unwrap();
        assert!((t0 - 4.0).abs() < 1e-6 && (t1 - 6.0).abs() < 1e-6);
        assert!(v.clip(Vec3::new(-5.0, 1.0, 1.0), Vec3::X, 3.0).is_none());
        assert!(v.clip(Vec3::new(-5.0, 3.0, 1.0), Vec3::X, 100.0).is_none());
        let (t0, t1) = v.clip(Vec3::new(0.0, 1.0, 1.0), Vec3::Y, 0.5).unwrap();
        assert!(t0 == 0.0 && t1 == 0.5);
    }
}
