//! The `cpu` suite's Embree twin: the primary-ray scene's mesh and camera rays
//! traced by Intel Embree 3 (Debian's `libembree3-3`, loaded at run time, so
//! the bench builds and runs without it), on as many threads as the CPU
//! backend uses, one ray at a time (`rtcIntersect1`) and in 4×4-pixel packets
//! of 16 (`rtcIntersect16`). Each writes the picture the Rust primary-ray
//! programs write (barycentric colours through `triangle_device`'s own
//! functions), so the suite checks that Embree and raykit found the same hits.

use std::ffi::{c_char, c_void};
use std::sync::atomic::{AtomicUsize, Ordering};

use raykit::glam::{UVec2, Vec2, Vec3};
use triangle_device::{barycentric_color, camera_ray, make_color, Params};

/// The side of the square tiles of pixels the threads claim.
const TILE: u32 = 16;

/// The library's file name, or `RAYKIT_EMBREE_LIB`'s path.
const LIBRARY: &str = "libembree3.so.3";

const RTC_GEOMETRY_TYPE_TRIANGLE: u32 = 0;
const RTC_BUFFER_TYPE_INDEX: u32 = 0;
const RTC_BUFFER_TYPE_VERTEX: u32 = 1;
const RTC_FORMAT_UINT3: u32 = 0x5003;
const RTC_FORMAT_FLOAT3: u32 = 0x9003;
const RTC_BUILD_QUALITY_HIGH: u32 = 2;
const RTC_INVALID_GEOMETRY_ID: u32 = u32::MAX;
const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: u32 = 0;
const RTC_INTERSECT_CONTEXT_FLAG_COHERENT: u32 = 1;

/// `RTCIntersectContext` of Embree 3.13 as Debian builds it
/// (`RTC_MAX_INSTANCE_LEVEL_COUNT` 1, `RTC_MIN_WIDTH` 0).
#[repr(C)]
struct IntersectContext {
    flags: u32,
    filter: *const c_void,
    inst_id: [u32; 1],
}

/// `RTCRayHit`: `RTCRay` and `RTCHit`, each 16-byte aligned.
#[repr(C, align(16))]
#[derive(Clone, Copy, Default)]
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
    inst_id: [u32; 1],
}

/// `RTCRayHit16`: the same fields, sixteen of each, 64-byte aligned.
#[repr(C, align(64))]
struct RayHit16 {
    org: [[f32; 16]; 3],
    tnear: [f32; 16],
    dir: [[f32; 16]; 3],
    time: [f32; 16],
    tfar: [f32; 16],
    mask: [u32; 16],
    id: [u32; 16],
    flags: [u32; 16],
    ng: [[f32; 16]; 3],
    u: [f32; 16],
    v: [f32; 16],
    prim_id: [u32; 16],
    geom_id: [u32; 16],
    inst_id: [[u32; 16]; 1],
}

/// `valid` masks of `rtcIntersect16`, 64-byte aligned.
#[repr(C, align(64))]
struct Valid16([i32; 16]);

type Handle = *mut c_void;

/// The entry points the twin calls.
struct Api {
    new_device: unsafe extern "C" fn(*const c_char) -> Handle,
    release_device: unsafe extern "C" fn(Handle),
    new_scene: unsafe extern "C" fn(Handle) -> Handle,
    release_scene: unsafe extern "C" fn(Handle),
    set_scene_build_quality: unsafe extern "C" fn(Handle, u32),
    new_geometry: unsafe extern "C" fn(Handle, u32) -> Handle,
    set_new_geometry_buffer: unsafe extern "C" fn(Handle, u32, u32, u32, usize, usize) -> *mut c_void,
    commit_geometry: unsafe extern "C" fn(Handle),
    attach_geometry: unsafe extern "C" fn(Handle, Handle) -> u32,
    release_geometry: unsafe extern "C" fn(Handle),
    commit_scene: unsafe extern "C" fn(Handle),
    intersect1: unsafe extern "C" fn(Handle, *mut IntersectContext, *mut RayHit),
    intersect16: unsafe extern "C" fn(*const i32, Handle, *mut IntersectContext, *mut RayHit16),
    _library: libloading::Library,
}

impl Api {
    /// Embree, loaded once and never unloaded: its thread pool's threads outlive
    /// every scene, and unloading the library under them crashes the process at exit.
    fn get() -> anyhow::Result<&'static Api> {
        static API: std::sync::OnceLock<Result<Api, String>> = std::sync::OnceLock::new();
        API.get_or_init(|| Api::load().map_err(|e| e.to_string())).as_ref().map_err(|e| anyhow::anyhow!("{e}"))
    }

    /// Loads Embree, or says how to install it.
    fn load() -> anyhow::Result<Api> {
        let path = std::env::var("RAYKIT_EMBREE_LIB").unwrap_or_else(|_| LIBRARY.to_owned());
        // SAFETY: loading Embree runs its initialisers, which have no preconditions.
        let library = unsafe { libloading::Library::new(&path) }.map_err(|e| {
            anyhow::anyhow!(
                "Embree ({path}) could not be loaded: {e}; install it with `apt-get install libembree3-3` \
                 (`cargo xtask bench cpu` does) or name the library in RAYKIT_EMBREE_LIB"
            )
        })?;
        macro_rules! symbol {
            ($name:literal) => {
                // SAFETY: the symbol is Embree 3's function of that name, whose C signature
                // the field's type spells; the library stays loaded in `_library`.
                *unsafe { library.get(concat!($name, "\0").as_bytes()) }
                    .map_err(|e| anyhow::anyhow!("Embree has no {}: {e}", $name))?
            };
        }
        Ok(Api {
            new_device: symbol!("rtcNewDevice"),
            release_device: symbol!("rtcReleaseDevice"),
            new_scene: symbol!("rtcNewScene"),
            release_scene: symbol!("rtcReleaseScene"),
            set_scene_build_quality: symbol!("rtcSetSceneBuildQuality"),
            new_geometry: symbol!("rtcNewGeometry"),
            set_new_geometry_buffer: symbol!("rtcSetNewGeometryBuffer"),
            commit_geometry: symbol!("rtcCommitGeometry"),
            attach_geometry: symbol!("rtcAttachGeometry"),
            release_geometry: symbol!("rtcReleaseGeometry"),
            commit_scene: symbol!("rtcCommitScene"),
            intersect1: symbol!("rtcIntersect1"),
            intersect16: symbol!("rtcIntersect16"),
            _library: library,
        })
    }
}

/// A committed Embree scene of one triangle mesh.
pub struct Scene {
    api: &'static Api,
    device: Handle,
    scene: Handle,
}

// SAFETY: Embree's committed scenes may be traversed from any number of threads at once.
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: both handles came from this API and are released once.
        unsafe {
            (self.api.release_scene)(self.scene);
            (self.api.release_device)(self.device);
        }
    }
}

impl Scene {
    /// Embree's scene of the mesh (`vertices`, three `indices` per triangle),
    /// built at high quality for tracing.
    pub fn new(vertices: &[Vec3], indices: &[u32]) -> anyhow::Result<Scene> {
        let api = Api::get()?;
        // SAFETY: the calls follow Embree's API: a device, a scene on it, a geometry whose
        // buffers Embree allocates with the sizes given and which are filled before the commit.
        unsafe {
            let device = (api.new_device)(std::ptr::null());
            anyhow::ensure!(!device.is_null(), "rtcNewDevice failed");
            let scene = (api.new_scene)(device);
            (api.set_scene_build_quality)(scene, RTC_BUILD_QUALITY_HIGH);
            let geometry = (api.new_geometry)(device, RTC_GEOMETRY_TYPE_TRIANGLE);
            let v = (api.set_new_geometry_buffer)(
                geometry,
                RTC_BUFFER_TYPE_VERTEX,
                0,
                RTC_FORMAT_FLOAT3,
                12,
                vertices.len(),
            );
            let i = (api.set_new_geometry_buffer)(
                geometry,
                RTC_BUFFER_TYPE_INDEX,
                0,
                RTC_FORMAT_UINT3,
                12,
                indices.len() / 3,
            );
            anyhow::ensure!(!v.is_null() && !i.is_null(), "rtcSetNewGeometryBuffer failed");
            std::ptr::copy_nonoverlapping(vertices.as_ptr().cast::<f32>(), v.cast::<f32>(), vertices.len() * 3);
            std::ptr::copy_nonoverlapping(indices.as_ptr(), i.cast::<u32>(), indices.len() / 3 * 3);
            (api.commit_geometry)(geometry);
            (api.attach_geometry)(scene, geometry);
            (api.release_geometry)(geometry);
            (api.commit_scene)(scene);
            Ok(Scene { api, device, scene })
        }
    }

    /// Traces the camera rays of `params` over a `width × height` picture on
    /// `threads` threads, in packets of 16 (`rtcIntersect16`, 4×4 pixels) or
    /// one ray at a time, and writes the primary-ray programs' colours
    /// (RGBA8) into `image`.
    pub fn trace(
        &self,
        params: &Params,
        (width, height): (u32, u32),
        threads: usize,
        packets: bool,
        image: &mut [u32],
    ) {
        let dims = UVec2::new(width, height);
        // Tiles of 16×16 pixels, each 16 packets of 4×4: few atomic claims, and no
        // cache line of the image written by two threads.
        let tiles_x = width.div_ceil(TILE);
        let tiles = (tiles_x * height.div_ceil(TILE)) as usize;
        let next = AtomicUsize::new(0);
        let image_address = image.as_mut_ptr() as usize;
        let miss = make_color(crate::trace::PRIMARY_BACKGROUND);
        let work = || {
            let mut context = IntersectContext {
                flags: if packets {
                    RTC_INTERSECT_CONTEXT_FLAG_COHERENT
                } else {
                    RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
                },
                filter: std::ptr::null(),
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            };
            let colour =
                |hit: bool, u: f32, v: f32| if hit { make_color(barycentric_color(Vec2::new(u, v))) } else { miss };
            let write = |x: u32, y: u32, value: u32| {
                // SAFETY: each pixel belongs to one tile, and each tile to one thread.
                unsafe { *(image_address as *mut u32).add((y * width + x) as usize) = value };
            };
            // SAFETY: zeroed is a valid `RTCRayHit16` (plain numbers).
            let mut rays: Box<RayHit16> = unsafe { Box::new(std::mem::zeroed()) };
            loop {
                let tile = next.fetch_add(1, Ordering::Relaxed);
                if tile >= tiles {
                    break;
                }
                let (tx, ty) = ((tile as u32 % tiles_x) * TILE, (tile as u32 / tiles_x) * TILE);
                for block in 0..(TILE / 4) * (TILE / 4) {
                    let (x0, y0) = (tx + (block % (TILE / 4)) * 4, ty + (block / (TILE / 4)) * 4);
                    let pixels = (0..16u32).map(|k| (x0 + k % 4, y0 + k / 4));
                    if packets {
                        // Lanes outside the picture are marked invalid.
                        let mut valid = Valid16([0; 16]);
                        for (k, (x, y)) in pixels.clone().enumerate() {
                            if x >= width || y >= height {
                                continue;
                            }
                            let (o, d) = camera_ray(UVec2::new(x, y), dims, params);
                            for axis in 0..3 {
                                (rays.org[axis][k], rays.dir[axis][k]) = (o[axis], d[axis]);
                            }
                            (rays.tnear[k], rays.tfar[k], rays.mask[k]) = (0.0, 1e16, u32::MAX);
                            rays.geom_id[k] = RTC_INVALID_GEOMETRY_ID;
                            valid.0[k] = -1;
                        }
                        // SAFETY: the packet, mask and context are valid and aligned as Embree requires.
                        unsafe { (self.api.intersect16)(valid.0.as_ptr(), self.scene, &mut context, &mut *rays) };
                        for (k, (x, y)) in pixels.enumerate() {
                            if valid.0[k] != 0 {
                                write(x, y, colour(rays.geom_id[k] != RTC_INVALID_GEOMETRY_ID, rays.u[k], rays.v[k]));
                            }
                        }
                    } else {
                        for (x, y) in pixels.filter(|&(x, y)| x < width && y < height) {
                            let (o, d) = camera_ray(UVec2::new(x, y), dims, params);
                            let mut ray = RayHit {
                                org: o.to_array(),
                                dir: d.to_array(),
                                tfar: 1e16,
                                mask: u32::MAX,
                                geom_id: RTC_INVALID_GEOMETRY_ID,
                                ..RayHit::default()
                            };
                            // SAFETY: the ray and context are valid and aligned as Embree requires.
                            unsafe { (self.api.intersect1)(self.scene, &mut context, &mut ray) };
                            write(x, y, colour(ray.geom_id != RTC_INVALID_GEOMETRY_ID, ray.u, ray.v));
                        }
                    }
                }
            }
        };
        std::thread::scope(|scope| {
            for _ in 0..threads.max(1) {
                scope.spawn(work);
            }
        });
    }
}
