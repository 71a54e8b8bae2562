//! The surface rows of the batch ([`crate::stream::batch::Surfaces`]): the gather stage that
//! fills them after each trace ([`fill`]: hits on triangle meshes, similarity spheres,
//! rectangles, disks and cylinders, and on meshes seen through instances, reconstructed 8 at a time by the
//! lane forms of [`crate::geometry::surface_lanes`], every other hit by `Scene::interaction`;
//! direct mesh hits wait in chunks of one mesh where they can, whose triangles, vertices,
//! normals and uvs are vector gathers, `x8::MeshChunks`), and the one surface load of the three kernels
//! ([`super::diffuse`], [`super::vertex`], [`super::plastic`]): 8 paths' surface points, true
//! normals, shading frames and incident directions, loaded 8-wide in place from the rows, one
//! `vgatherdps` per field over the 8 rows. The rows hold the scalar interaction's bits either way.

use crate::geometry::surface_lanes as sl;
use crate::lane::vec::{V2, V3};
use crate::scene::Scene;
use crate::stream::batch::Batch;
use glam::{Mat4, Vec3};

/// How the gather stage reconstructs a hit on a shape (instanced hits take the lane forms on
/// meshes only, `Scene::interaction` on other shapes).
#[derive(Clone, Debug)]
pub(crate) enum Form {
    /// A triangle mesh: [`crate::geometry::surface_lanes::triangle`]; a mesh of at most
    /// [`SMALL_TRIS`] triangles also as tables by triangle ([`SmallTris`]).
    Triangles(Option<Box<SmallTris>>),
    /// A sphere with a similarity `to_world`: centre, radius, uv rotation, `flip_normals` sign.
    Sphere(Vec3, f32, Mat4, f32),
    /// A rectangle: `to_object`, `to_world`, then signed true normal, signed shading normal,
    /// dp/du, dp/dv (`Shape::rectangle_lanes`).
    Rectangle(Box<(Mat4, Mat4, [Vec3; 4])>),
    /// A disk: `to_object`, `hit_to_world`, `to_world`, signed normal (`Shape::disk_lanes`).
    Disk(Box<(Mat4, Mat4, Mat4, Vec3)>),
    /// A cylinder: its constants (`Cylinder::lanes`) and `flip_normals` sign.
    Cylinder(Box<(crate::geometry::cylinder::CylinderLanes, f32)>),
    /// Anything else (curves, SDF grids, spheres through a `SphereMap`):
    /// `Scene::interaction`, one hit at a time.
    Scalar,
}

impl Form {
    /// Per shape of `scene`, its form (decided once, at load).
    pub(crate) fn table(scene: &Scene) -> Vec<Form> {
        use crate::geometry::ShapeKind;
        scene
            .shapes
            .iter()
            .map(|s| {
                if let ShapeKind::Mesh(m) = &s.kind {
                    Form::Triangles(SmallTris::new(m).map(Box::new))
                } else if let Some(c) = s.sphere_lanes() {
                    Form::Sphere(c.0, c.1, c.2, c.3)
                } else if let Some(r) = s.rectangle_lanes() {
                    Form::Rectangle(Box::new(r))
                } else if let Some(d) = s.disk_lanes() {
                    Form::Disk(Box::new(d))
                } else if let ShapeKind::Cylinder(c) = &s.kind {
                    let sign = if s.flip_normals { -1.0 } else { 1.0 };
                    Form::Cylinder(Box::new((c.lanes(), sign)))
                } else {
                    Form::Scalar
                }
            })
            .collect()
    }
}

/// The most triangles a mesh held as [`SmallTris`] has.
pub(crate) const SMALL_TRIS: usize = 16;

/// A mesh of at most [`SMALL_TRIS`] triangles (a Cornell box's wall, its light, its two
/// boxes of 12) as tables by triangle, built once at load: per corner, its position, vertex
/// normal and uv, component by component, 16 triangles wide (zero past the mesh's triangles and
/// for an attribute the mesh has not). The gather stage reads a chunk's corners from them by
/// permutes indexed by the triangle, instead of the vertex indices' gather and the position,
/// normal and uv gathers that depend on it: one `vpermps` per component for a mesh of at most 8
/// triangles (`lane::LaneLookup::lookup8` on the tables' first halves), two and a blend for
/// more (`Avx2::lookup16`; one at width 16, `Avx512::lookup16`). The same floats, so the same
/// rows. Also per triangle what its hits' interactions take from it alone (`c`: the face
/// normal before the `flip_normals` sign, dp/du, dp/dv; `surface_lanes::triangle_consts` at
/// width 1, the lane function's bits), looked up instead of computed per hit.
#[derive(Clone, Debug)]
pub(crate) struct SmallTris {
    p: [[[f32; SMALL_TRIS]; 3]; 3],
    n: [[[f32; SMALL_TRIS]; 3]; 3],
    uv: [[[f32; SMALL_TRIS]; 2]; 3],
    /// Per triangle its `TriangleConsts` `ng`, `dpdu`, `dpdv`, component by component (of
    /// `triangle_consts` with uvs where the mesh has them, without else: the form its chunks
    /// take).
    c: [[[f32; SMALL_TRIS]; 3]; 3],
    /// More than 8 triangles: the lookups read both halves.
    wide: bool,
}

impl SmallTris {
    /// The tables of `m`, or `None` when it has more than [`SMALL_TRIS`] triangles or a vertex
    /// index out of range of its positions, normals or uvs.
    fn new(m: &crate::geometry::mesh::TriMesh) -> Option<SmallTris> {
        let n = m.positions.len();
        let within = |len: Option<usize>| len.is_none_or(|l| l == n);
        if m.indices.len() > SMALL_TRIS
            || !within(m.normals.as_ref().map(Vec::len))
            || !within(m.uvs.as_ref().map(Vec::len))
            || m.indices.iter().flatten().any(|&i| i as usize >= n)
        {
            return None;
        }
        let mut s = SmallTris {
            p: [[[0.0; SMALL_TRIS]; 3]; 3],
            n: [[[0.0; SMALL_TRIS]; 3]; 3],
            uv: [[[0.0; SMALL_TRIS]; 2]; 3],
            c: [[[0.0; SMALL_TRIS]; 3]; 3],
            wide: m.indices.len() > 8,
        };
        for (t, tri) in m.indices.iter().enumerate() {
            for (c, &j) in tri.iter().enumerate() {
                let j = j as usize;
                for (k, x) in m.positions[j].to_array().into_iter().enumerate() {
                    s.p[c][k][t] = x;
                }
                if let Some(ns) = &m.normals {
                    for (k, x) in ns[j].to_array().into_iter().enumerate() {
                        s.n[c][k][t] = x;
                    }
                }
                if let Some(uvs) = &m.uvs {
                    (s.uv[c][0][t], s.uv[c][1][t]) = (uvs[j].x, uvs[j].y);
                }
            }
            let p = tri.map(|j| V3::from(m.positions[j as usize]));
            let consts = match &m.uvs {
                Some(uvs) => {
                    let uv = tri.map(|j| V2::new(uvs[j as usize].x, uvs[j as usize].y));
                    sl::triangle_consts::<f32, true>(&p, &uv, true)
                }
                None => sl::triangle_consts::<f32, false>(&p, &[V2::new(0.0, 0.0); 3], false),
            };
            for (k, v) in [consts.ng, consts.dpdu, consts.dpdv]
                .into_iter()
                .enumerate()
            {
                (s.c[k][0][t], s.c[k][1][t], s.c[k][2][t]) = (v.x, v.y, v.z);
            }
        }
        Some(s)
    }
}

/// The gather stage: writes the surface row of every active path of `batch` whose ray hit
/// something (rows of paths without a hit are left as they are) and every active path's
/// `Batch::hit_flag`. 8-wide where `avx` is given (the chunk's hits grouped by form; the
/// one-mesh chunks of [`SmallTris`] 16 wide where `w16` is given too), else one
/// `Scene::interaction` per hit; adds the hits reconstructed in lanes to `in_lanes`, those of
/// them reconstructed 16 wide to `in_lanes_16`.
pub(crate) fn fill(
    scene: &Scene,
    forms: &[Form],
    #[cfg(target_arch = "x86_64")] avx: Option<crate::lane::Avx2>,
    #[cfg(target_arch = "x86_64")] w16: Option<crate::lane::Avx512>,
    batch: &mut Batch,
    in_lanes: &mut u64,
    in_lanes_16: &mut u64,
) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = avx {
        let (lanes, lanes16) = x8::fill(avx, w16, scene, forms, batch);
        *in_lanes += lanes;
        *in_lanes_16 += lanes16;
        return;
    }
    let _ = in_lanes_16;
    let _ = forms;
    let (active, hit, ray, surf) = (&batch.active, &batch.hit, &batch.ray, &mut batch.surf);
    let flag = &mut batch.hit_flag;
    for &i in active {
        let i = i as usize;
        flag[i] = hit[i].is_hit() as u32;
        if let Some(h) = &hit[i].get() {
            surf.set(i, &scene.interaction(&ray[i], h));
        }
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use crate::accel::HitRow;
    use crate::geometry::hit::NO_INSTANCE;
    use crate::lane::frame::Frame;
    use crate::lane::vec::V3;
    use crate::lane::{
        Avx2, Avx512, F32x16, F32x8, Hint, I32x16, I32x8, Lane, LaneI32, LaneLookup, ToArray, Wide,
    };
    use crate::stream::batch::{cols, Surfaces};
    use crate::stream::kernels::diffuse::Surface;
    use crate::stream::BATCH;

    const N: usize = BATCH * cols::ROW;

    use super::{Form, SMALL_TRIS};
    use crate::geometry::surface_lanes::{self as sl, SurfLanes};
    use crate::geometry::{Hit, Ray, ShapeKind};
    use crate::lane::vec::V2;
    use crate::scene::Scene;
    use crate::stream::batch::Batch;

    /// Up to `C` path ids of one form waiting for their reconstruction in lanes (8, or 16 for
    /// a one-mesh slot, [`MeshChunks`]).
    struct Pending<const C: usize = 8> {
        ids: [u32; C],
        n: usize,
    }

    impl<const C: usize> Pending<C> {
        const EMPTY: Pending<C> = Pending { ids: [0; C], n: 0 };
        /// Adds `i`; returns whether the chunk is full.
        #[inline(always)]
        fn push(&mut self, i: u32) -> bool {
            self.push_upto(i, C)
        }
        /// Adds `i`; returns whether the chunk holds `cap` (at most `C`) ids.
        #[inline(always)]
        fn push_upto(&mut self, i: u32, cap: usize) -> bool {
            self.ids[self.n] = i;
            self.n += 1;
            self.n == cap
        }
        /// The first `W` ids (at least as many as the chunk holds), padded with the first (a
        /// padded lane is computed and not stored).
        #[inline(always)]
        fn take<const W: usize>(&mut self) -> ([u32; W], usize) {
            let n = std::mem::take(&mut self.n);
            debug_assert!(n <= W, "{n} ids in a chunk of {W}");
            let mut ids = *self.ids.first_chunk::<W>().expect("W ≤ C");
            let first = ids[0];
            for id in &mut ids[n.min(W)..] {
                *id = first;
            }
            (ids, n)
        }
    }

    /// How many one-mesh chunks [`MeshChunks`] keeps.
    const SLOTS: usize = 8;

    /// How many chunk fills lie between a pipelined chunk's index prefetch and its vertex
    /// prefetch, and again between that and its reconstruction ([`MeshChunks::enter`]): 1
    /// unless `GROOVE_GATHER_LAG` (environment, read once; 0 to 3, 0 turning the pipeline off)
    /// says otherwise, for measurements. Lags 1 and 2 and the prefetch hints were measured on
    /// million (`docs/bench/README.md`, forty-second session, h2).
    fn lag() -> usize {
        static LAG: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
        *LAG.get_or_init(|| {
            std::env::var("GROOVE_GATHER_LAG")
                .ok()
                .and_then(|v| v.parse().ok())
                .map_or(1, |l: usize| l.min((RING - 1) / 2))
        })
    }

    /// The fewest triangles of a mesh whose chunks go through [`MeshChunks`]' pipeline (768 KB
    /// of index rows: a mesh whose rows stay in the caches gains nothing from the prefetches).
    const PIPE_MIN_TRIS: usize = 1 << 16;

    /// The prefetches' hint: every cache level (`prefetchnta` measured slower on million,
    /// `prefetcht1` no faster).
    const HINT: Hint = Hint::T0;

    /// Chunks in flight in [`MeshChunks`]' pipeline (a ring; more than twice the largest lag).
    const RING: usize = 8;

    /// A full one-mesh chunk in flight: its paths, the mesh, the hits' triangles and (once its
    /// index rows are loaded) their vertex indices.
    #[derive(Clone, Copy)]
    struct Flight {
        ids: [u32; 8],
        n: usize,
        geom: u32,
        prim: [u32; 8],
        tri: [[i32; 8]; 3],
    }

    impl Flight {
        const EMPTY: Flight = Flight {
            ids: [0; 8],
            n: 0,
            geom: 0,
            prim: [0; 8],
            tri: [[0; 8]; 3],
        };
    }

    /// Direct hits on triangle meshes waiting for their 8-wide reconstruction, in chunks of one
    /// mesh each where they can (slot `geom % SLOTS` holds one mesh's hits at a time; those are
    /// gathered with vector gathers, [`one_mesh_triangles`]), else in `mixed` (gathered lane by
    /// lane, [`triangles`]). A full chunk of a large mesh ([`piped`]) goes through a software
    /// pipeline of prefetches before its reconstruction ([`MeshChunks::enter`]). Which chunk a
    /// hit waits in, and when its chunk is reconstructed, change only the order in which rows
    /// are written, not what they hold. Where AVX-512 is on (`w16`), a slot holding a mesh
    /// of [`super::SmallTris`] fills to 16 hits, reconstructed 16 at a time ([`small_triangles`] at
    /// width 16: the same lane functions, so the same rows); a partial chunk of at most 8 goes
    /// 8 wide.
    struct MeshChunks<const C: usize> {
        geom: [u32; SLOTS],
        /// Whether the slot's mesh goes through the pipeline.
        piped: [bool; SLOTS],
        /// How many hits fill the slot's chunk where `C` is 16 (`w16` is there): 16 for a mesh
        /// of [`super::SmallTris`], else 8. (Without AVX-512, `C` is 8: every chunk holds 8, as
        /// before the 16-wide chunks, at the same cost.)
        cap: [usize; SLOTS],
        slot: [Pending<C>; SLOTS],
        mixed: Pending,
        w16: Option<Avx512>,
        /// Hits reconstructed 16 wide.
        lanes16: u64,
        /// The pipeline: chunk `k` (the `k`th entered) in `ring[k % RING]`; `done` of the
        /// `entered` chunks reconstructed.
        ring: [Flight; RING],
        entered: usize,
        done: usize,
        lag: usize,
    }

    impl<const C: usize> MeshChunks<C> {
        fn new(w16: Option<Avx512>) -> MeshChunks<C> {
            MeshChunks {
                geom: [0; SLOTS],
                piped: [false; SLOTS],
                cap: [8; SLOTS],
                slot: [Pending::EMPTY; SLOTS],
                mixed: Pending::EMPTY,
                w16,
                lanes16: 0,
                ring: [Flight::EMPTY; RING],
                entered: 0,
                done: 0,
                lag: lag(),
            }
        }

        /// Adds path `i`, whose ray hit mesh `geom`; reconstructs the chunk it fills.
        #[inline(always)]
        fn push(&mut self, avx: Avx2, st: &mut Stage, geom: u32, i: u32) {
            let s = geom as usize % SLOTS;
            if self.slot[s].n == 0 {
                self.geom[s] = geom;
                self.piped[s] = self.lag > 0 && piped(st, geom);
                if C > 8 {
                    let small = matches!(st.forms[geom as usize], Form::Triangles(Some(_)));
                    self.cap[s] = if small && self.w16.is_some() { 16 } else { 8 };
                }
            }
            if self.geom[s] == geom {
                let cap = if C > 8 { self.cap[s] } else { 8 };
                if self.slot[s].push_upto(i, cap) {
                    self.full(avx, st, s);
                }
            } else if self.mixed.push(i) {
                triangles(avx, st, self.mixed.take());
            }
        }

        /// Reconstructs slot `s`'s chunk (full, or partial at the end, padded): 16 wide where it
        /// holds more than 8 hits (only a slot of `cap` 16 does, so `w16` is there), else 8
        /// wide, directly or through the pipeline.
        #[inline(always)]
        fn full(&mut self, avx: Avx2, st: &mut Stage, s: usize) {
            let geom = self.geom[s];
            if C > 8 && self.slot[s].n > 8 {
                let (ids, n) = self.slot[s].take::<16>();
                let w16 = self.w16.expect("a chunk of 16 only with AVX-512");
                w16.run(
                    #[inline(always)]
                    || small_triangles(w16, st, geom, &ids, n),
                );
                self.lanes16 += n as u64;
                return;
            }
            let c = self.slot[s].take();
            if self.piped[s] {
                self.enter(avx, st, geom, c);
            } else {
                one_mesh_triangles(avx, st, geom, c, None);
            }
        }

        /// Puts a full chunk of mesh `geom` into the pipeline (a software pipeline over the
        /// chunks, so that the two dependent misses of a cold hit, its index row and then the
        /// vertex rows it names, overlap with the work on other chunks instead of stalling its
        /// own reconstruction): prefetches the chunk's index rows, loads the index rows of the
        /// chunk entered `lag` chunks before (in the caches by now) and prefetches the vertex
        /// rows they name, and reconstructs the chunk entered `2 lag` before. Each path's row
        /// is written from its own hit and ray alone, which the stage does not change, so the
        /// delay changes the order of the row writes only, not what they hold.
        #[inline(always)]
        fn enter(&mut self, avx: Avx2, st: &mut Stage, geom: u32, (ids, n): ([u32; 8], usize)) {
            let lag = self.lag;
            let m = mesh(st, geom);
            let k = self.entered;
            let f = &mut self.ring[k % RING];
            (f.ids, f.n, f.geom) = (ids, n, geom);
            for (p, &i) in f.prim.iter_mut().zip(&ids) {
                *p = st.hit[i as usize].0[1];
            }
            avx.prefetch_rows([&m.indices[..]], avx.load_u32(&f.prim), HINT);
            self.entered += 1;
            if k >= lag {
                self.vertices(avx, st, k - lag);
            }
            if k >= 2 * lag {
                self.reconstruct(avx, st, k - 2 * lag);
                self.done += 1;
            }
        }

        /// Loads the index rows of the chunk entered `k`th (kept for its reconstruction) and
        /// prefetches the rows of the vertices they name.
        #[inline(always)]
        fn vertices(&mut self, avx: Avx2, st: &Stage, k: usize) {
            let f = &mut self.ring[k % RING];
            let m = mesh(st, f.geom);
            let tri = avx.gather3_u32(&m.indices, avx.load_u32(&f.prim));
            for (kept, &c) in f.tri.iter_mut().zip(&tri) {
                *kept = c.to_array();
                match &m.normals {
                    Some(ns) => avx.prefetch_rows([&m.positions[..], &ns[..]], c, HINT),
                    None => avx.prefetch_rows([&m.positions[..]], c, HINT),
                }
                if let Some(uvs) = &m.uvs {
                    avx.prefetch_rows([&uvs[..]], c, HINT);
                }
            }
        }

        /// Reconstructs the chunk entered `k`th.
        #[inline(always)]
        fn reconstruct(&self, avx: Avx2, st: &mut Stage, k: usize) {
            let f = &self.ring[k % RING];
            one_mesh_triangles(avx, st, f.geom, (f.ids, f.n), Some(&f.tri));
        }

        /// Reconstructs the partly filled chunks (padded) and empties the pipeline.
        #[inline(always)]
        fn flush(&mut self, avx: Avx2, st: &mut Stage) {
            for s in 0..SLOTS {
                if self.slot[s].n > 0 {
                    self.full(avx, st, s);
                }
            }
            let (d, e) = (self.done, self.entered);
            for k in d.max(e.saturating_sub(self.lag))..e {
                self.vertices(avx, st, k);
            }
            for k in d..e {
                self.reconstruct(avx, st, k);
            }
            self.done = e;
            if self.mixed.n > 0 {
                triangles(avx, st, self.mixed.take());
            }
        }
    }

    /// Mesh `g` of the scene.
    #[inline(always)]
    fn mesh<'s>(st: &Stage<'s>, g: u32) -> &'s crate::geometry::mesh::TriMesh {
        let ShapeKind::Mesh(m) = &st.scene.shapes[g as usize].kind else {
            unreachable!("Form::Triangles is set for meshes only");
        };
        m
    }

    /// Whether mesh `g`'s chunks go through [`MeshChunks`]' pipeline: a mesh of at least
    /// [`PIPE_MIN_TRIS`] triangles, not held as [`super::SmallTris`], within the gathers' 32-bit
    /// offsets.
    fn piped(st: &Stage, g: u32) -> bool {
        let m = mesh(st, g);
        matches!(st.forms[g as usize], Form::Triangles(None))
            && m.indices.len() >= PIPE_MIN_TRIS
            && fits(m)
    }

    /// Whether every table of `m` is within the gathers' 32-bit offsets.
    #[inline(always)]
    fn fits(m: &crate::geometry::mesh::TriMesh) -> bool {
        let fits = |len: usize| len <= i32::MAX as usize / 3;
        fits(m.indices.len())
            && fits(m.positions.len())
            && m.normals.as_ref().is_none_or(|v| fits(v.len()))
            && m.uvs.as_ref().is_none_or(|v| fits(v.len()))
    }

    /// The rays, hits and rows the gather stage works on.
    struct Stage<'a> {
        scene: &'a Scene,
        forms: &'a [Form],
        ray: &'a [Ray],
        hit: &'a [crate::accel::HitRow],
        surf: &'a mut Surfaces,
    }

    /// [`super::fill`] in lanes: each active path with a hit goes to its form's pending chunk,
    /// which is reconstructed when it holds 8 (16 for the one-mesh chunks of [`super::SmallTris`]
    /// where `w16` is given) and at the end, padded. Returns how many hits went through the
    /// lane forms, and how many of those 16 wide.
    pub(crate) fn fill(
        avx: Avx2,
        w16: Option<Avx512>,
        scene: &Scene,
        forms: &[Form],
        batch: &mut Batch,
    ) -> (u64, u64) {
        match w16 {
            Some(_) => avx.run(
                #[inline(always)]
                || fill_run::<16>(avx, w16, scene, forms, batch),
            ),
            None => avx.run(
                #[inline(always)]
                || fill_run::<8>(avx, None, scene, forms, batch),
            ),
        }
    }

    /// [`fill`]'s loop, its one-mesh chunks of at most `C` hits (16 with `w16`, else 8: two
    /// instances, so that the 8-wide one keeps its constant chunk size). Call inside
    /// [`Avx2::run`].
    #[inline(always)]
    fn fill_run<const C: usize>(
        avx: Avx2,
        w16: Option<Avx512>,
        scene: &Scene,
        forms: &[Form],
        batch: &mut Batch,
    ) -> (u64, u64) {
        let mut st = Stage {
            scene,
            forms,
            ray: &batch.ray,
            hit: &batch.hit,
            surf: &mut batch.surf,
        };
        let mut tri = MeshChunks::<C>::new(w16);
        let (mut sph, mut rect) = (Pending::<8>::EMPTY, Pending::<8>::EMPTY);
        let (mut disks, mut itri) = (Pending::<8>::EMPTY, Pending::<8>::EMPTY);
        let mut cyl = Pending::<8>::EMPTY;
        let mut scalar = 0;
        let mut hits = 0;
        // The hit flag of every active path (`Batch::hit_flag`), cut to the hits'
        // length (one bounds test covers both) and stored in each branch.
        let flag = &mut batch.hit_flag[..st.hit.len()];
        // The rows' words read where they lie: the shape and the instance decide the
        // branch (the whole hit only for the 1-lane reconstruction).
        let hit = st.hit;
        for &i in &batch.active {
            let row = &hit[i as usize];
            let geom = row.geom();
            if geom == HitRow::MISS {
                flag[i as usize] = 0;
                continue;
            }
            flag[i as usize] = 1;
            hits += 1;
            let form = &st.forms[geom as usize];
            if row.inst() != NO_INSTANCE {
                if let Form::Triangles(_) = form {
                    if itri.push(i) {
                        instanced_triangles(avx, &mut st, itri.take());
                    }
                } else {
                    scalar += 1;
                    let i = i as usize;
                    let h = row.get().expect("a hit");
                    let si = st.scene.interaction(&st.ray[i], &h);
                    st.surf.set(i, &si);
                }
                continue;
            }
            match form {
                Form::Triangles(_) => tri.push(avx, &mut st, geom, i),
                Form::Sphere(..) => {
                    if sph.push(i) {
                        spheres(avx, &mut st, sph.take());
                    }
                }
                Form::Rectangle(_) => {
                    if rect.push(i) {
                        rectangles(avx, &mut st, rect.take());
                    }
                }
                Form::Disk(_) => {
                    if disks.push(i) {
                        disks_x8(avx, &mut st, disks.take());
                    }
                }
                Form::Cylinder(_) => {
                    if cyl.push(i) {
                        cylinders(avx, &mut st, cyl.take());
                    }
                }
                Form::Scalar => {
                    scalar += 1;
                    let i = i as usize;
                    let h = row.get().expect("a hit");
                    let si = st.scene.interaction(&st.ray[i], &h);
                    st.surf.set(i, &si);
                }
            }
        }
        tri.flush(avx, &mut st);
        if sph.n > 0 {
            spheres(avx, &mut st, sph.take());
        }
        if rect.n > 0 {
            rectangles(avx, &mut st, rect.take());
        }
        if disks.n > 0 {
            disks_x8(avx, &mut st, disks.take());
        }
        if itri.n > 0 {
            instanced_triangles(avx, &mut st, itri.take());
        }
        if cyl.n > 0 {
            cylinders(avx, &mut st, cyl.take());
        }
        (hits - scalar, tri.lanes16)
    }

    /// Eight lanes of 3-vectors, filled lane by lane.
    #[derive(Clone, Copy, Default)]
    struct Cols3([[f32; 8]; 3]);

    impl Cols3 {
        #[inline(always)]
        fn set(&mut self, k: usize, v: glam::Vec3) {
            self.0[0][k] = v.x;
            self.0[1][k] = v.y;
            self.0[2][k] = v.z;
        }
        #[inline(always)]
        fn load(&self, avx: Avx2) -> V3<F32x8> {
            V3::new(
                avx.load(&self.0[0]),
                avx.load(&self.0[1]),
                avx.load(&self.0[2]),
            )
        }
    }

    /// Path `i`'s hit row as 8 lanes (its words' bits).
    #[inline(always)]
    fn hit_row(avx: Avx2, hit: &[crate::accel::HitRow], i: u32) -> F32x8 {
        F32x8::from_bits(avx.load_u32(&hit[i as usize].0))
    }

    /// The hit rows of the lanes `ids` as columns (`geom`, `prim`, `t`, `u`, `v`, `inst` and two
    /// zeros, each word's bits), their first three also stored as `m`'s columns. Every lane is a
    /// hit (a chunk holds hits, its padding repeats its first): the rows
    /// ([`crate::accel::HitRow`]) are loaded whole and transposed, instead of each lane's hit
    /// unpacked and its fields stored one by one.
    #[inline(always)]
    fn hit_columns(avx: Avx2, st: &Stage, ids: &[u32; 8], m: &mut Meta) -> [F32x8; 8] {
        let f = avx.hit_fields(st.hit, ids);
        f[0].store(&mut m.shape);
        f[1].store(&mut m.prim);
        f[2].store(&mut m.t);
        f
    }

    /// Each lane's ray point at its hit (`Ray::at`, 8-wide), and its [`Meta`] (the hits read
    /// as [`hit_columns`]).
    #[inline(always)]
    fn ray_points(avx: Avx2, st: &Stage, ids: &[u32; 8], m: &mut Meta) -> V3<F32x8> {
        let t = hit_columns(avx, st, ids, m)[2];
        let (o, d) = m.rays(avx, st, ids);
        sl::ray_at(o, d, t)
    }

    // The row layout `store` writes as four groups of 8 floats.
    const _: () = assert!(
        cols::P == 0
            && cols::NG == 3
            && cols::S == 6
            && cols::T == 9
            && cols::N == 12
            && cols::WI == 15
            && cols::UV == 18
            && cols::DPDU == 20
            && cols::DPDV == 23
            && cols::DIST == 26
            && cols::SHAPE == 27
            && cols::PRIM == 28
            && cols::ROW == 32
    );

    /// What a row takes from each lane's hit and ray besides the lane form's fields.
    struct Meta {
        /// −ray.d ([`Meta::rays`]).
        wi: V3<F32x8>,
        t: [f32; 8],
        /// The shape and primitive indices' bits.
        shape: [f32; 8],
        prim: [f32; 8],
    }

    impl Meta {
        #[inline(always)]
        fn new(avx: Avx2) -> Meta {
            let z = avx.splat(0.0);
            Meta {
                wi: V3::new(z, z, z),
                t: [0.0; 8],
                shape: [0.0; 8],
                prim: [0.0; 8],
            }
        }

        /// The shape every lane hit, when they all hit one (the common case of a chunk of
        /// spheres or rectangles: one large shape): then its lane form's constants are splat
        /// instead of gathered lane by lane (the same values, so the same results).
        #[inline(always)]
        fn one_shape(&self) -> Option<usize> {
            let g = self.shape[0].to_bits();
            self.shape
                .iter()
                .all(|s| s.to_bits() == g)
                .then_some(g as usize)
        }

        #[inline(always)]
        fn set(&mut self, k: usize, h: &Hit) {
            self.t[k] = h.t;
            self.shape[k] = f32::from_bits(h.geom);
            self.prim[k] = f32::from_bits(h.prim);
        }

        /// The lanes' ray origins and directions (each ray loaded whole and transposed, not
        /// field by field); sets `wi`.
        #[inline(always)]
        fn rays(&mut self, avx: Avx2, st: &Stage, ids: &[u32; 8]) -> (V3<F32x8>, V3<F32x8>) {
            let f = avx.ray_fields(st.ray, ids);
            let d = V3::new(f[3], f[4], f[5]);
            self.wi = -d;
            (V3::new(f[0], f[1], f[2]), d)
        }
    }

    /// Writes the first `n` lanes of `s` and `m` into the rows of `ids` ([`store_rows`]).
    #[inline(always)]
    fn store(avx: Avx2, st: &mut Stage, ids: &[u32; 8], n: usize, s: &SurfLanes<F32x8>, m: &Meta) {
        // The 8-wide form of `store_rows` written out, `m`'s columns loaded where they go:
        // through `store_rows` the one-mesh chunks of `SmallTris` took ~20 instructions a
        // sample more on cbox-rgb (the transposes' inputs spilled).
        let wi = m.wi;
        let (f, z) = (&s.frame, avx.splat(0.0));
        let g0 = F32x8::transpose8([s.p.x, s.p.y, s.p.z, s.ng.x, s.ng.y, s.ng.z, f.s.x, f.s.y]);
        let g1 = F32x8::transpose8([f.s.z, f.t.x, f.t.y, f.t.z, f.n.x, f.n.y, f.n.z, wi.x]);
        for (k, &i) in ids.iter().enumerate().take(n) {
            let r = st.surf.row_groups_mut(i as usize);
            g0[k].store(&mut r[0]);
            g1[k].store(&mut r[1]);
        }
        let g2 = F32x8::transpose8([
            wi.y, wi.z, s.uv.x, s.uv.y, s.dpdu.x, s.dpdu.y, s.dpdu.z, s.dpdv.x,
        ]);
        let (t, shape, prim) = (avx.load(&m.t), avx.load(&m.shape), avx.load(&m.prim));
        let g3 = F32x8::transpose8([s.dpdv.y, s.dpdv.z, t, shape, prim, z, z, z]);
        for (k, &i) in ids.iter().enumerate().take(n) {
            let r = st.surf.row_groups_mut(i as usize);
            g2[k].store(&mut r[2]);
            g3[k].store(&mut r[3]);
        }
    }

    /// Writes the first `n` lanes of `s`, the incident directions `wi` and the hits' `t`,
    /// shape and primitive words (`meta`) into the rows of `ids`: the 32 fields as four groups
    /// of 8 lanes, each transposed into the rows' runs of 8 floats (one store per group and
    /// row instead of 29 scalar stores per row, [`SurfRows::store_groups`]). In two halves
    /// (groups 0–1, then 2–3), so that 16 transposed registers are live at a time rather than
    /// 32 (which spilled at width 8), each row found without a bounds test
    /// ([`Surfaces::row_groups_mut`]).
    #[inline(always)]
    fn store_rows<T: SurfRows<W>, const W: usize>(
        t: T,
        surf: &mut Surfaces,
        ids: &[u32; W],
        n: usize,
        s: &SurfLanes<T::F>,
        wi: V3<T::F>,
        [dist, shape, prim]: [T::F; 3],
    ) {
        let (f, z) = (&s.frame, t.splat(0.0));
        let g0 = [s.p.x, s.p.y, s.p.z, s.ng.x, s.ng.y, s.ng.z, f.s.x, f.s.y];
        let g1 = [f.s.z, f.t.x, f.t.y, f.t.z, f.n.x, f.n.y, f.n.z, wi.x];
        t.store_groups(surf, ids, n, 0, g0, g1);
        let g2 = [
            wi.y, wi.z, s.uv.x, s.uv.y, s.dpdu.x, s.dpdu.y, s.dpdu.z, s.dpdv.x,
        ];
        let g3 = [s.dpdv.y, s.dpdv.z, dist, shape, prim, z, z, z];
        t.store_groups(surf, ids, n, 2, g2, g3);
    }

    /// What the gather stage's chunks need of a width beyond [`Wide`]: the hit rows and rays
    /// of a chunk in lanes, the [`super::SmallTris`] tables' lookups and the surface rows' stores, by
    /// transposes and permutes (moves only: every lane's bits), at width 8 ([`Avx2`]) and 16
    /// ([`Avx512`]).
    trait SurfRows<const W: usize>: Wide<W> {
        /// The hit rows of the lanes `ids` as columns (`geom`, `prim`, `t`, `u`, `v`, `inst`
        /// and two zeros, each word's bits), each row loaded whole.
        fn hit_fields(self, hit: &[HitRow], ids: &[u32; W]) -> [Self::F; 8];
        /// The rays of the lanes `ids` as columns (o, d, tmin, tmax), each loaded whole.
        fn ray_fields(self, ray: &[Ray], ids: &[u32; W]) -> [Self::F; 8];
        /// Per lane `table[t]` (`t` below the mesh's triangle count; `wide`: above 8).
        fn look(self, table: &[f32; SMALL_TRIS], t: Self::I, wide: bool) -> Self::F;
        /// `b` in every lane.
        fn mask_splat(self, b: bool) -> Self::M;
        /// Writes groups `first` and `first + 1` of the rows of the first `n` lanes of `ids`
        /// (8 floats each): lane `k`'s values of `a`, then of `b`.
        fn store_groups(
            self,
            surf: &mut Surfaces,
            ids: &[u32; W],
            n: usize,
            first: usize,
            a: [Self::F; 8],
            b: [Self::F; 8],
        );
    }

    impl SurfRows<8> for Avx2 {
        /// One 32-byte load per row and [`F32x8::transpose8`]. Written out, not a closure or
        /// `array::from_fn` (either compiled out of line would lose the lanes' target
        /// features).
        #[inline(always)]
        fn hit_fields(self, h: &[HitRow], ids: &[u32; 8]) -> [F32x8; 8] {
            F32x8::transpose8([
                hit_row(self, h, ids[0]),
                hit_row(self, h, ids[1]),
                hit_row(self, h, ids[2]),
                hit_row(self, h, ids[3]),
                hit_row(self, h, ids[4]),
                hit_row(self, h, ids[5]),
                hit_row(self, h, ids[6]),
                hit_row(self, h, ids[7]),
            ])
        }
        #[inline(always)]
        fn ray_fields(self, ray: &[Ray], ids: &[u32; 8]) -> [F32x8; 8] {
            Avx2::ray_fields(self, ray, ids)
        }
        /// The first 8 entries by one permute where the mesh has at most 8 triangles, all 16
        /// by two and a blend else.
        #[inline(always)]
        fn look(self, table: &[f32; SMALL_TRIS], t: I32x8, wide: bool) -> F32x8 {
            if wide {
                self.lookup16(table, t)
            } else {
                let (half, _) = table.split_first_chunk::<8>().expect("16 entries");
                I32x8::lookup8(half, t)
            }
        }
        #[inline(always)]
        fn mask_splat(self, b: bool) -> crate::lane::M8 {
            Avx2::mask_splat(self, b)
        }
        /// Each group transposed ([`F32x8::transpose8`]) into the 8 rows' runs.
        #[inline(always)]
        fn store_groups(
            self,
            surf: &mut Surfaces,
            ids: &[u32; 8],
            n: usize,
            first: usize,
            a: [F32x8; 8],
            b: [F32x8; 8],
        ) {
            let (a, b) = (F32x8::transpose8(a), F32x8::transpose8(b));
            // A loop of 8 with a test (unrolled: the registers indexed by constants), not one
            // of `n`.
            for k in 0..8 {
                if k < n {
                    let r = surf.row_groups_mut(ids[k] as usize);
                    a[k].store(&mut r[first]);
                    b[k].store(&mut r[first + 1]);
                }
            }
        }
    }

    impl SurfRows<16> for Avx512 {
        /// Two rows per register ([`Avx512::words16_at`]).
        #[inline(always)]
        fn hit_fields(self, h: &[HitRow], ids: &[u32; 16]) -> [F32x16; 8] {
            self.words16_at(|k| &h[ids[k] as usize].0)
        }
        /// Two rays per register ([`Avx512::ray_fields16_at`]).
        #[inline(always)]
        fn ray_fields(self, ray: &[Ray], ids: &[u32; 16]) -> [F32x16; 8] {
            self.ray_fields16_at(|k| &ray[ids[k] as usize])
        }
        /// One permute over the 16 entries ([`Avx512::lookup16`]), whatever the count.
        #[inline(always)]
        fn look(self, table: &[f32; SMALL_TRIS], t: I32x16, _wide: bool) -> F32x16 {
            self.lookup16(table, t)
        }
        #[inline(always)]
        fn mask_splat(self, b: bool) -> crate::lane::M16 {
            Avx512::mask_splat(self, b)
        }
        /// Each group's rows two to a register ([`Avx512::row_pairs16`]): lane `k`'s in the
        /// low half, lane `k + 8`'s in the high half.
        #[inline(always)]
        fn store_groups(
            self,
            surf: &mut Surfaces,
            ids: &[u32; 16],
            n: usize,
            first: usize,
            a: [F32x16; 8],
            b: [F32x16; 8],
        ) {
            let (a, b) = (self.row_pairs16(a), self.row_pairs16(b));
            for k in 0..8 {
                if k < n {
                    let r = surf.row_groups_mut(ids[k] as usize);
                    a[k].store_low8(&mut r[first]);
                    b[k].store_low8(&mut r[first + 1]);
                }
                if k + 8 < n {
                    let r = surf.row_groups_mut(ids[k + 8] as usize);
                    a[k].store_high8(&mut r[first]);
                    b[k].store_high8(&mut r[first + 1]);
                }
            }
        }
    }

    /// Hits on triangle meshes: [`triangle_input`], then [`sl::triangle`].
    #[inline(always)]
    fn triangles(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let (x, meta) = triangle_input(avx, st, &ids);
        let s = sl::triangle(&x);
        store(avx, st, &ids, n, &s, &meta);
    }

    /// Hits on one triangle mesh, shape `g` (every lane's): [`one_mesh_input`], then
    /// [`sl::triangle`] ([`sl::triangle_no_uv`] for a mesh without uvs); a mesh held as
    /// [`super::SmallTris`] takes [`small_triangles`], a mesh too large for 32-bit gather offsets
    /// [`triangles`]. `tri`: the hits' vertex indices when loaded
    /// already (by [`MeshChunks`]' pipeline).
    #[inline(always)]
    fn one_mesh_triangles(
        avx: Avx2,
        st: &mut Stage,
        g: u32,
        (ids, n): ([u32; 8], usize),
        tri: Option<&[[i32; 8]; 3]>,
    ) {
        let shape = &st.scene.shapes[g as usize];
        let ShapeKind::Mesh(m) = &shape.kind else {
            unreachable!("Form::Triangles is set for meshes only");
        };
        if let Form::Triangles(Some(small)) = &st.forms[g as usize] {
            let (x, c, meta) = small_input(avx, st, &ids, m, small, shape.flip_normals);
            let s = if m.uvs.is_some() {
                sl::triangle_at::<_, true>(&x, &c)
            } else {
                sl::triangle_at::<_, false>(&x, &c)
            };
            store(avx, st, &ids, n, &s, &meta);
            return;
        }
        if !fits(m) {
            return triangles(avx, st, (ids, n));
        }
        let (x, meta) = one_mesh_input(avx, st, &ids, m, shape.flip_normals, tri);
        let s = if m.uvs.is_some() {
            sl::triangle(&x)
        } else {
            sl::triangle_no_uv(&x)
        };
        store(avx, st, &ids, n, &s, &meta);
    }

    /// [`triangle_input`] for lanes that all hit mesh `m` (whose `flip_normals` is `flip`):
    /// the triangles' vertex indices, then their positions, normals and uvs, by vector
    /// gathers; the per-mesh flags and sign splat. The same values as lane by lane (the mesh is
    /// validated at load: its indices are in range, so the gathers' clamps change nothing).
    #[inline(always)]
    fn one_mesh_input(
        avx: Avx2,
        st: &Stage,
        ids: &[u32; 8],
        m: &crate::geometry::mesh::TriMesh,
        flip: bool,
        tri: Option<&[[i32; 8]; 3]>,
    ) -> (sl::Triangle<F32x8>, Meta) {
        let (prim, b, meta) = mesh_hits(avx, st, ids);
        let tri = match tri {
            Some(t) => [
                avx.load_i32(&t[0]),
                avx.load_i32(&t[1]),
                avx.load_i32(&t[2]),
            ],
            None => avx.gather3_u32(&m.indices, prim),
        };
        let p = [
            gv3(F32x8::gather3(&m.positions, tri[0])),
            gv3(F32x8::gather3(&m.positions, tri[1])),
            gv3(F32x8::gather3(&m.positions, tri[2])),
        ];
        let z = avx.splat(0.0);
        let (n, has_n) = match &m.normals {
            Some(ns) => (
                [
                    gv3(F32x8::gather3(ns, tri[0])),
                    gv3(F32x8::gather3(ns, tri[1])),
                    gv3(F32x8::gather3(ns, tri[2])),
                ],
                avx.mask_splat(true),
            ),
            None => ([V3::new(z, z, z); 3], avx.mask_splat(false)),
        };
        let (uv, has_uv) = match &m.uvs {
            Some(uvs) => (
                [
                    gv2(avx.gather2(uvs, tri[0])),
                    gv2(avx.gather2(uvs, tri[1])),
                    gv2(avx.gather2(uvs, tri[2])),
                ],
                avx.mask_splat(true),
            ),
            None => ([V2::new(z, z); 3], avx.mask_splat(false)),
        };
        let x = sl::Triangle {
            p,
            n,
            uv,
            has_n,
            has_uv,
            b1: b[0],
            b2: b[1],
            sign: avx.splat(if flip { -1.0 } else { 1.0 }),
        };
        (x, meta)
    }

    /// The hits of the lanes `ids` on one mesh, as [`one_mesh_input`] and [`small_input`] read
    /// them: the triangle indices, the barycentrics (`Hit::u`, `Hit::v`) and the lanes'
    /// [`Meta`] with their rays. The hit rows are read as [`hit_columns`] (every lane is a
    /// hit): one transpose, not each lane's hit unpacked and its fields stored one by one.
    #[inline(always)]
    fn mesh_hits(avx: Avx2, st: &Stage, ids: &[u32; 8]) -> (I32x8, [F32x8; 2], Meta) {
        let mut meta = Meta::new(avx);
        let f = hit_columns(avx, st, ids, &mut meta);
        meta.rays(avx, st, ids);
        (f[1].to_bits(), [f[3], f[4]], meta)
    }

    /// [`small_triangles`]' input at width 8, read as [`one_mesh_input`] reads it (the hits
    /// and rays into a [`Meta`], whose columns [`store`] loads where they go: fewer
    /// instructions than [`small_triangles`]' at width 8, whose values stay live through the
    /// reconstruction): each lane's corners and its triangle's own terms looked up by its
    /// triangle index in the tables. The same values.
    #[inline(always)]
    fn small_input(
        avx: Avx2,
        st: &Stage,
        ids: &[u32; 8],
        m: &crate::geometry::mesh::TriMesh,
        small: &super::SmallTris,
        flip: bool,
    ) -> (sl::Triangle<F32x8>, sl::TriangleConsts<F32x8>, Meta) {
        let (tri, b, meta) = mesh_hits(avx, st, ids);
        let (x, c) = small_lookups(avx, small, m, tri, b, flip);
        (x, c, meta)
    }

    /// Hits on one mesh held as [`super::SmallTris`], shape `g` (every lane's), `W` at a time: the
    /// lanes' hit rows and rays in lanes ([`SurfRows`]), each lane's corners looked up by its
    /// triangle index in the tables (the floats the gathers read) with the triangle's own terms
    /// ([`sl::TriangleConsts`]), the hits' terms of [`sl::triangle`] ([`sl::triangle_no_uv`]
    /// for a mesh without uvs: [`sl::triangle_at`]), and the first `n` lanes' rows stored.
    /// One source for widths 8 and 16 (the lane forms are per lane), so each row is the same
    /// bits at either width. Call inside the token's `run`.
    #[inline(always)]
    fn small_triangles<T: SurfRows<W>, const W: usize>(
        t: T,
        st: &mut Stage,
        g: u32,
        ids: &[u32; W],
        n: usize,
    ) {
        let scene = st.scene;
        let shape = &scene.shapes[g as usize];
        let ShapeKind::Mesh(m) = &shape.kind else {
            unreachable!("Form::Triangles is set for meshes only");
        };
        let Form::Triangles(Some(small)) = &st.forms[g as usize] else {
            unreachable!("small_triangles takes meshes held as SmallTris only");
        };
        let h = t.hit_fields(st.hit, ids);
        let r = t.ray_fields(st.ray, ids);
        let (x, c) = small_lookups(
            t,
            small,
            m,
            h[1].to_bits(),
            [h[3], h[4]],
            shape.flip_normals,
        );
        let s = if m.uvs.is_some() {
            sl::triangle_at::<_, true>(&x, &c)
        } else {
            sl::triangle_at::<_, false>(&x, &c)
        };
        // −ray.d, as `Meta::rays`.
        let wi = -V3::new(r[3], r[4], r[5]);
        store_rows(t, st.surf, ids, n, &s, wi, [h[2], h[0], h[1]]);
    }

    /// The hits' input to [`sl::triangle_at`] on a mesh held as [`super::SmallTris`]: each
    /// lane's corners (positions, normals and uvs where the mesh has them) and the triangle's
    /// own terms looked up by its triangle index `tri`, the barycentrics `b`, the sign of
    /// `flip`. Shared by the 8-wide `small_input` and the generic [`small_triangles`].
    #[inline(always)]
    fn small_lookups<T: SurfRows<W>, const W: usize>(
        t: T,
        small: &super::SmallTris,
        m: &crate::geometry::mesh::TriMesh,
        tri: T::I,
        b: [T::F; 2],
        flip: bool,
    ) -> (sl::Triangle<T::F>, sl::TriangleConsts<T::F>) {
        let wide = small.wide;
        let p = [
            look3(t, &small.p[0], tri, wide),
            look3(t, &small.p[1], tri, wide),
            look3(t, &small.p[2], tri, wide),
        ];
        let z = t.splat(0.0);
        let (n, has_n) = if m.normals.is_some() {
            let n = [
                look3(t, &small.n[0], tri, wide),
                look3(t, &small.n[1], tri, wide),
                look3(t, &small.n[2], tri, wide),
            ];
            (n, t.mask_splat(true))
        } else {
            ([V3::new(z, z, z); 3], t.mask_splat(false))
        };
        let (uv, has_uv) = if m.uvs.is_some() {
            let uv = [
                look2(t, &small.uv[0], tri, wide),
                look2(t, &small.uv[1], tri, wide),
                look2(t, &small.uv[2], tri, wide),
            ];
            (uv, t.mask_splat(true))
        } else {
            ([V2::new(z, z); 3], t.mask_splat(false))
        };
        let x = sl::Triangle {
            p,
            n,
            uv,
            has_n,
            has_uv,
            b1: b[0],
            b2: b[1],
            sign: t.splat(if flip { -1.0 } else { 1.0 }),
        };
        let c = sl::TriangleConsts {
            ng: look3(t, &small.c[0], tri, wide),
            dpdu: look3(t, &small.c[1], tri, wide),
            dpdv: look3(t, &small.c[2], tri, wide),
        };
        (x, c)
    }

    /// Per lane `table[k][tri]` for the three components `k` ([`SurfRows::look`]; a plain
    /// function, not a closure: see `tests/cli/simd_calls.rs`).
    #[inline(always)]
    fn look3<T: SurfRows<W>, const W: usize>(
        t: T,
        table: &[[f32; SMALL_TRIS]; 3],
        tri: T::I,
        wide: bool,
    ) -> V3<T::F> {
        V3::new(
            t.look(&table[0], tri, wide),
            t.look(&table[1], tri, wide),
            t.look(&table[2], tri, wide),
        )
    }

    #[inline(always)]
    fn look2<T: SurfRows<W>, const W: usize>(
        t: T,
        table: &[[f32; SMALL_TRIS]; 2],
        tri: T::I,
        wide: bool,
    ) -> V2<T::F> {
        V2::new(t.look(&table[0], tri, wide), t.look(&table[1], tri, wide))
    }

    /// A gathered vector's components as a [`V3`] (a plain function, not a closure: see
    /// `tests/cli/simd_calls.rs`).
    #[inline(always)]
    fn gv3(c: [F32x8; 3]) -> V3<F32x8> {
        V3::new(c[0], c[1], c[2])
    }

    #[inline(always)]
    fn gv2(c: [F32x8; 2]) -> V2<F32x8> {
        V2::new(c[0], c[1])
    }

    /// Hits on meshes seen through instances: [`triangle_input`] (the member's triangle, in
    /// group space), [`sl::triangle`], then each lane's instance transform ([`sl::instance`]).
    #[inline(always)]
    fn instanced_triangles(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let (x, meta) = triangle_input(avx, st, &ids);
        let (mut w, mut nm) = ([Cols3::default(); 4], [Cols3::default(); 3]);
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = st.hit[i as usize].get() else {
                continue;
            };
            let (to_world, normal) = st.scene.instances[h.inst as usize].lanes();
            for (j, c) in w.iter_mut().enumerate() {
                c.set(k, to_world.col(j).truncate());
            }
            for (j, c) in nm.iter_mut().enumerate() {
                c.set(k, normal.col(j));
            }
        }
        let m = sl::InstanceLanes {
            to_world: load4(avx, &w),
            normal: [nm[0].load(avx), nm[1].load(avx), nm[2].load(avx)],
        };
        let s = sl::instance(&m, &sl::triangle(&x));
        store(avx, st, &ids, n, &s, &meta);
    }

    /// Each lane's triangle gathered from its mesh (vertices, normals, uvs, barycentrics and
    /// `flip_normals` sign), and its [`Meta`].
    #[inline(always)]
    fn triangle_input(avx: Avx2, st: &Stage, ids: &[u32; 8]) -> (sl::Triangle<F32x8>, Meta) {
        let mut p = [Cols3::default(); 3];
        let mut nrm = [Cols3::default(); 3];
        let mut uv = [[[0.0f32; 8]; 2]; 3];
        let (mut has_n, mut has_uv) = ([false; 8], [false; 8]);
        let (mut b1, mut b2, mut sign) = ([0.0f32; 8], [0.0f32; 8], [0.0f32; 8]);
        let mut meta = Meta::new(avx);
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = st.hit[i as usize].get() else {
                continue;
            };
            let shape = &st.scene.shapes[h.geom as usize];
            let ShapeKind::Mesh(m) = &shape.kind else {
                unreachable!("Form::Triangles is set for meshes only");
            };
            let tri = m.indices[h.prim as usize];
            for j in 0..3 {
                p[j].set(k, m.positions[tri[j] as usize]);
            }
            if let Some(ns) = &m.normals {
                has_n[k] = true;
                for j in 0..3 {
                    nrm[j].set(k, ns[tri[j] as usize]);
                }
            }
            if let Some(uvs) = &m.uvs {
                has_uv[k] = true;
                for j in 0..3 {
                    let t = uvs[tri[j] as usize];
                    uv[j][0][k] = t.x;
                    uv[j][1][k] = t.y;
                }
            }
            meta.set(k, &h);
            b1[k] = h.u;
            b2[k] = h.v;
            sign[k] = if shape.flip_normals { -1.0 } else { 1.0 };
        }
        meta.rays(avx, st, ids);
        let x = sl::Triangle {
            p: [p[0].load(avx), p[1].load(avx), p[2].load(avx)],
            n: [nrm[0].load(avx), nrm[1].load(avx), nrm[2].load(avx)],
            uv: [
                V2::new(avx.load(&uv[0][0]), avx.load(&uv[0][1])),
                V2::new(avx.load(&uv[1][0]), avx.load(&uv[1][1])),
                V2::new(avx.load(&uv[2][0]), avx.load(&uv[2][1])),
            ],
            has_n: avx.mask(&has_n),
            has_uv: avx.mask(&has_uv),
            b1: avx.load(&b1),
            b2: avx.load(&b2),
            sign: avx.load(&sign),
        };
        (x, meta)
    }

    /// Hits on spheres with a similarity `to_world`: [`sl::sphere`].
    #[inline(always)]
    fn spheres(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let mut m = Meta::new(avx);
        let x = ray_points(avx, st, &ids, &mut m);
        if let Some(g) = m.one_shape() {
            let Form::Sphere(centre, radius, frame, sg) = &st.forms[g] else {
                unreachable!("a sphere's chunk holds spheres only");
            };
            let frame = [
                splat3(avx, frame.x_axis.truncate()),
                splat3(avx, frame.y_axis.truncate()),
                splat3(avx, frame.z_axis.truncate()),
            ];
            let (c, r, sign) = (splat3(avx, *centre), avx.splat(*radius), avx.splat(*sg));
            let s = sl::sphere(c, r, frame, sign, x);
            store(avx, st, &ids, n, &s, &m);
            return;
        }
        let (mut c, mut f) = (Cols3::default(), [Cols3::default(); 3]);
        let (mut r, mut sign) = ([0.0f32; 8], [0.0f32; 8]);
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = st.hit[i as usize].get() else {
                continue;
            };
            let Form::Sphere(centre, radius, frame, sg) = &st.forms[h.geom as usize] else {
                unreachable!("a sphere's chunk holds spheres only");
            };
            c.set(k, *centre);
            r[k] = *radius;
            sign[k] = *sg;
            f[0].set(k, frame.x_axis.truncate());
            f[1].set(k, frame.y_axis.truncate());
            f[2].set(k, frame.z_axis.truncate());
        }
        let frame = [f[0].load(avx), f[1].load(avx), f[2].load(avx)];
        let s = sl::sphere(c.load(avx), avx.load(&r), frame, avx.load(&sign), x);
        store(avx, st, &ids, n, &s, &m);
    }

    /// `v` in every lane.
    #[inline(always)]
    fn splat3(avx: Avx2, v: glam::Vec3) -> V3<F32x8> {
        V3::new(avx.splat(v.x), avx.splat(v.y), avx.splat(v.z))
    }

    #[inline(always)]
    fn load4(avx: Avx2, c: &[Cols3; 4]) -> [V3<F32x8>; 4] {
        [
            c[0].load(avx),
            c[1].load(avx),
            c[2].load(avx),
            c[3].load(avx),
        ]
    }

    /// Hits on rectangles: [`sl::rectangle`].
    #[inline(always)]
    fn rectangles(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let mut m = Meta::new(avx);
        let x = ray_points(avx, st, &ids, &mut m);
        let rect = if let Some(g) = m.one_shape() {
            let Form::Rectangle(r) = &st.forms[g] else {
                unreachable!("a rectangle's chunk holds rectangles only");
            };
            let (to_object, to_world, consts) = &**r;
            // Written out, not `map`/`from_fn`: those can be out-of-line calls compiled
            // without the lanes' target features.
            let col = |a: &glam::Mat4, j: usize| splat3(avx, a.col(j).truncate());
            let cols = |a| [col(a, 0), col(a, 1), col(a, 2), col(a, 3)];
            let [ng, nrm, dpdu, dpdv] = *consts;
            let (ng, nrm, dpdu, dpdv) = (
                splat3(avx, ng),
                splat3(avx, nrm),
                splat3(avx, dpdu),
                splat3(avx, dpdv),
            );
            sl::Rectangle {
                to_object: cols(to_object),
                to_world: cols(to_world),
                ng,
                n: nrm,
                dpdu,
                dpdv,
            }
        } else {
            let (mut o, mut w) = ([Cols3::default(); 4], [Cols3::default(); 4]);
            let mut k4 = [Cols3::default(); 4];
            for (k, &i) in ids.iter().enumerate() {
                let Some(h) = st.hit[i as usize].get() else {
                    continue;
                };
                let Form::Rectangle(r) = &st.forms[h.geom as usize] else {
                    unreachable!("a rectangle's chunk holds rectangles only");
                };
                let (to_object, to_world, consts) = &**r;
                for j in 0..4 {
                    o[j].set(k, to_object.col(j).truncate());
                    w[j].set(k, to_world.col(j).truncate());
                    k4[j].set(k, consts[j]);
                }
            }
            let [ng, nrm, dpdu, dpdv] = load4(avx, &k4);
            sl::Rectangle {
                to_object: load4(avx, &o),
                to_world: load4(avx, &w),
                ng,
                n: nrm,
                dpdu,
                dpdv,
            }
        };
        let s = sl::rectangle(&rect, x);
        store(avx, st, &ids, n, &s, &m);
    }

    /// Hits on disks: [`sl::disk`].
    #[inline(always)]
    fn disks_x8(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let (mut o, mut hw) = ([Cols3::default(); 4], [Cols3::default(); 4]);
        let (mut w, mut ng) = ([Cols3::default(); 3], Cols3::default());
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = st.hit[i as usize].get() else {
                continue;
            };
            let Form::Disk(d) = &st.forms[h.geom as usize] else {
                unreachable!("a disk's chunk holds disks only");
            };
            let (to_object, hit_to_world, to_world, nrm) = &**d;
            for j in 0..4 {
                o[j].set(k, to_object.col(j).truncate());
                hw[j].set(k, hit_to_world.col(j).truncate());
            }
            for (j, c) in w.iter_mut().enumerate() {
                c.set(k, to_world.col(j).truncate());
            }
            ng.set(k, *nrm);
        }
        let mut m = Meta::new(avx);
        let x = ray_points(avx, st, &ids, &mut m);
        let d = sl::Disk {
            to_object: load4(avx, &o),
            hit_to_world: load4(avx, &hw),
            to_world: [w[0].load(avx), w[1].load(avx), w[2].load(avx)],
            ng: ng.load(avx),
        };
        let s = sl::disk(&d, x);
        store(avx, st, &ids, n, &s, &m);
    }

    /// Hits on cylinders: [`sl::cylinder`].
    #[inline(always)]
    fn cylinders(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let (mut w, mut o) = ([Cols3::default(); 4], [Cols3::default(); 4]);
        let (mut nm, mut dpdv) = ([Cols3::default(); 3], Cols3::default());
        let (mut sign, mut quirk) = ([0.0f32; 8], [false; 8]);
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = st.hit[i as usize].get() else {
                continue;
            };
            let Form::Cylinder(c) = &st.forms[h.geom as usize] else {
                unreachable!("a cylinder's chunk holds cylinders only");
            };
            let (c, sg) = &**c;
            for j in 0..4 {
                w[j].set(k, c.to_world[j]);
                o[j].set(k, c.to_object[j]);
            }
            for (j, col) in nm.iter_mut().enumerate() {
                col.set(k, c.normal[j]);
            }
            dpdv.set(k, c.dpdv);
            (sign[k], quirk[k]) = (*sg, c.quirk);
        }
        let mut m = Meta::new(avx);
        let x = ray_points(avx, st, &ids, &mut m);
        let c = sl::CylinderLanes {
            to_world: load4(avx, &w),
            to_object: load4(avx, &o),
            normal: [nm[0].load(avx), nm[1].load(avx), nm[2].load(avx)],
            dpdv: dpdv.load(avx),
            sign: avx.load(&sign),
            quirk: avx.mask(&quirk),
        };
        let s = sl::cylinder(&c, x);
        store(avx, st, &ids, n, &s, &m);
    }

    /// The vector whose x is field `c`, in the rows that start at `row` (index of a row's
    /// first float).
    #[inline(always)]
    fn v3<I: LaneI32>(flat: &[f32; N], c: usize, row: I) -> V3<I::F> {
        // Plain statements, not a closure (a closure would be compiled outside `Avx2::run`'s
        // target features, see `kernels`).
        let (x, y, z) = (
            row.add(row.splat(c as i32)),
            row.add(row.splat(c as i32 + 1)),
            row.add(row.splat(c as i32 + 2)),
        );
        V3::new(
            I::F::gather::<N>(flat, x),
            I::F::gather::<N>(flat, y),
            I::F::gather::<N>(flat, z),
        )
    }

    /// The three kernels' surface prologue: the chunk's surfaces ([`load`]), their points per
    /// lane (for the lane-by-lane light points), the incident direction in the shading frame
    /// and the side test per lane (`diffuse::incident`), as booleans (the per-lane loops) and
    /// as bits (`bits`, bit `k` for lane `k`: the light gather's lanes,
    /// `light::x8::Gather::add_x8`, without a mask rebuilt from the booleans).
    pub(crate) struct Prologue<L: Lane, const W: usize> {
        pub surf: Surface<L>,
        pub p: crate::stream::kernels::light::x8::Cols3<W>,
        pub wi: V3<L>,
        pub front: [bool; W],
        pub bits: u32,
    }

    /// [`Prologue`] of the paths `ids`. Call inside [`Avx2::run`].
    #[inline(always)]
    pub(crate) fn prologue<T: Wide<W>, const W: usize>(
        avx: T,
        s: &Surfaces,
        ids: &[u32; W],
    ) -> Prologue<T::F, W> {
        let surf = load(avx, s, ids);
        let p = crate::stream::kernels::light::x8::Cols3::store(surf.p);
        let (wi, front) = crate::stream::kernels::diffuse::incident(&surf);
        Prologue {
            surf,
            p,
            wi,
            front: front.to_array(),
            bits: T::bits(front),
        }
    }

    /// The uvs of the paths `ids` (each with its interaction in `s`), for 8-wide texture
    /// lookups ([`crate::texture::BitmapTexture::eval_x8`]). Call inside [`Avx2::run`].
    #[inline(always)]
    pub(crate) fn uv<T: Wide<W>, const W: usize>(avx: T, s: &Surfaces, ids: &[u32; W]) -> V2<T::F> {
        let row = row_starts(avx, ids);
        let flat = s.flat();
        let (u, v) = (
            row.add(row.splat(cols::UV as i32)),
            row.add(row.splat(cols::UV as i32 + 1)),
        );
        V2::new(
            <T::F as Lane>::gather::<N>(flat, u),
            <T::F as Lane>::gather::<N>(flat, v),
        )
    }

    /// Where the rows of the paths `ids` start in [`Surfaces::flat`]: `id · ROW` in lanes (the
    /// ids loaded as they are and shifted, not 8 scalar products stored and reloaded; the same
    /// 32-bit words, `ROW` being a power of two).
    #[inline(always)]
    fn row_starts<T: Wide<W>, const W: usize>(avx: T, ids: &[u32; W]) -> T::I {
        const { assert!(cols::ROW == 1 << ROW_SHIFT) };
        avx.load_i32(&ids.map(|i| i as i32)).shl::<ROW_SHIFT>()
    }

    /// log₂ of [`cols::ROW`].
    const ROW_SHIFT: i32 = 5;

    /// The surfaces of the paths `ids` (each with its interaction in `s`). Call inside
    /// [`Avx2::run`].
    #[inline(always)]
    pub(crate) fn load<T: Wide<W>, const W: usize>(
        avx: T,
        s: &Surfaces,
        ids: &[u32; W],
    ) -> Surface<T::F> {
        let row = row_starts(avx, ids);
        let flat = s.flat();
        Surface {
            p: v3(flat, cols::P, row),
            ng: v3(flat, cols::NG, row),
            frame: Frame {
                s: v3(flat, cols::S, row),
                t: v3(flat, cols::T, row),
                n: v3(flat, cols::N, row),
            },
            wi_world: v3(flat, cols::WI, row),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{SmallTris, SMALL_TRIS};
    use crate::geometry::mesh::TriMesh;
    use glam::{Vec2, Vec3};

    /// A mesh of `tris` triangles over `tris + 2` vertices (a fan), with every attribute's
    /// bits distinct (signed zeros, subnormals, infinities and NaN payloads among them).
    fn mesh(tris: usize, normals: bool, uvs: bool) -> TriMesh {
        let n = tris + 2;
        let odd = [
            0.0f32,
            -0.0,
            1e-40,
            f32::INFINITY,
            f32::from_bits(0x7fc0_1234),
        ];
        let f = |k: usize| odd.get(k % 11).copied().unwrap_or(k as f32 * 1.25 - 7.0);
        TriMesh {
            positions: (0..n)
                .map(|i| Vec3::new(f(3 * i), f(3 * i + 1), f(3 * i + 2)))
                .collect(),
            normals: normals.then(|| (0..n).map(|i| Vec3::new(f(i + 50), -f(i), 0.5)).collect()),
            uvs: uvs.then(|| (0..n).map(|i| Vec2::new(f(i + 90), f(2 * i))).collect()),
            indices: (0..tris as u32).map(|t| [0, t + 1, t + 2]).collect(),
        }
    }

    /// The tables hold each triangle's corners' positions, normals and uvs bit for bit (zero
    /// for an attribute the mesh has not and past its triangles); a mesh of more than
    /// [`SMALL_TRIS`] triangles, or with an index out of range, or attribute arrays of another
    /// length than the positions, gets none (the gathers take it).
    #[test]
    fn small_tables_hold_the_mesh_bits() {
        for tris in 0..=SMALL_TRIS {
            for (normals, uvs) in [(false, false), (true, false), (false, true), (true, true)] {
                let m = mesh(tris, normals, uvs);
                let s = SmallTris::new(&m).expect("small");
                assert_eq!(s.wide, tris > 8);
                for t in 0..SMALL_TRIS {
                    for c in 0..3 {
                        let j = m.indices.get(t).map(|i| i[c] as usize);
                        for k in 0..3 {
                            let want = |v: Option<&Vec<Vec3>>| {
                                j.zip(v).map_or(0, |(j, v)| v[j].to_array()[k].to_bits())
                            };
                            assert_eq!(s.p[c][k][t].to_bits(), want(Some(&m.positions)));
                            assert_eq!(s.n[c][k][t].to_bits(), want(m.normals.as_ref()));
                        }
                        for k in 0..2 {
                            let want = j
                                .zip(m.uvs.as_ref())
                                .map_or(0, |(j, v)| v[j].to_array()[k].to_bits());
                            assert_eq!(s.uv[c][k][t].to_bits(), want);
                        }
                    }
                }
            }
        }
        assert!(SmallTris::new(&mesh(SMALL_TRIS + 1, true, true)).is_none());
        let mut bad = mesh(3, true, false);
        bad.indices[2][1] = bad.positions.len() as u32;
        assert!(SmallTris::new(&bad).is_none());
        let mut short = mesh(3, true, true);
        short.uvs.as_mut().unwrap().pop();
        assert!(SmallTris::new(&short).is_none());
    }

    /// The gather stage in lanes (`x8::fill`) writes every hit's row and flag as the scalar
    /// stage does (`Scene::interaction` into `Surfaces::set`), bit for bit, at width 8 and,
    /// where the CPU has AVX-512, with the one-mesh chunks of meshes of at most 16 triangles
    /// 16 wide (full chunks, partial ones of 9 to 15 padded, the rest 8 wide): random rays from
    /// inside the scenes' bounds, random subsets of a batch active, on the Cornell box's cubes
    /// and the chunk scene's cubes, octahedra and quad (normals, uvs, flipped, face normals;
    /// meshes sharing a slot) and the surface scene's every form.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn lane_rows_equal_the_scalar_rows_at_widths_8_and_16() {
        use crate::accel::HitRow;
        use crate::geometry::Ray;
        use crate::lane::{Avx2, Avx512};
        use crate::math::Pcg32;
        use crate::sampler::Sampler;
        use crate::stream::batch::{cols, Batch};
        use crate::stream::BATCH;
        let Some(avx) = Avx2::detect() else {
            eprintln!("note: no AVX2: the lane gather stage is not checked");
            return;
        };
        let w16 = Avx512::detect();
        if w16.is_none() {
            eprintln!("note: no AVX-512: the 16-wide surface chunks are not checked");
        }
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/scenes/");
        let mut r = Pcg32::new(43, 1);
        for name in [
            "cbox_v3.xml",
            "stream_mesh_chunks.xml",
            "stream_surfaces.xml",
        ] {
            let path = std::path::PathBuf::from(dir).join(name);
            let l = crate::load::load_scene(&path, &Default::default()).unwrap();
            let scene = &l.scene;
            let forms = super::Form::table(scene);
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for s in &scene.shapes {
                let (a, b) = s.bounds();
                (lo, hi) = (lo.min(a), hi.max(b));
            }
            let (mut lanes16, mut hits) = (0, 0);
            for round in 0..24 {
                // New batches each round (`Batch::push` appends to the rays and hits kept).
                let mut batch = Batch::new(BATCH, scene.materials.node_count());
                let mut want = Batch::new(BATCH, scene.materials.node_count());
                let share = [1.0, 0.9, 0.5, 0.1][round % 4];
                let mut active = Vec::new();
                for i in 0..BATCH {
                    let mut f = || r.next_f32();
                    let o = lo + (hi - lo) * Vec3::new(f(), f(), f());
                    let d = Vec3::new(f() - 0.5, f() - 0.5, f() - 0.5)
                        .try_normalize()
                        .unwrap_or(Vec3::Z);
                    let ray = Ray::new(o, d);
                    let hit = HitRow::new(scene.accel.intersect(&ray));
                    for b in [&mut batch, &mut want] {
                        b.push(Vec2::ZERO, Sampler::from_seed(1, i as u64), ray);
                        b.hit[i] = hit;
                    }
                    if f() < share {
                        active.push(i as u32);
                    }
                }
                for b in [&mut batch, &mut want] {
                    b.active.clone_from(&active);
                    b.hit_flag.fill(7);
                }
                super::fill(scene, &forms, None, None, &mut want, &mut 0, &mut 0);
                // Width 8 on even rounds, 16 (where there) on odd ones.
                let wide = if round % 2 == 1 { w16 } else { None };
                let (n, n16) = super::x8::fill(avx, wide, scene, &forms, &mut batch);
                (hits, lanes16) = (hits + n, lanes16 + n16);
                assert!(
                    wide.is_some() || n16 == 0,
                    "{name}: 16 wide without AVX-512"
                );
                assert_eq!(
                    batch.hit_flag, want.hit_flag,
                    "{name}, round {round}: flags"
                );
                let (got, exp) = (batch.surf.flat(), want.surf.flat());
                for &i in &active {
                    let i = i as usize;
                    let row = i * cols::ROW..(i + 1) * cols::ROW;
                    for (c, (g, w)) in got[row.clone()].iter().zip(&exp[row]).enumerate() {
                        assert_eq!(
                            g.to_bits(),
                            w.to_bits(),
                            "{name}, round {round} (16 wide: {}), path {i}, field {c}: {:?}",
                            wide.is_some(),
                            batch.hit[i].get(),
                        );
                    }
                }
            }
            eprintln!("{name}: {hits} hits in lanes, {lanes16} of them 16 wide");
            assert!(hits > 0, "{name}: no hit in lanes");
            if w16.is_some() && name != "stream_surfaces.xml" {
                assert!(lanes16 > 0, "{name}: no 16-wide chunk");
            }
        }
    }
}
