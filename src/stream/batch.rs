//! A batch of paths in structure-of-arrays form, allocated once per worker and reused for every
//! batch it renders (no allocation per ray), with the two list operations of the scheduler: the
//! stable counting sort of the active paths by material and the stable compaction.

use crate::geometry::{Hit, Ray, SurfaceInteraction};
use crate::integrator::path::{PathState, PendingLight};
use crate::material::MatId;
use crate::sampler::Sampler;
use glam::Vec2;

/// The per-path arrays of one batch, indexed by the path's position in the batch (its place in
/// the block's canonical (y, x, sample) order), and the lists of path ids the stages walk.
pub(crate) struct Batch {
    /// Film position of each path's camera sample.
    pub pos: Vec<Vec2>,
    /// Each path's random stream, keyed by (seed, pixel, sample) as in the scalar renderer.
    pub sampler: Vec<Sampler>,
    pub state: Vec<PathState>,
    /// The ray each path traces next.
    pub ray: Vec<Ray>,
    /// What the last trace found.
    pub hit: Vec<Option<Hit>>,
    /// The surface each path scatters at (set by the emission stage for the paths that go on).
    pub si: Vec<Option<SurfaceInteraction>>,
    /// The light sample whose shadow ray is pending.
    pub light: Vec<Option<PendingLight>>,
    /// Whether the path goes on after the shading stage.
    pub alive: Vec<bool>,
    /// Material of the surface each path scatters at (the sort key).
    pub material: Vec<MatId>,
    /// Ids of the paths to trace, ascending.
    pub active: Vec<u32>,
    /// Ids of the paths that scatter at this bounce, ascending (before the sort).
    pub scatter: Vec<u32>,
    /// `scatter` stably sorted by material.
    pub sorted: Vec<u32>,
    /// Ids of the paths with a pending shadow ray, ascending.
    pub shadow: Vec<u32>,
    /// Counting-sort bins: one per material id, plus one.
    bins: Vec<u32>,
    /// Light points the 8-wide kernels sampled in lanes since the shading stage last took
    /// them, per kind (`LaneCounters::kernel_lights`).
    pub light_lanes: [u64; crate::stream::kernels::light::KINDS],
}

impl Batch {
    /// Buffers for batches of up to `capacity` paths over materials `0..materials`.
    pub fn new(capacity: usize, materials: usize) -> Batch {
        Batch {
            pos: Vec::with_capacity(capacity),
            sampler: Vec::with_capacity(capacity),
            state: Vec::with_capacity(capacity),
            ray: Vec::with_capacity(capacity),
            hit: Vec::with_capacity(capacity),
            si: Vec::with_capacity(capacity),
            light: Vec::with_capacity(capacity),
            alive: Vec::with_capacity(capacity),
            material: Vec::with_capacity(capacity),
            active: Vec::with_capacity(capacity),
            scatter: Vec::with_capacity(capacity),
            sorted: Vec::with_capacity(capacity),
            shadow: Vec::with_capacity(capacity),
            bins: vec![0; materials + 1],
            light_lanes: [0; crate::stream::kernels::light::KINDS],
        }
    }

    /// Empties the batch (capacities are kept).
    pub fn clear(&mut self) {
        self.pos.clear();
        self.sampler.clear();
        self.state.clear();
        self.ray.clear();
        self.hit.clear();
        self.si.clear();
        self.light.clear();
        self.alive.clear();
        self.material.clear();
        self.active.clear();
        self.scatter.clear();
        self.sorted.clear();
        self.shadow.clear();
    }

    /// Adds a path whose camera ray is `ray`.
    pub fn push(&mut self, pos: Vec2, sampler: Sampler, ray: Ray) {
        self.pos.push(pos);
        self.sampler.push(sampler);
        self.state.push(PathState::new());
        self.ray.push(ray);
        self.hit.push(None);
        self.si.push(None);
        self.light.push(None);
        self.alive.push(false);
        self.material.push(0);
    }

    /// Number of paths in the batch.
    pub fn len(&self) -> usize {
        self.pos.len()
    }

    /// Sorts `scatter` by `material` into `sorted`, stably (a counting sort: equal materials keep
    /// their ascending path order). Returns whether `sorted` holds more than one material.
    pub fn sort_by_material(&mut self) -> bool {
        self.sorted.clear();
        let Some(&first) = self.scatter.first() else {
            return false;
        };
        let m0 = self.material[first as usize];
        if self
            .scatter
            .iter()
            .all(|&i| self.material[i as usize] == m0)
        {
            self.sorted.extend_from_slice(&self.scatter);
            return false;
        }
        self.bins.fill(0);
        for &i in &self.scatter {
            self.bins[self.material[i as usize] as usize + 1] += 1;
        }
        for k in 1..self.bins.len() {
            self.bins[k] += self.bins[k - 1];
        }
        self.sorted.resize(self.scatter.len(), 0);
        for &i in &self.scatter {
            let b = &mut self.bins[self.material[i as usize] as usize];
            self.sorted[*b as usize] = i;
            *b += 1;
        }
        true
    }

    /// Keeps in `active` the paths still alive, in ascending order (stable compaction).
    pub fn compact(&mut self) {
        let alive = &self.alive;
        self.active.retain(|&i| alive[i as usize]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn batch(materials: &[MatId]) -> Batch {
        let mut b = Batch::new(materials.len(), 8);
        for &m in materials {
            b.push(
                Vec2::ZERO,
                Sampler::from_seed(1, 1),
                Ray::new(Vec3::ZERO, Vec3::Z),
            );
            *b.material.last_mut().unwrap() = m;
        }
        b
    }

    #[test]
    fn the_material_sort_is_stable() {
        let mut b = batch(&[3, 1, 3, 0, 1, 7, 3]);
        b.scatter.extend([0, 1, 2, 4, 5, 6]);
        assert!(b.sort_by_material());
        assert_eq!(b.sorted, [1, 4, 0, 2, 6, 5]);
        b.scatter.clear();
        b.scatter.extend([0, 2, 6]);
        assert!(!b.sort_by_material());
        assert_eq!(b.sorted, [0, 2, 6]);
    }

    #[test]
    fn compaction_keeps_the_order() {
        let mut b = batch(&[0; 6]);
        b.active.extend([0, 1, 2, 3, 4, 5]);
        for i in [1, 2, 5] {
            b.alive[i] = true;
        }
        b.compact();
        assert_eq!(b.active, [1, 2, 5]);
    }
}
