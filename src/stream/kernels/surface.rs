//! The surface rows of the batch ([`crate::stream::batch::Surfaces`]): the gather stage that
//! fills them after each trace ([`fill`]: hits on triangle meshes, similarity spheres,
//! rectangles, disks and cylinders, and on meshes seen through instances, reconstructed 8 at a
//! time by the lane forms of [`crate::geometry::surface_lanes`], every other hit by
//! `Scene::interaction`; direct mesh hits wait in chunks of one mesh where they can, whose
//! triangles, vertices, normals and uvs are vector gathers, `x8::MeshChunks`, 16 at a time on
//! AVX-512: the same functions instantiated at width 16, a flushed chunk of at most 8 hits 8
//! wide), and the one surface load of the three kernels ([`super::diffuse`], [`super::vertex`],
//! [`super::plastic`]): 8 paths' surface points, true normals, shading frames and incident
//! directions, loaded 8-wide in place from the rows, one `vgatherdps` per field over the 8
//! rows. The rows hold the scalar interaction's bits either way.

use crate::geometry::hit::NO_INSTANCE;
use crate::scene::Scene;
use crate::stream::batch::Batch;
use glam::{Mat4, Vec3};

/// How the gather stage reconstructs a hit on a shape (instanced hits take the lane forms on
/// meshes only, `Scene::interaction` on other shapes).
#[derive(Clone, Debug)]
pub(crate) enum Form {
    /// A triangle mesh: [`crate::geometry::surface_lanes::triangle`].
    Triangles,
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
                if let ShapeKind::Mesh(_) = s.kind {
                    Form::Triangles
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

/// The gather stage: writes the surface row of every active path of `batch` whose ray hit
/// something (rows of paths without a hit are left as they are). 8-wide where `avx` is given
/// (the chunk's hits grouped by form; one mesh's hits 16 at a time where `avx512` is given too,
/// [`x8::fill`]), else one `Scene::interaction` per hit; adds the hits reconstructed in lanes
/// to `in_lanes.0`, the part of them reconstructed 16 wide to `in_lanes.1`.
pub(crate) fn fill(
    scene: &Scene,
    forms: &[Form],
    #[cfg(target_arch = "x86_64")] avx: Option<(crate::lane::Avx2, Option<crate::lane::Avx512>)>,
    batch: &mut Batch,
    in_lanes: (&mut u64, &mut u64),
) {
    #[cfg(target_arch = "x86_64")]
    if let Some((avx, w16)) = avx {
        let (lanes, lanes16) = x8::fill(avx, w16, scene, forms, batch);
        *in_lanes.0 += lanes;
        *in_lanes.1 += lanes16;
        return;
    }
    let _ = (forms, in_lanes);
    let (active, hit, ray, surf) = (&batch.active, &batch.hit, &batch.ray, &mut batch.surf);
    for &i in active {
        let i = i as usize;
        if let Some(h) = &hit[i] {
            surf.set(i, &scene.interaction(&ray[i], h));
        }
    }
}

/// Whether a hit is on a shape itself, not seen through an instance.
#[inline(always)]
fn direct(h: &crate::geometry::Hit) -> bool {
    h.inst == NO_INSTANCE
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use crate::lane::frame::Frame;
    use crate::lane::vec::V3;
    use crate::lane::{Avx2, Avx512, F32x16, F32x8, Lane, LaneI32, ToArray, Wide};
    use crate::stream::batch::{cols, Surfaces};
    use crate::stream::kernels::diffuse::Surface;
    use crate::stream::BATCH;

    const N: usize = BATCH * cols::ROW;

    use super::Form;
    use crate::geometry::surface_lanes::{self as sl, SurfLanes};
    use crate::geometry::{Hit, Ray, ShapeKind};
    use crate::lane::vec::V2;
    use crate::scene::Scene;
    use crate::stream::batch::Batch;

    /// Up to `W` path ids of one form waiting for their `W`-wide reconstruction.
    struct Pending<const W: usize = 8> {
        ids: [u32; W],
        n: usize,
    }

    impl<const W: usize> Pending<W> {
        const EMPTY: Pending<W> = Pending { ids: [0; W], n: 0 };
        /// Adds `i`; returns whether the chunk is full.
        #[inline(always)]
        fn push(&mut self, i: u32) -> bool {
            self.ids[self.n] = i;
            self.n += 1;
            self.n == W
        }
        /// The ids, padded with the first (a padded lane is computed and not stored).
        #[inline(always)]
        fn take(&mut self) -> ([u32; W], usize) {
            let n = std::mem::take(&mut self.n);
            let mut ids = self.ids;
            let first = ids[0];
            for id in &mut ids[n..] {
                *id = first;
            }
            (ids, n)
        }
    }

    /// How many one-mesh chunks [`MeshChunks`] keeps.
    const SLOTS: usize = 8;

    /// Direct hits on triangle meshes waiting for their `W`-wide reconstruction, in chunks of
    /// one mesh each where they can (slot `geom % SLOTS` holds one mesh's hits at a time; those
    /// are gathered with vector gathers, [`one_mesh_triangles`]), else in `mixed` (8 wide,
    /// gathered lane by lane, [`triangles`]). Which chunk a hit waits in changes only the order
    /// in which rows are written, not what they hold.
    struct MeshChunks<const W: usize> {
        geom: [u32; SLOTS],
        slot: [Pending<W>; SLOTS],
        mixed: Pending,
    }

    impl<const W: usize> MeshChunks<W> {
        const EMPTY: MeshChunks<W> = MeshChunks {
            geom: [0; SLOTS],
            slot: [Pending::EMPTY; SLOTS],
            mixed: Pending::EMPTY,
        };

        /// Adds path `i`, whose ray hit mesh `geom`; reconstructs the chunk it fills.
        #[inline(always)]
        fn push<T: Rows<W>>(&mut self, t: T, avx: Avx2, st: &mut Stage, geom: u32, i: u32) {
            let s = geom as usize % SLOTS;
            if self.slot[s].n == 0 {
                self.geom[s] = geom;
            }
            if self.geom[s] == geom {
                if self.slot[s].push(i) {
                    one_mesh_triangles(t, avx, st, geom, self.slot[s].take());
                }
            } else if self.mixed.push(i) {
                triangles(avx, st, self.mixed.take());
            }
        }

        /// Reconstructs the partly filled chunks (padded); at width 16 a chunk of at most 8
        /// hits goes 8 wide (the same rows: only the chunking changes).
        #[inline(always)]
        fn flush<T: Rows<W>>(&mut self, t: T, avx: Avx2, st: &mut Stage) {
            for s in 0..SLOTS {
                let n = self.slot[s].n;
                if n > 8 || (n > 0 && W == 8) {
                    one_mesh_triangles(t, avx, st, self.geom[s], self.slot[s].take());
                } else if n > 0 {
                    let (ids, n) = self.slot[s].take();
                    let ids: [u32; 8] = ids[..8].try_into().expect("8 ids");
                    one_mesh_triangles(avx, avx, st, self.geom[s], (ids, n));
                }
            }
            if self.mixed.n > 0 {
                triangles(avx, st, self.mixed.take());
            }
        }
    }

    /// The rays, hits and rows the gather stage works on.
    struct Stage<'a> {
        scene: &'a Scene,
        forms: &'a [Form],
        ray: &'a [Ray],
        hit: &'a [Option<Hit>],
        surf: &'a mut Surfaces,
        /// Hits whose rows were written by a 16-wide chunk.
        lanes16: u64,
    }

    /// What the gather stage needs of a lane width besides [`Wide`]: a chunk's rays, a mesh's
    /// triangles and uvs by vector gathers, and the rows' stores. [`Avx2`] is width 8;
    /// [`Avx512`] width 16, whose rays are two 8-wide loads joined and whose rows are stored as
    /// two 8-wide halves (moves only, so the same bits).
    trait Rows<const W: usize>: Wide<W> {
        /// The rays of the paths `ids` in lanes: o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax.
        fn ray_fields(self, avx: Avx2, rays: &[Ray], ids: &[u32; W]) -> [Self::F; 8];
        /// [`Avx2::gather3_u32`] at this width.
        fn gather3_u32(self, table: &[[u32; 3]], idx: Self::I) -> [Self::I; 3];
        /// [`Avx2::gather2`] at this width.
        fn gather2(self, table: &[glam::Vec2], idx: Self::I) -> [Self::F; 2];
        /// `b` in every lane.
        fn all(self, b: bool) -> Self::M;
        /// [`store`] at this width.
        fn store(
            self,
            avx: Avx2,
            st: &mut Stage,
            ids: &[u32; W],
            n: usize,
            s: &SurfLanes<Self::F>,
            m: &Meta<Self::F, W>,
        );
    }

    impl Rows<8> for Avx2 {
        #[inline(always)]
        fn ray_fields(self, _: Avx2, rays: &[Ray], ids: &[u32; 8]) -> [F32x8; 8] {
            Avx2::ray_fields(self, rays, ids)
        }
        #[inline(always)]
        fn gather3_u32(
            self,
            table: &[[u32; 3]],
            idx: crate::lane::I32x8,
        ) -> [crate::lane::I32x8; 3] {
            Avx2::gather3_u32(self, table, idx)
        }
        #[inline(always)]
        fn gather2(self, table: &[glam::Vec2], idx: crate::lane::I32x8) -> [F32x8; 2] {
            Avx2::gather2(self, table, idx)
        }
        #[inline(always)]
        fn all(self, b: bool) -> crate::lane::M8 {
            self.mask_splat(b)
        }
        #[inline(always)]
        fn store(
            self,
            _: Avx2,
            st: &mut Stage,
            ids: &[u32; 8],
            n: usize,
            s: &SurfLanes<F32x8>,
            m: &Meta<F32x8, 8>,
        ) {
            store(self, st, ids, n, s, m)
        }
    }

    /// Two 8-wide vectors as one 16-wide (lanes 0–7, then 8–15).
    #[inline(always)]
    fn join(w: Avx512, lo: F32x8, hi: F32x8) -> F32x16 {
        let mut a = [0.0f32; 16];
        let (l, h) = a.split_at_mut(8);
        lo.store(l.try_into().expect("8 floats"));
        hi.store(h.try_into().expect("8 floats"));
        w.load(&a)
    }

    /// A 16-wide vector's lanes 0–7 (`half` 0) or 8–15 (`half` 1) as an 8-wide one.
    #[inline(always)]
    fn half(avx: Avx2, v: F32x16, half: usize) -> F32x8 {
        let a = v.to_array();
        avx.load(a[8 * half..8 * half + 8].try_into().expect("8 floats"))
    }

    #[inline(always)]
    fn half3(avx: Avx2, v: V3<F32x16>, h: usize) -> V3<F32x8> {
        V3::new(half(avx, v.x, h), half(avx, v.y, h), half(avx, v.z, h))
    }

    impl Rows<16> for Avx512 {
        #[inline(always)]
        fn ray_fields(self, avx: Avx2, rays: &[Ray], ids: &[u32; 16]) -> [F32x16; 8] {
            let lo = avx.ray_fields(rays, ids[..8].try_into().expect("8 ids"));
            let hi = avx.ray_fields(rays, ids[8..].try_into().expect("8 ids"));
            [
                join(self, lo[0], hi[0]),
                join(self, lo[1], hi[1]),
                join(self, lo[2], hi[2]),
                join(self, lo[3], hi[3]),
                join(self, lo[4], hi[4]),
                join(self, lo[5], hi[5]),
                join(self, lo[6], hi[6]),
                join(self, lo[7], hi[7]),
            ]
        }
        #[inline(always)]
        fn gather3_u32(
            self,
            table: &[[u32; 3]],
            idx: crate::lane::I32x16,
        ) -> [crate::lane::I32x16; 3] {
            Avx512::gather3_u32(self, table, idx)
        }
        #[inline(always)]
        fn gather2(self, table: &[glam::Vec2], idx: crate::lane::I32x16) -> [F32x16; 2] {
            Avx512::gather2(self, table, idx)
        }
        #[inline(always)]
        fn all(self, b: bool) -> crate::lane::M16 {
            self.mask(&[b; 16])
        }
        /// Lanes 0–7, then (where `n` > 8) lanes 8–15, each through the 8-wide [`store`].
        #[inline(always)]
        fn store(
            self,
            avx: Avx2,
            st: &mut Stage,
            ids: &[u32; 16],
            n: usize,
            s: &SurfLanes<F32x16>,
            m: &Meta<F32x16, 16>,
        ) {
            st.lanes16 += n as u64;
            for h in 0..2 {
                if n <= 8 * h {
                    break;
                }
                let (f, r) = (&s.frame, 8 * h..8 * h + 8);
                let s8 = SurfLanes {
                    p: half3(avx, s.p, h),
                    ng: half3(avx, s.ng, h),
                    frame: Frame {
                        s: half3(avx, f.s, h),
                        t: half3(avx, f.t, h),
                        n: half3(avx, f.n, h),
                    },
                    uv: V2::new(half(avx, s.uv.x, h), half(avx, s.uv.y, h)),
                    dpdu: half3(avx, s.dpdu, h),
                    dpdv: half3(avx, s.dpdv, h),
                };
                let m8 = Meta {
                    wi: half3(avx, m.wi, h),
                    t: m.t[r.clone()].try_into().expect("8 floats"),
                    shape: m.shape[r.clone()].try_into().expect("8 floats"),
                    prim: m.prim[r.clone()].try_into().expect("8 floats"),
                };
                let ids: &[u32; 8] = ids[r].try_into().expect("8 ids");
                store(avx, st, ids, (n - 8 * h).min(8), &s8, &m8);
            }
        }
    }

    /// [`super::fill`] in lanes: each active path with a hit goes to its form's pending chunk,
    /// which is reconstructed when it holds 8 (one mesh's hits: 16 where `w16` is given) and at
    /// the end, padded. Returns how many hits went through the lane forms, and how many of them
    /// 16 wide.
    pub(crate) fn fill(
        avx: Avx2,
        w16: Option<Avx512>,
        scene: &Scene,
        forms: &[Form],
        batch: &mut Batch,
    ) -> (u64, u64) {
        match w16 {
            Some(w) => w.run(
                #[inline(always)]
                || fill_in(w, avx, scene, forms, batch),
            ),
            None => avx.run(
                #[inline(always)]
                || fill_in(avx, avx, scene, forms, batch),
            ),
        }
    }

    /// [`fill`] with one mesh's hits `W` wide through `t`, the rest 8 wide through `avx`. Call
    /// inside `t`'s `run`.
    #[inline(always)]
    fn fill_in<T: Rows<W>, const W: usize>(
        t: T,
        avx: Avx2,
        scene: &Scene,
        forms: &[Form],
        batch: &mut Batch,
    ) -> (u64, u64) {
        {
            {
                let mut st = Stage {
                    scene,
                    forms,
                    ray: &batch.ray,
                    hit: &batch.hit,
                    surf: &mut batch.surf,
                    lanes16: 0,
                };
                let mut tri = MeshChunks::<W>::EMPTY;
                let (mut sph, mut rect) = (Pending::EMPTY, Pending::EMPTY);
                let (mut disks, mut itri) = (Pending::EMPTY, Pending::EMPTY);
                let mut cyl = Pending::EMPTY;
                let mut scalar = 0;
                let mut hits = 0;
                for &i in &batch.active {
                    let Some(h) = &st.hit[i as usize] else {
                        continue;
                    };
                    hits += 1;
                    let form = &st.forms[h.geom as usize];
                    if !super::direct(h) {
                        if let Form::Triangles = form {
                            if itri.push(i) {
                                instanced_triangles(avx, &mut st, itri.take());
                            }
                        } else {
                            scalar += 1;
                            let i = i as usize;
                            let si = st.scene.interaction(&st.ray[i], h);
                            st.surf.set(i, &si);
                        }
                        continue;
                    }
                    match form {
                        Form::Triangles => tri.push(t, avx, &mut st, h.geom, i),
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
                            let si = st.scene.interaction(&st.ray[i], h);
                            st.surf.set(i, &si);
                        }
                    }
                }
                tri.flush(t, avx, &mut st);
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
                (hits - scalar, st.lanes16)
            }
        }
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

    /// Each lane's ray point at its hit (`Ray::at`, 8-wide), and its [`Meta`].
    #[inline(always)]
    fn ray_points(avx: Avx2, st: &Stage, ids: &[u32; 8], m: &mut Meta) -> V3<F32x8> {
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = &st.hit[i as usize] else {
                continue;
            };
            m.set(k, h);
        }
        let (o, d) = m.rays(avx, avx, st, ids);
        sl::ray_at(o, d, avx.load(&m.t))
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

    /// What a row takes from each lane's hit and ray besides the lane form's fields (`W`
    /// lanes of type `F`).
    struct Meta<F = F32x8, const W: usize = 8> {
        /// −ray.d ([`Meta::rays`]).
        wi: V3<F>,
        t: [f32; W],
        /// The shape and primitive indices' bits.
        shape: [f32; W],
        prim: [f32; W],
    }

    impl<F: Lane, const W: usize> Meta<F, W> {
        #[inline(always)]
        fn new<T: Wide<W, F = F>>(t: T) -> Meta<F, W> {
            let z = t.splat(0.0);
            Meta {
                wi: V3::new(z, z, z),
                t: [0.0; W],
                shape: [0.0; W],
                prim: [0.0; W],
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
        fn rays<T: Rows<W, F = F>>(
            &mut self,
            t: T,
            avx: Avx2,
            st: &Stage,
            ids: &[u32; W],
        ) -> (V3<F>, V3<F>) {
            let f = t.ray_fields(avx, st.ray, ids);
            let d = V3::new(f[3], f[4], f[5]);
            self.wi = -d;
            (V3::new(f[0], f[1], f[2]), d)
        }
    }

    /// Writes the first `n` lanes of `s` and `m` into the rows of `ids`: the 32 fields as four
    /// groups of 8 lanes, each transposed into 8 rows' runs of 8 floats (one store per group
    /// and row instead of 29 scalar stores per row).
    #[inline(always)]
    fn store(avx: Avx2, st: &mut Stage, ids: &[u32; 8], n: usize, s: &SurfLanes<F32x8>, m: &Meta) {
        let wi = m.wi;
        let (f, z) = (&s.frame, avx.splat(0.0));
        let g0 = F32x8::transpose8([s.p.x, s.p.y, s.p.z, s.ng.x, s.ng.y, s.ng.z, f.s.x, f.s.y]);
        let g1 = F32x8::transpose8([f.s.z, f.t.x, f.t.y, f.t.z, f.n.x, f.n.y, f.n.z, wi.x]);
        let g2 = F32x8::transpose8([
            wi.y, wi.z, s.uv.x, s.uv.y, s.dpdu.x, s.dpdu.y, s.dpdu.z, s.dpdv.x,
        ]);
        let (t, shape, prim) = (avx.load(&m.t), avx.load(&m.shape), avx.load(&m.prim));
        let g3 = F32x8::transpose8([s.dpdv.y, s.dpdv.z, t, shape, prim, z, z, z]);
        for (k, &i) in ids.iter().enumerate().take(n) {
            let r = st.surf.row_mut(i as usize);
            let (a, rest) = r.split_at_mut(8);
            let (b, rest) = rest.split_at_mut(8);
            let (c, d) = rest.split_at_mut(8);
            g0[k].store(a.try_into().expect("8 floats"));
            g1[k].store(b.try_into().expect("8 floats"));
            g2[k].store(c.try_into().expect("8 floats"));
            g3[k].store(d.try_into().expect("8 floats"));
        }
    }

    /// Hits on triangle meshes: [`triangle_input`], then [`sl::triangle`].
    #[inline(always)]
    fn triangles(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let (x, meta) = triangle_input(avx, st, &ids);
        let s = sl::triangle(&x);
        store(avx, st, &ids, n, &s, &meta);
    }

    /// Hits on one triangle mesh, shape `g` (every lane's), `W` at a time through `t`:
    /// [`one_mesh_input`], then [`sl::triangle`] ([`sl::triangle_no_uv`] for a mesh without
    /// uvs); a mesh too large for 32-bit gather offsets takes [`triangles`], 8 at a time.
    #[inline(always)]
    fn one_mesh_triangles<T: Rows<W>, const W: usize>(
        t: T,
        avx: Avx2,
        st: &mut Stage,
        g: u32,
        (ids, n): ([u32; W], usize),
    ) {
        let shape = &st.scene.shapes[g as usize];
        let ShapeKind::Mesh(m) = &shape.kind else {
            unreachable!("Form::Triangles is set for meshes only");
        };
        let fits = |len: usize| len <= i32::MAX as usize / 3;
        if !(fits(m.indices.len())
            && fits(m.positions.len())
            && m.normals.as_ref().is_none_or(|v| fits(v.len()))
            && m.uvs.as_ref().is_none_or(|v| fits(v.len())))
        {
            // Eight lanes at a time (padded with the chunk's first id, as `Pending::take`).
            for h in (0..W).step_by(8).take_while(|&h| h < n) {
                let ids8: [u32; 8] = ids[h..h + 8].try_into().expect("8 ids");
                triangles(avx, st, (ids8, (n - h).min(8)));
            }
            return;
        }
        let (x, meta) = one_mesh_input(t, avx, st, &ids, m, shape.flip_normals);
        let s = if m.uvs.is_some() {
            sl::triangle(&x)
        } else {
            sl::triangle_no_uv(&x)
        };
        t.store(avx, st, &ids, n, &s, &meta);
    }

    /// [`triangle_input`] for lanes that all hit mesh `m` (whose `flip_normals` is `flip`):
    /// the triangles' vertex indices, then their positions, normals and uvs, by vector
    /// gathers; the per-mesh flags and sign splat. The same values as lane by lane (the mesh is
    /// validated at load: its indices are in range, so the gathers' clamps change nothing).
    #[inline(always)]
    fn one_mesh_input<T: Rows<W>, const W: usize>(
        t: T,
        avx: Avx2,
        st: &Stage,
        ids: &[u32; W],
        m: &crate::geometry::mesh::TriMesh,
        flip: bool,
    ) -> (sl::Triangle<T::F>, Meta<T::F, W>) {
        let (mut prim, mut b1, mut b2) = ([0i32; W], [0.0f32; W], [0.0f32; W]);
        let mut meta = Meta::new(t);
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = st.hit[i as usize] else {
                continue;
            };
            prim[k] = h.prim as i32;
            b1[k] = h.u;
            b2[k] = h.v;
            meta.set(k, &h);
        }
        meta.rays(t, avx, st, ids);
        let tri = t.gather3_u32(&m.indices, t.load_i32(&prim));
        let p = [
            gv3(T::F::gather3(&m.positions, tri[0])),
            gv3(T::F::gather3(&m.positions, tri[1])),
            gv3(T::F::gather3(&m.positions, tri[2])),
        ];
        let z = t.splat(0.0);
        let (n, has_n) = match &m.normals {
            Some(ns) => (
                [
                    gv3(T::F::gather3(ns, tri[0])),
                    gv3(T::F::gather3(ns, tri[1])),
                    gv3(T::F::gather3(ns, tri[2])),
                ],
                t.all(true),
            ),
            None => ([V3::new(z, z, z); 3], t.all(false)),
        };
        let (uv, has_uv) = match &m.uvs {
            Some(uvs) => (
                [
                    gv2(t.gather2(uvs, tri[0])),
                    gv2(t.gather2(uvs, tri[1])),
                    gv2(t.gather2(uvs, tri[2])),
                ],
                t.all(true),
            ),
            None => ([V2::new(z, z); 3], t.all(false)),
        };
        let x = sl::Triangle {
            p,
            n,
            uv,
            has_n,
            has_uv,
            b1: t.load(&b1),
            b2: t.load(&b2),
            sign: t.splat(if flip { -1.0 } else { 1.0 }),
        };
        (x, meta)
    }

    /// A gathered vector's components as a [`V3`] (a plain function, not a closure: see
    /// `tests/cli/simd_calls.rs`).
    #[inline(always)]
    fn gv3<L: Lane>(c: [L; 3]) -> V3<L> {
        V3::new(c[0], c[1], c[2])
    }

    #[inline(always)]
    fn gv2<L: Lane>(c: [L; 2]) -> V2<L> {
        V2::new(c[0], c[1])
    }

    /// Hits on meshes seen through instances: [`triangle_input`] (the member's triangle, in
    /// group space), [`sl::triangle`], then each lane's instance transform ([`sl::instance`]).
    #[inline(always)]
    fn instanced_triangles(avx: Avx2, st: &mut Stage, (ids, n): ([u32; 8], usize)) {
        let (x, meta) = triangle_input(avx, st, &ids);
        let (mut w, mut nm) = ([Cols3::default(); 4], [Cols3::default(); 3]);
        for (k, &i) in ids.iter().enumerate() {
            let Some(h) = st.hit[i as usize] else {
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
            let Some(h) = st.hit[i as usize] else {
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
        meta.rays(avx, avx, st, ids);
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
            let Some(h) = st.hit[i as usize] else {
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
                let Some(h) = st.hit[i as usize] else {
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
            let Some(h) = st.hit[i as usize] else {
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
            let Some(h) = st.hit[i as usize] else {
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
    /// and the side test per lane (`diffuse::incident`).
    pub(crate) struct Prologue<L: Lane, const W: usize> {
        pub surf: Surface<L>,
        pub p: crate::stream::kernels::light::x8::Cols3<W>,
        pub wi: V3<L>,
        pub front: [bool; W],
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
        }
    }

    /// The uvs of the paths `ids` (each with its interaction in `s`), for 8-wide texture
    /// lookups ([`crate::texture::BitmapTexture::eval_x8`]). Call inside [`Avx2::run`].
    #[inline(always)]
    pub(crate) fn uv<T: Wide<W>, const W: usize>(avx: T, s: &Surfaces, ids: &[u32; W]) -> V2<T::F> {
        let row = avx.load_i32(&ids.map(|i| (i as usize * cols::ROW) as i32));
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

    /// The surfaces of the paths `ids` (each with its interaction in `s`). Call inside
    /// [`Avx2::run`].
    #[inline(always)]
    pub(crate) fn load<T: Wide<W>, const W: usize>(
        avx: T,
        s: &Surfaces,
        ids: &[u32; W],
    ) -> Surface<T::F> {
        let row = avx.load_i32(&ids.map(|i| (i as usize * cols::ROW) as i32));
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
