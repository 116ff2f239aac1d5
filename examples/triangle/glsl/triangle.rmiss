#version 460
#extension GL_GOOGLE_include_directive : require
#include "common.glsl"
layout(location = 0) rayPayloadInEXT vec3 color;
layout(shaderRecordEXT, scalar) buffer MissData { vec3 bg_color; } record;
void main() { color = record.bg_color; }
