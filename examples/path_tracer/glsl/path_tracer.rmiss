#version 460
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
layout(location = 0) rayPayloadInEXT HitInfo hit;
void main() {
    hit.t = -1.0;
}
