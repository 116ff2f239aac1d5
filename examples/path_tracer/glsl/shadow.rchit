#version 460
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
// The shadow ray type's hit group (never run: shadow rays skip closest-hit).
layout(location = 0) rayPayloadInEXT uint visible;
void main() {
    visible = 0u;
}
