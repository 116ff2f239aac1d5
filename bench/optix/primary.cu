// The primary-ray programs of the `primary` suite for OptiX: optixTriangle's
// programs as raykit's triangle-device writes them (examples/triangle/device):
// a pinhole camera ray per pixel, the miss program's background colour from its
// record, a closest-hit colour from the barycentrics, sutil's make_color.
#include <optix.h>

#include "shared.h"
#include "vec.h"

extern "C" {
__constant__ PrimaryParams params;
}

// One channel clamped to [0, 1], sRGB-encoded, quantised to 8 bits
// (raykit_device::color::srgb8 by its formula).
static __forceinline__ __device__ unsigned int srgb8(float c) {
    c = fminf(fmaxf(c, 0.0f), 1.0f);
    float s = c <= 0.0031308f ? 12.92f * c : 1.055f * powf(c, 1.0f / 2.4f) - 0.055f;
    return (unsigned int)(s * 255.0f + 0.5f);
}

static __forceinline__ __device__ unsigned int make_color(float3 c) {
    return srgb8(c.x) | (srgb8(c.y) << 8) | (srgb8(c.z) << 16) | (255u << 24);
}

extern "C" __global__ void __raygen__rg() {
    const uint3 idx = optixGetLaunchIndex();
    const uint3 dim = optixGetLaunchDimensions();
    // pixel_to_ndc, then camera_ray.
    const float x = ((float)idx.x + 0.5f) / (float)dim.x;
    const float y = ((float)idx.y + 0.5f) / (float)dim.y;
    const float dx = 2.0f * x - 1.0f;
    const float dy = 1.0f - 2.0f * y;
    const float3 direction = normalize(dx * params.cam_u + dy * params.cam_v + params.cam_w);
    unsigned int p0 = __float_as_uint(0.0f), p1 = __float_as_uint(0.0f), p2 = __float_as_uint(0.0f);
    optixTrace(params.handle, params.cam_eye, direction, 0.0f, 1e16f, 0.0f, OptixVisibilityMask(255),
               OPTIX_RAY_FLAG_NONE, 0, 1, 0, p0, p1, p2);
    const float3 color = make_float3(__uint_as_float(p0), __uint_as_float(p1), __uint_as_float(p2));
    params.image[idx.x + dim.x * idx.y] = make_color(color);
}

extern "C" __global__ void __miss__ms() {
    const PrimaryMissData* data = reinterpret_cast<const PrimaryMissData*>(optixGetSbtDataPointer());
    optixSetPayload_0(__float_as_uint(data->bg_color.x));
    optixSetPayload_1(__float_as_uint(data->bg_color.y));
    optixSetPayload_2(__float_as_uint(data->bg_color.z));
}

extern "C" __global__ void __closesthit__ch() {
    const float2 b = optixGetTriangleBarycentrics();
    optixSetPayload_0(__float_as_uint(1.0f - b.x - b.y));
    optixSetPayload_1(__float_as_uint(b.x));
    optixSetPayload_2(__float_as_uint(b.y));
}
