// WGSL twin of the triangle programs (../device/src/lib.rs): the same launch
// params, record and bindless buffer table, in raykit's WGSL conventions
// (raykit-wgsl's prelude.wgsl).
enable wgpu_ray_tracing_pipeline;
enable wgpu_binding_array;

struct Words { words: array<u32> }
@group(0) @binding(0) var<storage, read_write> buffers: binding_array<Words>;

struct Vec2u { x: u32, y: u32 }
struct Vec3f { x: f32, y: f32, z: f32 }
fn vec3f(v: Vec3f) -> vec3<f32> { return vec3<f32>(v.x, v.y, v.z); }

// triangle_device::Params (push constants).
struct Params {
    image: u32,
    size: Vec2u,
    cam_eye: Vec3f,
    cam_u: Vec3f,
    cam_v: Vec3f,
    cam_w: Vec3f,
    pad: u32,
    handle: vec2<u32>,
}
var<immediate> params: Params;

// Params member 7, `handle`.
@group(2) @binding(7) var scene: acceleration_structure;

// triangle_device::MissData.
struct MissData { bg_color: Vec3f }
@group(3) @binding(0) var<storage, read> miss_data: MissData;
@group(3) @binding(1) var<storage, read> barycentrics: vec2<f32>;

var<ray_payload> color: vec3<f32>;
var<incoming_ray_payload> incoming_color: vec3<f32>;

fn to_srgb(c: f32) -> f32 {
    if c <= 0.0031308 { return 12.92 * c; }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}
fn q(v: f32) -> u32 { return u32(to_srgb(clamp(v, 0.0, 1.0)) * 255.0 + 0.5); }

@ray_generation
fn rg(@builtin(ray_invocation_id) id: vec3<u32>, @builtin(num_ray_invocations) dims: vec3<u32>) {
    let d = vec2<f32>(2.0 * (f32(id.x) + 0.5) / f32(dims.x) - 1.0, 1.0 - 2.0 * (f32(id.y) + 0.5) / f32(dims.y));
    let dir = normalize(d.x * vec3f(params.cam_u) + d.y * vec3f(params.cam_v) + vec3f(params.cam_w));
    color = vec3<f32>(0.0);
    traceRay(scene, RayDesc(0u, 0xffu, 0.0, 1e16, vec3f(params.cam_eye), dir), &color);
    let pixel = id.x + dims.x * id.y;
    buffers[params.image & 4095u].words[pixel] = q(color.x) | (q(color.y) << 8u) | (q(color.z) << 16u) | (255u << 24u);
}

@miss @incoming_payload(incoming_color)
fn ms() {
    incoming_color = vec3f(miss_data.bg_color);
}

@closest_hit @incoming_payload(incoming_color)
fn ch() {
    let b = barycentrics;
    incoming_color = vec3<f32>(1.0 - b.x - b.y, b.x, b.y);
}
