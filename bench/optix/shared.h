// Launch params and SBT record data of the OptiX twins, shared by the device
// programs (primary.cu, path.cu) and the host program (main.cpp). The layouts
// follow raykit's device crates (examples/triangle/device,
// examples/path_tracer/device); buffers are device pointers here instead of
// buffer-table handles.
#pragma once

#include <optix_types.h>

#ifndef __CUDACC__
#include <vector_types.h>
#endif

// The primary-ray programs (triangle-device): one camera ray per pixel.
struct PrimaryParams {
    unsigned int* image;  // RGBA8 pixels, row-major, row 0 at the top
    uint2 size;
    float3 cam_eye;
    float3 cam_u;  // right, scaled to half the image-plane width
    float3 cam_v;  // up, scaled to half the image-plane height
    float3 cam_w;  // forward, to the image-plane centre
    OptixTraversableHandle handle;
};

// The miss program's record data: the background colour.
struct PrimaryMissData {
    float3 bg_color;
};

// The path tracer (path-tracer-device).
struct PathParams {
    float4* accum;         // per pixel: radiance sum (xyz), rays traced (w)
    const float* normals;  // unit geometric normal per triangle, 3 floats each
    uint2 size;
    unsigned int subframe;
    unsigned int samples;
    unsigned int max_depth;
    unsigned int row_offset;
    float3 cam_eye;
    float3 cam_u;
    float3 cam_v;
    float3 cam_w;
    OptixTraversableHandle handle;
};

// The raygen record: the parallelogram light.
struct PathRaygenData {
    float3 corner;
    float3 v1;
    float3 v2;
    float3 emission;
};

// The radiance hit group's record, one per material group (build input).
struct PathHitData {
    float3 emission;
    unsigned int first_triangle;
    float3 albedo;
    unsigned int pad;
};

// The path tracer's constants (path_tracer_device::math).
#define PATH_RAY_EPSILON 0.01f
#define PATH_ROULETTE_AFTER 2u
#define PATH_ROULETTE_MAX_SURVIVAL 0.95f
