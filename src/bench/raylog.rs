//! Ray recording for the Embree ceiling of `groove bench --rays`: while recording is on, every
//! ray the renderer traces through [`Scene::intersect`](crate::scene::Scene::intersect) or
//! [`Scene::occluded`](crate::scene::Scene::occluded) is appended to a per-thread buffer, so the
//! same rays (the renderer's own distribution) can later be traced again with no shading.
//!
//! Off (the normal case) it costs one relaxed atomic load per ray. The render loop moves each
//! thread's buffer into a shared list after every image block ([`flush`]).

use crate::geometry::Ray;
use glam::Vec3;
use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// One recorded ray: `shadow` rays only ask for occlusion.
#[derive(Clone, Copy, Debug)]
pub struct LoggedRay {
    pub o: Vec3,
    pub d: Vec3,
    pub tmin: f32,
    pub tmax: f32,
    pub shadow: bool,
}

impl LoggedRay {
    pub fn ray(&self) -> Ray {
        Ray {
            o: self.o,
            d: self.d,
            tmin: self.tmin,
            tmax: self.tmax,
        }
    }
}

static RECORDING: AtomicBool = AtomicBool::new(false);
/// Rays kept so far (all threads); recording stops adding at [`Recorder`]'s cap.
static KEPT: AtomicUsize = AtomicUsize::new(0);
static CAP: AtomicUsize = AtomicUsize::new(0);
static SHARED: Mutex<Vec<Vec<LoggedRay>>> = Mutex::new(Vec::new());

thread_local! {
    static LOCAL: RefCell<Vec<LoggedRay>> = const { RefCell::new(Vec::new()) };
}

/// Record `ray` if recording is on (called by the scene for every traced ray).
#[inline]
pub fn record(ray: &Ray, shadow: bool) {
    if RECORDING.load(Ordering::Relaxed) {
        record_slow(ray, shadow);
    }
}

#[cold]
fn record_slow(ray: &Ray, shadow: bool) {
    if KEPT.fetch_add(1, Ordering::Relaxed) >= CAP.load(Ordering::Relaxed) {
        return;
    }
    LOCAL.with(|l| {
        l.borrow_mut().push(LoggedRay {
            o: ray.o,
            d: ray.d,
            tmin: ray.tmin,
            tmax: ray.tmax,
            shadow,
        })
    });
}

/// Move this thread's recorded rays to the shared list (the render loop calls it per block).
pub fn flush() {
    if !RECORDING.load(Ordering::Relaxed) {
        return;
    }
    let rays = LOCAL.with(|l| std::mem::take(&mut *l.borrow_mut()));
    if !rays.is_empty() {
        SHARED.lock().unwrap_or_else(|e| e.into_inner()).push(rays);
    }
}

/// Recording session: on while it lives, one at a time (a global switch; `groove bench` is its
/// only user and records one render at a time).
pub struct Recorder {
    _private: (),
}

impl Recorder {
    /// Start recording at most `cap` rays.
    pub fn start(cap: usize) -> Recorder {
        SHARED.lock().unwrap_or_else(|e| e.into_inner()).clear();
        KEPT.store(0, Ordering::Relaxed);
        CAP.store(cap, Ordering::Relaxed);
        RECORDING.store(true, Ordering::SeqCst);
        Recorder { _private: () }
    }

    /// Stop and return the recorded rays (per block, in no particular order) and how many rays
    /// were traced in all (more than recorded when the cap was reached).
    pub fn finish(self) -> (Vec<Vec<LoggedRay>>, usize) {
        flush();
        RECORDING.store(false, Ordering::SeqCst);
        let traced = KEPT.load(Ordering::Relaxed);
        let rays = std::mem::take(&mut *SHARED.lock().unwrap_or_else(|e| e.into_inner()));
        (rays, traced)
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        RECORDING.store(false, Ordering::SeqCst);
    }
}
