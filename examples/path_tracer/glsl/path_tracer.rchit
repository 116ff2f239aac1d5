#version 460
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
layout(location = 0) rayPayloadInEXT HitInfo hit;
layout(shaderRecordEXT, scalar) buffer HitRecord {
    vec3 emission;
    uint first_triangle;
    vec3 albedo;
    uint pad;
} material;

void main() {
    uint base = (material.first_triangle + gl_PrimitiveID) * 3u;
    vec3 n = vec3(uintBitsToFloat(buffers[SLOT(params.normals)].words[base]),
                  uintBitsToFloat(buffers[SLOT(params.normals)].words[base + 1u]),
                  uintBitsToFloat(buffers[SLOT(params.normals)].words[base + 2u]));
    hit.normal = dot(n, gl_WorldRayDirectionEXT) > 0.0 ? -n : n;
    hit.t = gl_HitTEXT;
    hit.emission = material.emission;
    hit.albedo = material.albedo;
}
