// Shared by the GLSL twin of the triangle programs: the same launch params and
// bindless buffer table as the Rust programs (set 0, binding 0; push constants).
#extension GL_EXT_ray_tracing : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_nonuniform_qualifier : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

layout(push_constant, scalar) uniform Params {
    uint image;
    uvec2 size;
    vec3 cam_eye;
    vec3 cam_u;
    vec3 cam_v;
    vec3 cam_w;
    uint pad;
    uint64_t handle;
} params;

layout(set = 0, binding = 0, scalar) buffer Words { uint words[]; } buffers[];
// A Buffer<T> handle is a table slot (low 12 bits) and a generation the host
// checks (the bits above): index the table with the slot bits only.
#define SLOT(handle) ((handle) & 4095u)
