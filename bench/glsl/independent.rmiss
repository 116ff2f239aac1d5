#version 460
#extension GL_GOOGLE_include_directive : require
#include "independent.glsl"

layout(location = 0) rayPayloadInEXT vec3 color;

void main() { color = camera.background.xyz; }
