// WGSL twin of the path tracer's device programs (../device/src), in raykit's
// WGSL conventions (raykit-wgsl's prelude.wgsl): the same launch params, SBT
// records, payloads, ray types and bindless buffer table as the Rust programs.
// Entry points: rg, ms, ms_shadow, ch, ch_shadow.
enable wgpu_ray_tracing_pipeline;
enable wgpu_binding_array;
enable primitive_index;

struct Words { words: array<u32> }
@group(0) @binding(0) var<storage, read_write> buffers: binding_array<Words>;

struct Vec3f { x: f32, y: f32, z: f32 }
fn vec3f(v: Vec3f) -> vec3<f32> { return vec3<f32>(v.x, v.y, v.z); }

// path_tracer_device::Params (push constants).
struct Params {
    accum: u32,      // Buffer<Vec4>: radiance sum (xyz), rays (w)
    normals: u32,    // Buffer<Vec3>: per-triangle normal
    size: vec2<u32>,
    subframe: u32,
    samples: u32,
    max_depth: u32,
    row_offset: u32, // first image row of this launch (a band of a split launch)
    cam_eye: Vec3f,
    cam_u: Vec3f,
    cam_v: Vec3f,
    cam_w: Vec3f,
    handle: vec2<u32>,
}
var<immediate> params: Params;

// Params member 11, `handle`.
@group(2) @binding(11) var scene: acceleration_structure;

// The shader records: the raygen program's light (RaygenRecord), the radiance
// hit group's material (HitRecord).
struct Light { corner: Vec3f, v1: Vec3f, v2: Vec3f, emission: Vec3f }
@group(3) @binding(0) var<storage, read> light: Light;
struct HitRecord { emission: vec3<f32>, first_triangle: u32, albedo: vec3<f32>, pad: u32 }
@group(3) @binding(0) var<storage, read> material: HitRecord;

// The radiance ray's payload (math::HitInfo): t < 0 is a miss. naga 30 lets one
// entry point trace with one payload type only, so the shadow ray carries a
// HitInfo too, whose `t` is the visibility flag (1: the light is visible).
struct HitInfo { normal: vec3<f32>, t: f32, emission: vec3<f32>, albedo: vec3<f32> }
var<ray_payload> hit: HitInfo;
var<ray_payload> shadow: HitInfo;
var<incoming_ray_payload> hit_in: HitInfo;

const PI: f32 = 3.14159265358979323846;
const RAY_EPSILON: f32 = 0.01;
const ROULETTE_AFTER: u32 = 2u;
const ROULETTE_MAX_SURVIVAL: f32 = 0.95;

// Ray types: radiance (SBT offset 0, miss 0) and shadow (offset 1, miss 1), stride 2.
fn ray_type_mask(cull_mask: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32) -> u32 {
    return (cull_mask & 0xffu) | ((sbt_offset & 0xffu) << 8u) | ((sbt_stride & 0xffu) << 16u) | ((miss_index & 0xffu) << 24u);
}

fn tea4(val0: u32, val1: u32) -> u32 {
    var v0 = val0;
    var v1 = val1;
    var s0 = 0u;
    for (var n = 0u; n < 4u; n++) {
        s0 += 0x9e3779b9u;
        v0 += ((v1 << 4u) + 0xa341316cu) ^ (v1 + s0) ^ ((v1 >> 5u) + 0xc8013ea4u);
        v1 += ((v0 << 4u) + 0xad90777du) ^ (v0 + s0) ^ ((v0 >> 5u) + 0x7e95761eu);
    }
    return v0;
}

fn rnd(state: ptr<function, u32>) -> f32 {
    *state = 1664525u * *state + 1013904223u;
    return f32(*state & 0x00ffffffu) / 16777216.0;
}

fn cosine_sample_hemisphere(u1: f32, u2: f32) -> vec3<f32> {
    let r = sqrt(u1);
    let phi = 2.0 * PI * u2;
    let x = r * cos(phi);
    let y = r * sin(phi);
    return vec3<f32>(x, y, sqrt(max(0.0, 1.0 - x * x - y * y)));
}

fn onb_to_world(n: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    var b = vec3<f32>(0.0, -n.z, n.y);
    if abs(n.x) > abs(n.z) {
        b = vec3<f32>(-n.y, n.x, 0.0);
    }
    b = normalize(b);
    let t = cross(b, n);
    return p.x * t + p.y * b + p.z * n;
}

@ray_generation
fn rg(@builtin(ray_invocation_id) launch_id: vec3<u32>) {
    // The pixel in the whole image: this launch may render a band of its rows.
    let index = launch_id.xy + vec2<u32>(0u, params.row_offset);
    let dims = params.size;
    let pixel = index.x + dims.x * index.y;
    let light_v1 = vec3f(light.v1);
    let light_v2 = vec3f(light.v2);
    let light_normal = normalize(cross(light_v1, light_v2));
    let light_area = length(cross(light_v1, light_v2));
    var seed = tea4(pixel, params.subframe);
    var sum = vec3<f32>(0.0);
    var rays = 0u;
    for (var s = 0u; s < params.samples; s++) {
        // PathState::camera
        let jx = rnd(&seed);
        let jy = rnd(&seed);
        let dx = 2.0 * (f32(index.x) + jx) / f32(dims.x) - 1.0;
        let dy = 1.0 - 2.0 * (f32(index.y) + jy) / f32(dims.y);
        var origin = vec3f(params.cam_eye);
        var direction = normalize(dx * vec3f(params.cam_u) + dy * vec3f(params.cam_v) + vec3f(params.cam_w));
        var throughput = vec3<f32>(1.0);
        var radiance = vec3<f32>(0.0);
        var depth = 0u;
        var done = false;
        while !done {
            hit = HitInfo(vec3<f32>(0.0), -1.0, vec3<f32>(0.0), vec3<f32>(0.0));
            traceRay(scene, RayDesc(RAY_FLAG_NONE, ray_type_mask(0xffu, 0u, 2u, 0u), RAY_EPSILON, 1e16, origin, direction), &hit);
            rays++;
            // PathState::shade
            if hit.t < 0.0 {
                done = true;
                break;
            }
            let p = origin + hit.t * direction;
            let n = hit.normal;
            if depth == 0u {
                radiance += throughput * hit.emission;
            }
            let lu = rnd(&seed);
            let lv = rnd(&seed);
            let light_point = vec3f(light.corner) + lu * light_v1 + lv * light_v2;
            let to_light = light_point - p;
            let distance = length(to_light);
            let l = to_light / distance;
            let n_dot_l = dot(n, l);
            let ln_dot_l = -dot(light_normal, l);
            var contribution = vec3<f32>(0.0);
            if n_dot_l > 0.0 && ln_dot_l > 0.0 {
                let geometry = n_dot_l * ln_dot_l * light_area / (distance * distance);
                contribution = throughput * (hit.albedo * (1.0 / PI)) * vec3f(light.emission) * geometry;
            }
            let u1 = rnd(&seed);
            let u2 = rnd(&seed);
            let local = cosine_sample_hemisphere(u1, u2);
            origin = p;
            direction = onb_to_world(n, local);
            throughput *= hit.albedo;
            depth++;
            let survive = rnd(&seed);
            if depth >= params.max_depth {
                done = true;
            } else if depth > ROULETTE_AFTER {
                let q = min(max(throughput.x, max(throughput.y, throughput.z)), ROULETTE_MAX_SURVIVAL);
                if survive >= q {
                    done = true;
                } else {
                    throughput /= q;
                }
            }
            // The shadow ray of next-event estimation.
            if any(contribution != vec3<f32>(0.0)) {
                shadow.t = 0.0;
                let flags = RAY_FLAG_TERMINATE_ON_FIRST_HIT | RAY_FLAG_SKIP_CLOSEST_HIT_SHADER | RAY_FLAG_FORCE_OPAQUE;
                traceRay(scene, RayDesc(flags, ray_type_mask(0xffu, 1u, 2u, 1u), RAY_EPSILON, distance - RAY_EPSILON, p, l), &shadow);
                rays++;
                if shadow.t != 0.0 {
                    radiance += contribution;
                }
            }
        }
        sum += radiance;
    }
    let base = pixel * 4u;
    var previous = vec4<f32>(0.0);
    if params.subframe != 0u {
        previous = vec4<f32>(
            bitcast<f32>(buffers[params.accum & 4095u].words[base]),
            bitcast<f32>(buffers[params.accum & 4095u].words[base + 1u]),
            bitcast<f32>(buffers[params.accum & 4095u].words[base + 2u]),
            bitcast<f32>(buffers[params.accum & 4095u].words[base + 3u]),
        );
    }
    let total = previous + vec4<f32>(sum, f32(rays));
    buffers[params.accum & 4095u].words[base] = bitcast<u32>(total.x);
    buffers[params.accum & 4095u].words[base + 1u] = bitcast<u32>(total.y);
    buffers[params.accum & 4095u].words[base + 2u] = bitcast<u32>(total.z);
    buffers[params.accum & 4095u].words[base + 3u] = bitcast<u32>(total.w);
}

@miss @incoming_payload(hit_in)
fn ms() {
    hit_in.t = -1.0;
}

@miss @incoming_payload(hit_in)
fn ms_shadow() {
    hit_in.t = 1.0;
}

@closest_hit @incoming_payload(hit_in)
fn ch(@builtin(primitive_index) primitive: u32, @builtin(world_ray_direction) direction: vec3<f32>,
      @builtin(ray_t_current_max) t: f32) {
    let base = (material.first_triangle + primitive) * 3u;
    let n = vec3<f32>(
        bitcast<f32>(buffers[params.normals & 4095u].words[base]),
        bitcast<f32>(buffers[params.normals & 4095u].words[base + 1u]),
        bitcast<f32>(buffers[params.normals & 4095u].words[base + 2u]),
    );
    var normal = n;
    if dot(n, direction) > 0.0 {
        normal = -n;
    }
    hit_in.normal = normal;
    hit_in.t = t;
    hit_in.emission = material.emission;
    hit_in.albedo = material.albedo;
}

// The shadow ray type's hit group (never run: shadow rays skip closest-hit).
@closest_hit @incoming_payload(hit_in)
fn ch_shadow() {
    hit_in.t = 0.0;
}
