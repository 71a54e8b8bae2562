//! The only FFI module: a thin, safe wrapper over Embree 3's C API (through `embree3::sys`).
//!
//! One device and one scene per [`EmbreeScene`]; geometry `i` is attached with id `i`, so Embree's
//! `geomID` is the caller's shape index. Embree scenes are immutable after `rtcCommitScene` and
//! `rtcIntersect1` / `rtcOccluded1` are thread-safe (Embree 3 API docs, "rtcIntersect1"), which is
//! what makes the wrapper `Send + Sync`.

use embree3::sys::*;
use glam::Vec3;
use std::ffi::{c_char, c_void, CStr};
use std::ptr;
use std::sync::Mutex;

/// Geometry handed to Embree, borrowed from the shapes.
pub(crate) enum GeomDesc<'a> {
    Triangles {
        positions: &'a [Vec3],
        indices: &'a [[u32; 3]],
    },
    /// Embree's exact ray–sphere primitive (`RTC_GEOMETRY_TYPE_SPHERE_POINT`).
    Sphere { center: Vec3, radius: f32 },
}

/// A committed Embree scene with its device.
pub(crate) struct EmbreeScene {
    device: RTCDevice,
    scene: RTCScene,
    /// Messages reported by Embree's error callback (the callback's user pointer points here).
    _errors: Box<Mutex<Vec<String>>>,
}

// SAFETY: the scene is committed and never mutated afterwards; Embree documents traversal
// (rtcIntersect1/rtcOccluded1) of a committed scene as thread-safe. The handles are released
// exactly once, in Drop.
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

/// A hit as Embree reports it.
pub(crate) struct RawHit {
    pub geom: u32,
    pub prim: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

unsafe extern "C" fn on_error(user: *mut c_void, code: RTCError, msg: *const c_char) {
    if user.is_null() {
        return;
    }
    // SAFETY: `user` is the address of the boxed Mutex owned by the EmbreeScene, which outlives
    // the device (the device is released first in Drop).
    let errors = unsafe { &*(user as *const Mutex<Vec<String>>) };
    let text = if msg.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated string valid for the duration of the call.
        unsafe { CStr::from_ptr(msg) }
            .to_string_lossy()
            .into_owned()
    };
    if let Ok(mut e) = errors.lock() {
        e.push(format!("{code:?}: {text}"));
    }
}

impl EmbreeScene {
    /// Builds and commits a scene; geometry `i` gets Embree id `i`.
    pub(crate) fn build(geoms: &[GeomDesc]) -> Result<EmbreeScene, String> {
        let errors = Box::new(Mutex::new(Vec::new()));
        // SAFETY: plain C calls; every handle is checked for null before use, and ownership of
        // the device/scene passes to the returned value (released in Drop, also on error paths
        // because `this` is constructed before anything can fail).
        unsafe {
            let device = rtcNewDevice(ptr::null());
            if device.is_null() {
                return Err("Embree: rtcNewDevice failed (unsupported CPU?)".into());
            }
            rtcSetDeviceErrorFunction(
                device,
                Some(on_error),
                &*errors as *const Mutex<Vec<String>> as *mut c_void,
            );
            let scene = rtcNewScene(device);
            let this = EmbreeScene {
                device,
                scene,
                _errors: errors,
            };
            if scene.is_null() {
                return Err(this.error_text("rtcNewScene failed"));
            }
            for (id, g) in geoms.iter().enumerate() {
                let geom = match g {
                    GeomDesc::Triangles { positions, indices } => {
                        let geom = rtcNewGeometry(device, RTCGeometryType::TRIANGLE);
                        if geom.is_null() {
                            return Err(this.error_text("rtcNewGeometry failed"));
                        }
                        let vb = rtcSetNewGeometryBuffer(
                            geom,
                            RTCBufferType::VERTEX,
                            0,
                            RTCFormat::FLOAT3,
                            12,
                            positions.len(),
                        ) as *mut f32;
                        let ib = rtcSetNewGeometryBuffer(
                            geom,
                            RTCBufferType::INDEX,
                            0,
                            RTCFormat::UINT3,
                            12,
                            indices.len(),
                        ) as *mut u32;
                        if vb.is_null() || ib.is_null() {
                            rtcReleaseGeometry(geom);
                            return Err(this.error_text("geometry buffer allocation failed"));
                        }
                        // SAFETY: Embree allocated `len` items of the given stride (plus padding).
                        let vs = std::slice::from_raw_parts_mut(vb, positions.len() * 3);
                        for (k, p) in positions.iter().enumerate() {
                            vs[3 * k..3 * k + 3].copy_from_slice(&p.to_array());
                        }
                        let is = std::slice::from_raw_parts_mut(ib, indices.len() * 3);
                        for (k, t) in indices.iter().enumerate() {
                            is[3 * k..3 * k + 3].copy_from_slice(t);
                        }
                        geom
                    }
                    GeomDesc::Sphere { center, radius } => {
                        let geom = rtcNewGeometry(device, RTCGeometryType::SPHERE_POINT);
                        if geom.is_null() {
                            return Err(this.error_text("rtcNewGeometry failed"));
                        }
                        let vb = rtcSetNewGeometryBuffer(
                            geom,
                            RTCBufferType::VERTEX,
                            0,
                            RTCFormat::FLOAT4,
                            16,
                            1,
                        ) as *mut f32;
                        if vb.is_null() {
                            rtcReleaseGeometry(geom);
                            return Err(this.error_text("geometry buffer allocation failed"));
                        }
                        let vs = std::slice::from_raw_parts_mut(vb, 4);
                        vs.copy_from_slice(&[center.x, center.y, center.z, *radius]);
                        geom
                    }
                };
                rtcCommitGeometry(geom);
                rtcAttachGeometryByID(scene, geom, id as u32);
                // The scene holds its own reference.
                rtcReleaseGeometry(geom);
            }
            rtcCommitScene(scene);
            let code = rtcGetDeviceError(device);
            if code != RTCError::NONE {
                return Err(this.error_text(&format!("scene build failed ({code:?})")));
            }
            if let Ok(e) = this._errors.lock() {
                if !e.is_empty() {
                    return Err(format!("Embree: {}", e.join("; ")));
                }
            }
            Ok(this)
        }
    }

    fn error_text(&self, what: &str) -> String {
        let extra = self
            ._errors
            .lock()
            .map(|e| e.join("; "))
            .unwrap_or_default();
        format!("Embree: {what} {extra}").trim_end().to_string()
    }

    fn context() -> RTCIntersectContext {
        // What the C inline rtcInitIntersectContext does: incoherent rays, no filter, no instance.
        RTCIntersectContext {
            flags: RTCIntersectContextFlags(0),
            filter: None,
            instID: [u32::MAX],
        }
    }

    fn ray(o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> RTCRay {
        RTCRay {
            org_x: o.x,
            org_y: o.y,
            org_z: o.z,
            tnear: tmin,
            dir_x: d.x,
            dir_y: d.y,
            dir_z: d.z,
            time: 0.0,
            tfar: tmax,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// Nearest hit with t in [tmin, tmax].
    pub(crate) fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<RawHit> {
        let mut ctx = Self::context();
        let mut rh = RTCRayHit {
            ray: Self::ray(o, d, tmin, tmax),
            hit: RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: u32::MAX,
                geomID: u32::MAX,
                instID: [u32::MAX],
            },
        };
        // SAFETY: the scene is committed; ctx and rh are valid, properly aligned locals.
        unsafe { rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        (rh.hit.geomID != u32::MAX).then_some(RawHit {
            geom: rh.hit.geomID,
            prim: rh.hit.primID,
            t: rh.ray.tfar,
            u: rh.hit.u,
            v: rh.hit.v,
        })
    }

    /// Whether anything is hit with t in [tmin, tmax].
    pub(crate) fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        let mut ctx = Self::context();
        let mut r = Self::ray(o, d, tmin, tmax);
        // SAFETY: as in `intersect`.
        unsafe { rtcOccluded1(self.scene, &mut ctx, &mut r) };
        // Embree sets tfar to −∞ when the ray is occluded.
        r.tfar == f32::NEG_INFINITY
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: handles created in `build`, released exactly once; the scene before its device.
        unsafe {
            if !self.scene.is_null() {
                rtcReleaseScene(self.scene);
            }
            rtcReleaseDevice(self.device);
        }
    }
}

/// Sets flush-to-zero and denormals-are-zero for the calling thread (Embree's recommendation for
/// performance, "Embree API: Performance Recommendations").
pub(crate) fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    #[allow(deprecated)]
    // SAFETY: only sets the FTZ (bit 15) and DAZ (bit 6) flags of this thread's MXCSR.
    unsafe {
        use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
        _mm_setcsr(_mm_getcsr() | 0x8040);
    }
}
