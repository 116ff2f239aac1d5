#version 460
#extension GL_EXT_ray_tracing : require
// A miss program whose push-constant block differs from the triangle's Params,
// to check that raykit refuses to link modules that disagree on the params type.
//   glslangValidator --target-env vulkan1.2 -o miss_other_params.rmiss.spv miss_other_params.rmiss
layout(location = 0) rayPayloadInEXT vec3 color;
layout(push_constant) uniform Other { vec4 tint; float scale; } other;
void main() { color = other.tint.rgb * other.scale; }
