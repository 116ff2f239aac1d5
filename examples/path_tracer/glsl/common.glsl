// GLSL twin of the path tracer's device programs (../device/src): the same
// launch params (push constants, scalar layout), SBT records, payloads and
// bindless buffer table (set 0, binding 0) as the Rust programs.
#extension GL_EXT_ray_tracing : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require

layout(push_constant, scalar) uniform Params {
    uint accum;      // Buffer<Vec4>: radiance sum (xyz), rays (w)
    uint normals;    // Buffer<Vec3>: per-triangle normal
    uvec2 size;
    uint subframe;
    uint samples;
    uint max_depth;
    uint row_offset; // first image row of this launch (a band of a split launch)
    vec3 cam_eye;
    vec3 cam_u;
    vec3 cam_v;
    vec3 cam_w;
    uint64_t handle;
} params;

layout(set = 0, binding = 0, scalar) buffer Words { uint words[]; } buffers[];
// A Buffer<T> handle is a table slot (low 12 bits) and a generation the host
// checks (the bits above): index the table with the slot bits only.
#define SLOT(handle) ((handle) & 4095u)

// The radiance ray's payload (math::HitInfo): t < 0 is a miss.
struct HitInfo {
    vec3 normal;
    float t;
    vec3 emission;
    vec3 albedo;
};

const float PI = 3.14159265358979323846;
const float RAY_EPSILON = 0.01;
const uint ROULETTE_AFTER = 2u;
const float ROULETTE_MAX_SURVIVAL = 0.95;
