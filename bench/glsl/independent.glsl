// The independent baseline's primary-ray programs: a plain descriptor set
// (binding 0: the TLAS, binding 1: the RGBA8 output, one uint per pixel) and
// the camera and background in push constants (std430, vec4 per vector, xyz
// used). No bindless table, no handles: what a Vulkan program written without
// raykit binds. The picture is examples/triangle's: one camera ray per pixel,
// barycentric colour on a hit, the background on a miss, sRGB-quantised.
#extension GL_EXT_ray_tracing : require

layout(push_constant, std430) uniform Camera {
    vec4 eye;
    vec4 u;
    vec4 v;
    vec4 w;
    vec4 background;
} camera;
