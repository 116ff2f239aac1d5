// The float3 arithmetic the device programs use (what glam does in the Rust
// programs), written out here rather than taken from the SDK samples' vec_math.h.
#pragma once

static __forceinline__ __device__ float3 operator+(float3 a, float3 b) { return make_float3(a.x + b.x, a.y + b.y, a.z + b.z); }
static __forceinline__ __device__ float3 operator-(float3 a, float3 b) { return make_float3(a.x - b.x, a.y - b.y, a.z - b.z); }
static __forceinline__ __device__ float3 operator-(float3 a) { return make_float3(-a.x, -a.y, -a.z); }
static __forceinline__ __device__ float3 operator*(float3 a, float3 b) { return make_float3(a.x * b.x, a.y * b.y, a.z * b.z); }
static __forceinline__ __device__ float3 operator*(float s, float3 a) { return make_float3(s * a.x, s * a.y, s * a.z); }
static __forceinline__ __device__ float3 operator*(float3 a, float s) { return make_float3(a.x * s, a.y * s, a.z * s); }
static __forceinline__ __device__ float3 operator/(float3 a, float s) { return make_float3(a.x / s, a.y / s, a.z / s); }
static __forceinline__ __device__ float3 operator/(float3 a, float3 b) { return make_float3(a.x / b.x, a.y / b.y, a.z / b.z); }
static __forceinline__ __device__ void operator+=(float3& a, float3 b) { a = a + b; }
static __forceinline__ __device__ void operator*=(float3& a, float3 b) { a = a * b; }
static __forceinline__ __device__ float dot(float3 a, float3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static __forceinline__ __device__ float3 cross(float3 a, float3 b) {
    return make_float3(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}
static __forceinline__ __device__ float length(float3 a) { return sqrtf(dot(a, a)); }
// glam's `normalize`, `self * (1.0 / self.length())`, as NVIDIA's Vulkan
// compiler turns it out: `1.0 / sqrt(x)` becomes one reciprocal square root.
// (`a * (1.0f / length(a))` under --use_fast_math rounds differently and moves
// 0.4% of the primary-ray pixels' colours by one step.)
static __forceinline__ __device__ float3 normalize(float3 a) { return a * rsqrtf(dot(a, a)); }
static __forceinline__ __device__ float max_element(float3 a) { return fmaxf(fmaxf(a.x, a.y), a.z); }
static __forceinline__ __device__ bool is_zero(float3 a) { return a.x == 0.0f && a.y == 0.0f && a.z == 0.0f; }
