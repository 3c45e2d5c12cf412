//! Embree (Intel's ray tracing kernels) as a peer, through its C library
//! loaded at run time: `CELLBIH_EMBREE` names the library file (Embree 4,
//! `libembree4.so.4`, or Embree 3, `libembree3.so.3`, told apart by the
//! name); without it the bench tries Embree 4 in `target/embree/` (where
//! `scripts/get-embree` unpacks the `embreex` wheel's), then those two
//! names on the loader's path and, finding none, leaves Embree out. One device of one thread
//! (`threads=1`); a scene of one triangle mesh, each triangle its own
//! three vertices, built at the low or medium quality
//! (`rtcSetSceneBuildQuality`); rays traced one at a time
//! (`rtcIntersect1`).

use std::ffi::{CStr, CString, c_char, c_void};
use std::ptr::null_mut;

use cellbih::bih::Ray;
use cellbih::scene::Scene;

type Device = *mut c_void;
type Handle = *mut c_void;

/// `struct RTCRayHit` (rtcore_ray.h): the ray, then the hit, each 16-byte
/// aligned; the hit's tail has room for an instance array's ids.
#[repr(C, align(16))]
struct RayHit {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: u32,
    id: u32,
    flags: u32,
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: u32,
    geom_id: u32,
    inst_id: [u32; 5],
}

/// Embree 3's `struct RTCIntersectContext` as `rtcInitIntersectContext`
/// sets it.
#[repr(C)]
struct Context3 {
    flags: u32,
    filter: *mut c_void,
    inst_id: [u32; 1],
}

const INVALID_ID: u32 = u32::MAX;
const GEOMETRY_TYPE_TRIANGLE: u32 = 0;
const BUFFER_TYPE_INDEX: u32 = 0;
const BUFFER_TYPE_VERTEX: u32 = 1;
const FORMAT_UINT3: u32 = 0x5003;
const FORMAT_FLOAT3: u32 = 0x9003;

/// Embree's build quality (`enum RTCBuildQuality`).
#[derive(Clone, Copy)]
pub enum Quality {
    Low = 0,
    Medium = 1,
}

/// The entry points used, looked up in the loaded library.
struct Api {
    new_device: unsafe extern "C" fn(*const c_char) -> Device,
    device_error: unsafe extern "C" fn(Device) -> u32,
    new_scene: unsafe extern "C" fn(Device) -> Handle,
    scene_quality: unsafe extern "C" fn(Handle, u32),
    new_geometry: unsafe extern "C" fn(Device, u32) -> Handle,
    new_buffer: unsafe extern "C" fn(Handle, u32, u32, u32, usize, usize) -> *mut c_void,
    commit_geometry: unsafe extern "C" fn(Handle),
    attach: unsafe extern "C" fn(Handle, Handle) -> u32,
    release_geometry: unsafe extern "C" fn(Handle),
    commit_scene: unsafe extern "C" fn(Handle),
    release_scene: unsafe extern "C" fn(Handle),
    device_property: unsafe extern "C" fn(Device, u32) -> isize,
    /// Embree 4: (scene, ray, arguments or null).
    intersect4: Option<unsafe extern "C" fn(Handle, *mut RayHit, *mut c_void)>,
    /// Embree 3: (scene, context, ray).
    intersect3: Option<unsafe extern "C" fn(Handle, *mut Context3, *mut RayHit)>,
}

/// A loaded Embree and one device of one thread.
pub struct Embree {
    api: Api,
    device: Device,
    /// The library's file, as the bench prints it.
    pub name: String,
}

// SAFETY: an Embree device may be used from any thread (Embree's API is
// thread-safe for a device and its scenes); the bench uses it from one.
unsafe impl Send for Embree {}
unsafe impl Sync for Embree {}

/// A built scene.
pub struct Built<'a> {
    embree: &'a Embree,
    scene: Handle,
}

impl Embree {
    /// Embree from `CELLBIH_EMBREE`, `target/embree/` or the loader's
    /// path; `Err` says why not (the bench then goes on without it).
    pub fn load() -> Result<Embree, String> {
        let names = match std::env::var("CELLBIH_EMBREE") {
            Ok(path) => vec![path],
            Err(_) => (unpacked().into_iter())
                .chain(["libembree4.so.4".into(), "libembree3.so.3".into()])
                .collect(),
        };
        let mut why = Vec::new();
        for name in names {
            let c = CString::new(name.clone()).map_err(|e| e.to_string())?;
            // SAFETY: dlopen with a valid C string; a null result is checked.
            let lib = unsafe { libc::dlopen(c.as_ptr(), libc::RTLD_NOW | libc::RTLD_LOCAL) };
            if lib.is_null() {
                // SAFETY: dlerror returns a C string or null.
                let e = unsafe { libc::dlerror() };
                why.push(if e.is_null() {
                    name
                } else {
                    unsafe { CStr::from_ptr(e) }.to_string_lossy().into_owned()
                });
                continue;
            }
            let four = !name.contains("embree3");
            let api = unsafe { Api::from(lib, four) }?;
            let config = CString::new("threads=1,set_affinity=0").expect("no NUL");
            // SAFETY: the entry point has this signature in Embree 3 and 4.
            let device = unsafe { (api.new_device)(config.as_ptr()) };
            if device.is_null() {
                return Err(format!("{name}: rtcNewDevice failed"));
            }
            return Ok(Embree { api, device, name });
        }
        Err(why.join("; "))
    }

    /// The Embree version the library reports (`RTC_DEVICE_PROPERTY_VERSION`).
    pub fn version(&self) -> String {
        // SAFETY: a property query on a live device.
        let v = unsafe { (self.api.device_property)(self.device, 0) };
        format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100)
    }

    /// Builds `s` at `quality`: the mesh's buffers filled and the scene
    /// committed (what the bench times as Embree's build).
    pub fn build(&self, s: &Scene, quality: Quality) -> Built<'_> {
        let a = &self.api;
        let n = s.len();
        // SAFETY: Embree's documented calls in order; the buffers it
        // returns hold `n` items of the given format and are written
        // within them.
        unsafe {
            let scene = (a.new_scene)(self.device);
            (a.scene_quality)(scene, quality as u32);
            let geom = (a.new_geometry)(self.device, GEOMETRY_TYPE_TRIANGLE);
            let v =
                (a.new_buffer)(geom, BUFFER_TYPE_VERTEX, 0, FORMAT_FLOAT3, 12, 3 * n) as *mut f32;
            let i = (a.new_buffer)(geom, BUFFER_TYPE_INDEX, 0, FORMAT_UINT3, 12, n) as *mut u32;
            assert!(!v.is_null() && !i.is_null(), "Embree gave no buffer");
            let (v, i) = (
                std::slice::from_raw_parts_mut(v, 9 * n),
                std::slice::from_raw_parts_mut(i, 3 * n),
            );
            for (k, t) in s.triangles.iter().enumerate() {
                for c in 0..3 {
                    v[9 * k + 3 * c..9 * k + 3 * c + 3].copy_from_slice(&t.v[c].to_array());
                    i[3 * k + c] = (3 * k + c) as u32;
                }
            }
            (a.commit_geometry)(geom);
            (a.attach)(scene, geom);
            (a.release_geometry)(geom);
            (a.commit_scene)(scene);
            let e = (a.device_error)(self.device);
            assert_eq!(e, 0, "Embree error {e} building {}", s.name);
            Built {
                embree: self,
                scene,
            }
        }
    }
}

impl Built<'_> {
    /// The closest hit of `r` (triangle, t), in `f32` as Embree traces.
    pub fn closest(&self, r: &Ray) -> Option<(u32, f64)> {
        let (o, d) = (r.origin.as_vec3(), r.dir.as_vec3());
        let mut rh = RayHit {
            org: o.to_array(),
            tnear: r.tmin as f32,
            dir: d.to_array(),
            time: 0.0,
            tfar: r.tmax as f32,
            mask: u32::MAX,
            id: 0,
            flags: 0,
            ng: [0.0; 3],
            u: 0.0,
            v: 0.0,
            prim_id: INVALID_ID,
            geom_id: INVALID_ID,
            inst_id: [INVALID_ID; 5],
        };
        let a = &self.embree.api;
        // SAFETY: a committed scene and a ray laid out as RTCRayHit.
        unsafe {
            match (a.intersect4, a.intersect3) {
                (Some(f), _) => f(self.scene, &mut rh, null_mut()),
                (None, Some(f)) => {
                    let mut ctx = Context3 {
                        flags: 0,
                        filter: null_mut(),
                        inst_id: [INVALID_ID],
                    };
                    f(self.scene, &mut ctx, &mut rh)
                }
                (None, None) => unreachable!("one of the two is looked up"),
            }
        }
        (rh.geom_id != INVALID_ID).then_some((rh.prim_id, rh.tfar as f64))
    }
}

impl Drop for Built<'_> {
    fn drop(&mut self) {
        // SAFETY: the scene was made by this device and is released once.
        unsafe { (self.embree.api.release_scene)(self.scene) }
    }
}

impl Api {
    /// Looks every entry point up in `lib`.
    ///
    /// # Safety
    /// `lib` is a loaded Embree 4 (`four`) or Embree 3 library.
    // Each transmute's target is the type of the field it fills.
    #[allow(clippy::missing_transmute_annotations)]
    unsafe fn from(lib: *mut c_void, four: bool) -> Result<Api, String> {
        let sym = |name: &str| -> Result<*mut c_void, String> {
            let c = CString::new(name).expect("no NUL");
            // SAFETY: dlsym on a handle dlopen returned.
            let p = unsafe { libc::dlsym(lib, c.as_ptr()) };
            (!p.is_null())
                .then_some(p)
                .ok_or_else(|| format!("Embree has no {name}"))
        };
        // SAFETY (every transmute): the entry point's C signature is the
        // function pointer type it is given (rtcore_*.h).
        unsafe {
            use std::mem::transmute as f;
            Ok(Api {
                new_device: f(sym("rtcNewDevice")?),
                device_error: f(sym("rtcGetDeviceError")?),
                new_scene: f(sym("rtcNewScene")?),
                scene_quality: f(sym("rtcSetSceneBuildQuality")?),
                new_geometry: f(sym("rtcNewGeometry")?),
                new_buffer: f(sym("rtcSetNewGeometryBuffer")?),
                commit_geometry: f(sym("rtcCommitGeometry")?),
                attach: f(sym("rtcAttachGeometry")?),
                release_geometry: f(sym("rtcReleaseGeometry")?),
                commit_scene: f(sym("rtcCommitScene")?),
                release_scene: f(sym("rtcReleaseScene")?),
                device_property: f(sym("rtcGetDeviceProperty")?),
                intersect4: if four {
                    Some(f(sym("rtcIntersect1")?))
                } else {
                    None
                },
                intersect3: if four {
                    None
                } else {
                    Some(f(sym("rtcIntersect1")?))
                },
            })
        }
    }
}

/// The Embree 4 library `scripts/get-embree` unpacked into `target/embree/`,
/// if any.
fn unpacked() -> Option<String> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/embree");
    let mut found: Vec<_> = (std::fs::read_dir(dir).ok()?.flatten())
        .map(|e| e.path())
        .filter(|p| {
            let name = p
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into());
            name.starts_with("libembree4") && name.contains(".so")
        })
        .collect();
    found.sort();
    Some(found.first()?.to_string_lossy().into_owned())
}
