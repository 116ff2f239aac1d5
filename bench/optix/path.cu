// The path tracer of the `path` suite for OptiX: raykit's path-tracer-device
// (examples/path_tracer/device) line for line — the same random numbers (sutil's
// tea<4> seeds and LCG stream), the same camera jitter, next-event estimation,
// cosine-weighted bounces and Russian roulette, in the same order, so the same
// paths and the same mean radiance. The path loop runs in raygen; closest-hit
// only reports the hit.
#include <optix.h>

#include "shared.h"
#include "vec.h"

extern "C" {
__constant__ PathParams params;
}

#define PATH_PI 3.14159265358979323846f

// sutil's tea<4> (raykit_device::sampling::tea4).
static __forceinline__ __device__ unsigned int tea4(unsigned int val0, unsigned int val1) {
    unsigned int v0 = val0, v1 = val1, s0 = 0;
    for (unsigned int n = 0; n < 4; n++) {
        s0 += 0x9e3779b9u;
        v0 += ((v1 << 4) + 0xa341316cu) ^ (v1 + s0) ^ ((v1 >> 5) + 0xc8013ea4u);
        v1 += ((v0 << 4) + 0xad90777du) ^ (v0 + s0) ^ ((v0 >> 5) + 0x7e95761eu);
    }
    return v0;
}

// sutil's LCG (raykit_device::sampling::Lcg): a uniform number in [0, 1).
static __forceinline__ __device__ float rnd(unsigned int& state) {
    state = state * 1664525u + 1013904223u;
    return (float)(state & 0x00ffffffu) / 16777216.0f;
}

// A cosine-weighted direction around +z.
static __forceinline__ __device__ float3 cosine_sample_hemisphere(float u1, float u2) {
    const float r = sqrtf(u1);
    float s, c;
    sincosf(2.0f * PATH_PI * u2, &s, &c);
    const float x = r * c;
    const float y = r * s;
    return make_float3(x, y, sqrtf(fmaxf(1.0f - x * x - y * y, 0.0f)));
}

// The orthonormal basis around a unit normal (raykit_device::sampling::Onb),
// applied to a local direction.
static __forceinline__ __device__ float3 onb_to_world(float3 normal, float3 p) {
    float3 binormal = fabsf(normal.x) > fabsf(normal.z) ? make_float3(-normal.y, normal.x, 0.0f)
                                                        : make_float3(0.0f, -normal.z, normal.y);
    binormal = normalize(binormal);
    const float3 tangent = cross(binormal, normal);
    return p.x * tangent + p.y * binormal + p.z * normal;
}

// What closest-hit reports (path_tracer_device::math::HitInfo); t < 0 is a miss.
struct HitInfo {
    float3 normal;
    float t;
    float3 emission;
    float3 albedo;
};

// One path (path_tracer_device::math::PathState).
struct PathState {
    float3 origin;
    float3 direction;
    float3 throughput;
    float3 radiance;
    unsigned int depth;
    bool done;
};

struct ShadowRay {
    float3 origin;
    float3 direction;
    float t_max;
    float3 contribution;
};

// PathState::camera: the jittered camera ray of pixel `index`.
static __forceinline__ __device__ PathState camera_state(uint2 index, uint2 dims, unsigned int& seed) {
    const float jx = rnd(seed);
    const float jy = rnd(seed);
    const float dx = 2.0f * ((float)index.x + jx) / (float)dims.x - 1.0f;
    const float dy = 1.0f - 2.0f * ((float)index.y + jy) / (float)dims.y;
    PathState s;
    s.origin = params.cam_eye;
    s.direction = normalize(dx * params.cam_u + dy * params.cam_v + params.cam_w);
    s.throughput = make_float3(1.0f, 1.0f, 1.0f);
    s.radiance = make_float3(0.0f, 0.0f, 0.0f);
    s.depth = 0;
    s.done = false;
    return s;
}

// PathState::shade: emission seen by the camera ray, one light sample (returned
// as a shadow ray), the cosine-weighted bounce, Russian roulette.
static __forceinline__ __device__ ShadowRay shade(PathState& s, const HitInfo& hit, const PathRaygenData& light,
                                                  unsigned int& seed, unsigned int max_depth) {
    ShadowRay shadow;
    shadow.origin = make_float3(0.0f, 0.0f, 0.0f);
    shadow.direction = make_float3(0.0f, 0.0f, 1.0f);
    shadow.t_max = 0.0f;
    shadow.contribution = make_float3(0.0f, 0.0f, 0.0f);
    if (hit.t < 0.0f) {
        s.done = true;
        return shadow;
    }
    const float3 p = s.origin + hit.t * s.direction;
    const float3 n = hit.normal;
    if (s.depth == 0) {
        s.radiance += s.throughput * hit.emission;
    }

    const float lu = rnd(seed);
    const float lv = rnd(seed);
    const float3 light_point = light.corner + lu * light.v1 + lv * light.v2;
    const float3 to_light = light_point - p;
    const float distance = length(to_light);
    const float3 l = to_light / distance;
    const float n_dot_l = dot(n, l);
    const float3 light_normal = normalize(cross(light.v1, light.v2));
    const float ln_dot_l = -dot(light_normal, l);
    shadow.origin = p;
    shadow.direction = l;
    shadow.t_max = distance - PATH_RAY_EPSILON;
    if (n_dot_l > 0.0f && ln_dot_l > 0.0f) {
        const float area = length(cross(light.v1, light.v2));
        const float geometry = n_dot_l * ln_dot_l * area / (distance * distance);
        shadow.contribution = s.throughput * (hit.albedo * (1.0f / PATH_PI)) * light.emission * geometry;
    }

    const float u1 = rnd(seed);
    const float u2 = rnd(seed);
    const float3 local = cosine_sample_hemisphere(u1, u2);
    s.origin = p;
    s.direction = onb_to_world(n, local);
    s.throughput *= hit.albedo;
    s.depth += 1;

    const float survive = rnd(seed);
    if (s.depth >= max_depth) {
        s.done = true;
    } else if (s.depth > PATH_ROULETTE_AFTER) {
        const float q = fminf(max_element(s.throughput), PATH_ROULETTE_MAX_SURVIVAL);
        if (survive >= q) {
            s.done = true;
        } else {
            s.throughput = s.throughput / q;
        }
    }
    return shadow;
}

extern "C" __global__ void __raygen__rg() {
    const uint3 launch = optixGetLaunchIndex();
    const uint2 index = make_uint2(launch.x, launch.y + params.row_offset);
    const uint2 dims = params.size;
    const unsigned int pixel = index.x + dims.x * index.y;
    const PathRaygenData* record = reinterpret_cast<const PathRaygenData*>(optixGetSbtDataPointer());
    unsigned int seed = tea4(pixel, params.subframe);
    float3 sum = make_float3(0.0f, 0.0f, 0.0f);
    unsigned int rays = 0;
    for (unsigned int sample = 0; sample < params.samples; sample++) {
        PathState state = camera_state(index, dims, seed);
        while (!state.done) {
            // HitInfo::MISS, then the radiance ray.
            unsigned int p0 = 0, p1 = 0, p2 = 0, p3 = __float_as_uint(-1.0f), p4 = 0, p5 = 0, p6 = 0, p7 = 0,
                         p8 = 0, p9 = 0;
            optixTrace(params.handle, state.origin, state.direction, PATH_RAY_EPSILON, 1e16f, 0.0f,
                       OptixVisibilityMask(255), OPTIX_RAY_FLAG_NONE, 0, 2, 0, p0, p1, p2, p3, p4, p5, p6, p7, p8,
                       p9);
            rays += 1;
            HitInfo hit;
            hit.normal = make_float3(__uint_as_float(p0), __uint_as_float(p1), __uint_as_float(p2));
            hit.t = __uint_as_float(p3);
            hit.emission = make_float3(__uint_as_float(p4), __uint_as_float(p5), __uint_as_float(p6));
            hit.albedo = make_float3(__uint_as_float(p7), __uint_as_float(p8), __uint_as_float(p9));
            const ShadowRay shadow = shade(state, hit, *record, seed, params.max_depth);
            if (!is_zero(shadow.contribution)) {
                unsigned int visible = 0;
                optixTrace(params.handle, shadow.origin, shadow.direction, PATH_RAY_EPSILON, shadow.t_max, 0.0f,
                           OptixVisibilityMask(255),
                           OPTIX_RAY_FLAG_TERMINATE_ON_FIRST_HIT | OPTIX_RAY_FLAG_DISABLE_CLOSESTHIT |
                               OPTIX_RAY_FLAG_DISABLE_ANYHIT,
                           1, 2, 1, visible);
                rays += 1;
                if (visible != 0) {
                    state.radiance += shadow.contribution;
                }
            }
        }
        sum += state.radiance;
    }
    float4 previous = make_float4(0.0f, 0.0f, 0.0f, 0.0f);
    if (params.subframe != 0) {
        previous = params.accum[pixel];
    }
    params.accum[pixel] =
        make_float4(previous.x + sum.x, previous.y + sum.y, previous.z + sum.z, previous.w + (float)rays);
}

extern "C" __global__ void __miss__ms() { optixSetPayload_3(__float_as_uint(-1.0f)); }

extern "C" __global__ void __closesthit__ch() {
    const PathHitData* material = reinterpret_cast<const PathHitData*>(optixGetSbtDataPointer());
    const unsigned int t = material->first_triangle + optixGetPrimitiveIndex();
    float3 normal = make_float3(params.normals[3 * t], params.normals[3 * t + 1], params.normals[3 * t + 2]);
    // face_forward against the ray.
    if (dot(normal, optixGetWorldRayDirection()) > 0.0f) {
        normal = -normal;
    }
    optixSetPayload_0(__float_as_uint(normal.x));
    optixSetPayload_1(__float_as_uint(normal.y));
    optixSetPayload_2(__float_as_uint(normal.z));
    optixSetPayload_3(__float_as_uint(optixGetRayTmax()));
    optixSetPayload_4(__float_as_uint(material->emission.x));
    optixSetPayload_5(__float_as_uint(material->emission.y));
    optixSetPayload_6(__float_as_uint(material->emission.z));
    optixSetPayload_7(__float_as_uint(material->albedo.x));
    optixSetPayload_8(__float_as_uint(material->albedo.y));
    optixSetPayload_9(__float_as_uint(material->albedo.z));
}

extern "C" __global__ void __miss__ms_shadow() { optixSetPayload_0(1u); }

// The shadow hit group's closest-hit (never run: shadow rays disable it).
extern "C" __global__ void __closesthit__ch_shadow() { optixSetPayload_0(0u); }
