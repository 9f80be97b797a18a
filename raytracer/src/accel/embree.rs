//! Embree 3 (Intel's ray-casting kernels), for the benchmark only: the
//! yardstick `hybrid-rt bench --embree` measures this project's hierarchy
//! against, on the same triangles and the same rays.
//!
//! Compiled with the `embree` cargo feature alone, which links the system's
//! `libembree3` (Debian's `libembree-dev`, 3.13). The renderer never uses it.
//! A hand-written binding of the few functions the benchmark calls, with
//! the structures laid out as `embree3/rtcore_*.h` (3.13,
//! `RTC_MAX_INSTANCE_LEVEL_COUNT` 1, `RTC_MIN_WIDTH` 0) declares them.

use std::ffi::{c_char, c_void, CStr};

use crate::geometry::Vec3;

type RtcDevice = *mut c_void;
type RtcScene = *mut c_void;
type RtcGeometry = *mut c_void;

/// `RTC_INVALID_GEOMETRY_ID`: the `geom_id` of a ray that hit nothing.
pub const INVALID_ID: u32 = u32::MAX;

const GEOMETRY_TYPE_TRIANGLE: u32 = 0;
const BUFFER_TYPE_INDEX: u32 = 0;
const BUFFER_TYPE_VERTEX: u32 = 1;
const FORMAT_UINT3: u32 = 0x5003;
const FORMAT_FLOAT3: u32 = 0x9003;
const CONTEXT_FLAG_INCOHERENT: u32 = 0;
const CONTEXT_FLAG_COHERENT: u32 = 1;

/// `struct RTCRay`.
#[repr(C, align(16))]
#[derive(Debug, Clone, Copy, Default)]
pub struct RtcRay {
    pub org: [f32; 3],
    pub tnear: f32,
    pub dir: [f32; 3],
    pub time: f32,
    /// The end of the segment; an occluded query sets it to `-inf`, a hit
    /// to the hit's distance.
    pub tfar: f32,
    pub mask: u32,
    pub id: u32,
    pub flags: u32,
}

/// `struct RTCHit`.
#[repr(C, align(16))]
#[derive(Debug, Clone, Copy, Default)]
pub struct RtcHit {
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
    pub prim_id: u32,
    pub geom_id: u32,
    pub inst_id: [u32; 1],
}

/// `struct RTCRayHit`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct RtcRayHit {
    pub ray: RtcRay,
    pub hit: RtcHit,
}

/// `struct RTCIntersectContext`.
#[repr(C)]
struct Context {
    flags: u32,
    filter: *const c_void,
    inst_id: [u32; 1],
}

impl Context {
    fn new(flags: u32) -> Self {
        Context {
            flags,
            filter: std::ptr::null(),
            inst_id: [INVALID_ID],
        }
    }
}

#[link(name = "embree3")]
extern "C" {
    fn rtcNewDevice(config: *const c_char) -> RtcDevice;
    fn rtcReleaseDevice(device: RtcDevice);
    fn rtcGetDeviceError(device: RtcDevice) -> u32;
    fn rtcNewScene(device: RtcDevice) -> RtcScene;
    fn rtcReleaseScene(scene: RtcScene);
    fn rtcNewGeometry(device: RtcDevice, kind: u32) -> RtcGeometry;
    fn rtcReleaseGeometry(geometry: RtcGeometry);
    fn rtcSetNewGeometryBuffer(
        geometry: RtcGeometry,
        kind: u32,
        slot: u32,
        format: u32,
        byte_stride: usize,
        count: usize,
    ) -> *mut c_void;
    fn rtcCommitGeometry(geometry: RtcGeometry);
    fn rtcAttachGeometry(scene: RtcScene, geometry: RtcGeometry) -> u32;
    fn rtcCommitScene(scene: RtcScene);
    fn rtcIntersect1(scene: RtcScene, context: *mut Context, rayhit: *mut RtcRayHit);
    fn rtcIntersect1M(
        scene: RtcScene,
        context: *mut Context,
        rayhit: *mut RtcRayHit,
        m: u32,
        byte_stride: usize,
    );
    fn rtcOccluded1(scene: RtcScene, context: *mut Context, ray: *mut RtcRay);
    fn rtcOccluded1M(
        scene: RtcScene,
        context: *mut Context,
        ray: *mut RtcRay,
        m: u32,
        byte_stride: usize,
    );
}

/// An Embree device (one thread) and a committed scene of one triangle
/// mesh. Triangle `i` of the mesh is `prim_id` `i`.
pub struct Embree {
    device: RtcDevice,
    scene: RtcScene,
}

impl Embree {
    /// Builds the scene over `triangles` (single precision, as Embree
    /// stores them). The build runs on the calling thread.
    pub fn new(triangles: &[[Vec3; 3]]) -> Result<Embree, String> {
        let n = triangles.len();
        if n == 0 || n > (u32::MAX / 3) as usize {
            return Err(format!("Embree: cannot build a mesh of {n} triangles"));
        }
        let config: &CStr = c"threads=1";
        // SAFETY: a valid C string; every handle is checked before use and
        // released in `drop` (the scene holds the geometry it attaches).
        unsafe {
            let device = rtcNewDevice(config.as_ptr());
            if device.is_null() {
                return Err("Embree: rtcNewDevice failed".into());
            }
            let scene = rtcNewScene(device);
            let me = Embree { device, scene };
            let geometry = rtcNewGeometry(device, GEOMETRY_TYPE_TRIANGLE);
            if scene.is_null() || geometry.is_null() {
                return Err(me.error("rtcNewScene/rtcNewGeometry"));
            }
            // Embree may read 16 bytes from the last vertex: it pads the
            // buffers it allocates itself.
            let v =
                rtcSetNewGeometryBuffer(geometry, BUFFER_TYPE_VERTEX, 0, FORMAT_FLOAT3, 12, 3 * n)
                    as *mut f32;
            let ix = rtcSetNewGeometryBuffer(geometry, BUFFER_TYPE_INDEX, 0, FORMAT_UINT3, 12, n)
                as *mut u32;
            if v.is_null() || ix.is_null() {
                rtcReleaseGeometry(geometry);
                return Err(me.error("rtcSetNewGeometryBuffer"));
            }
            let v = std::slice::from_raw_parts_mut(v, 9 * n);
            let ix = std::slice::from_raw_parts_mut(ix, 3 * n);
            for (i, t) in triangles.iter().enumerate() {
                for (k, p) in t.iter().enumerate() {
                    for a in 0..3 {
                        v[9 * i + 3 * k + a] = p[a] as f32;
                    }
                    ix[3 * i + k] = (3 * i + k) as u32;
                }
            }
            rtcCommitGeometry(geometry);
            rtcAttachGeometry(scene, geometry);
            rtcReleaseGeometry(geometry);
            rtcCommitScene(scene);
            match rtcGetDeviceError(device) {
                0 => Ok(me),
                _ => Err(me.error("rtcCommitScene")),
            }
        }
    }

    fn error(&self, what: &str) -> String {
        // SAFETY: `device` is a live device.
        let code = unsafe { rtcGetDeviceError(self.device) };
        format!("Embree: {what} failed (error {code})")
    }

    /// Nearest hits, one `rtcIntersect1` per ray.
    pub fn intersect1(&self, rays: &mut [RtcRayHit]) {
        let mut ctx = Context::new(CONTEXT_FLAG_INCOHERENT);
        for r in rays {
            // SAFETY: live scene, valid context and ray.
            unsafe { rtcIntersect1(self.scene, &mut ctx, r) };
        }
    }

    /// Nearest hits, the rays as coherent streams (`rtcIntersect1M`) of
    /// `stream` rays.
    pub fn intersect_streams(&self, rays: &mut [RtcRayHit], stream: usize) {
        let mut ctx = Context::new(CONTEXT_FLAG_COHERENT);
        for s in rays.chunks_mut(stream.max(1)) {
            // SAFETY: live scene, valid context, `s.len()` rays in a row.
            unsafe {
                rtcIntersect1M(
                    self.scene,
                    &mut ctx,
                    s.as_mut_ptr(),
                    s.len() as u32,
                    std::mem::size_of::<RtcRayHit>(),
                )
            };
        }
    }

    /// Any hits, one `rtcOccluded1` per ray (`tfar` becomes `-inf` where
    /// the ray is blocked).
    pub fn occluded1(&self, rays: &mut [RtcRay]) {
        let mut ctx = Context::new(CONTEXT_FLAG_INCOHERENT);
        for r in rays {
            // SAFETY: live scene, valid context and ray.
            unsafe { rtcOccluded1(self.scene, &mut ctx, r) };
        }
    }

    /// Any hits, as coherent streams (`rtcOccluded1M`) of `stream` rays.
    pub fn occluded_streams(&self, rays: &mut [RtcRay], stream: usize) {
        let mut ctx = Context::new(CONTEXT_FLAG_COHERENT);
        for s in rays.chunks_mut(stream.max(1)) {
            // SAFETY: live scene, valid context, `s.len()` rays in a row.
            unsafe {
                rtcOccluded1M(
                    self.scene,
                    &mut ctx,
                    s.as_mut_ptr(),
                    s.len() as u32,
                    std::mem::size_of::<RtcRay>(),
                )
            };
        }
    }
}

impl Drop for Embree {
    fn drop(&mut self) {
        // SAFETY: handles created in `new`, released once.
        unsafe {
            if !self.scene.is_null() {
                rtcReleaseScene(self.scene);
            }
            rtcReleaseDevice(self.device);
        }
    }
}

/// A ray for Embree: `org` and `dir` rounded to single precision, the
/// segment `(tnear, tfar)`.
pub fn ray(org: Vec3, dir: Vec3, tnear: f64, tfar: f64) -> RtcRay {
    RtcRay {
        org: org.to_array().map(|x| x as f32),
        tnear: tnear as f32,
        dir: dir.to_array().map(|x| x as f32),
        time: 0.0,
        tfar: tfar as f32,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}
