//! Device programs of the device-math tests: raygen evaluates every function of
//! `raykit_device::math` on input `i` of a buffer and writes the results, so
//! that the host can compare them, on each backend, with `std`'s `f32` methods.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::Vec4;
use raykit_device::math;
use raykit_device::{raygen, Buffer, LaunchParams, Raygen};

/// Launch params.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// One input per launch index: `x`, `y`, `z` (unused `w`); see [`FUNCTIONS`]
    /// for which function takes which.
    pub inputs: Buffer<Vec4>,
    /// [`FUNCTIONS`]`.len()` results per input, in that order.
    pub outputs: Buffer<f32>,
}

/// The functions, in the order of their results, with the arguments they take.
pub const FUNCTIONS: [&str; 29] = [
    "floor(x)",
    "ceil(x)",
    "round(x)",
    "trunc(x)",
    "fract(x)",
    "abs(x)",
    "signum(x)",
    "min(x, y)",
    "max(x, y)",
    "clamp(x, y, z)",
    "lerp(x, y, z)",
    "sqrt(x)",
    "rsqrt(x)",
    "exp(x)",
    "exp2(x)",
    "ln(x)",
    "log2(x)",
    "powf(x, y)",
    "sin(x)",
    "cos(x)",
    "tan(x)",
    "sin_cos(x).0",
    "sin_cos(x).1",
    "asin(x)",
    "acos(x)",
    "atan(x)",
    "atan2(x, y)",
    "smoothstep(y, z, x)",
    "step(y, x)",
];

/// Every function of [`FUNCTIONS`] of `(x, y, z)`, in that order; the same code
/// on the GPU and on the CPU backend.
pub fn evaluate(x: f32, y: f32, z: f32) -> [f32; 29] {
    let (s, c) = math::sin_cos(x);
    [
        math::floor(x),
        math::ceil(x),
        math::round(x),
        math::trunc(x),
        math::fract(x),
        math::abs(x),
        math::signum(x),
        math::min(x, y),
        math::max(x, y),
        math::clamp(x, y, z),
        math::lerp(x, y, z),
        math::sqrt(x),
        math::rsqrt(x),
        math::exp(x),
        math::exp2(x),
        math::ln(x),
        math::log2(x),
        math::powf(x, y),
        math::sin(x),
        math::cos(x),
        math::tan(x),
        s,
        c,
        math::asin(x),
        math::acos(x),
        math::atan(x),
        math::atan2(x, y),
        math::smoothstep(y, z, x),
        math::step(y, x),
    ]
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params) {
    let i = ctx.launch_index().x;
    let input = ctx.load(p.inputs, i);
    let results = evaluate(input.x, input.y, input.z);
    let count = FUNCTIONS.len() as u32;
    let mut k = 0;
    while k < count {
        ctx.store(p.outputs, count * i + k, results[k as usize]);
        k += 1;
    }
}
