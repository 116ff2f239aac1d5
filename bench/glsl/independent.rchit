#version 460
#extension GL_EXT_ray_tracing : require

layout(location = 0) rayPayloadInEXT vec3 color;
hitAttributeEXT vec2 bary;

void main() { color = vec3(1.0 - bary.x - bary.y, bary.x, bary.y); }
