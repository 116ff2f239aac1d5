//! Floating-point functions that device programs and the host share: on the
//! SPIR-V target through spirv-std's `Float` (GLSL.std.450 instructions), on the
//! host (the CPU backend, CPU references) through `std`'s `f32` methods. Code
//! that runs on both sides calls these instead of repeating the `cfg` split.
//!
//! The functions that are exact in IEEE arithmetic (`floor`, `ceil`, `trunc`,
//! `round`, `fract`, `abs`, `signum`, `min`, `max`, `clamp`, `step`) give the
//! same bits on both sides; the others are as precise as the Vulkan driver's
//! GLSL.std.450 (the Vulkan spec's bounds: e.g. 3 + 2·|x| ulps for `exp`,
//! an absolute 2⁻¹¹ for `sin` and `cos` on `[−π, π]`). The test
//! `tests/tests/math.rs` measures both backends against `std`.
//!
//! Where GLSL and Rust disagree, Rust's definition is kept: `round` rounds
//! halfway cases away from zero, `signum(±0)` is ±1, `min`/`max` return the
//! other argument for one NaN, and `clamp` never panics (`hi` wins when
//! `lo > hi`). `fract` is GLSL's `x − floor(x)` (in `[0, 1)`), not `std`'s
//! `x − trunc(x)`.

/// A one-argument function through spirv-std's `Float` on the GPU, `std` on the host.
macro_rules! float_fn {
    ($(#[$doc:meta])* $name:ident => $method:ident) => {
        $(#[$doc])*
        pub fn $name(x: f32) -> f32 {
            #[cfg(target_arch = "spirv")]
            {
                // `core` has some of these (`abs`) as inherent methods.
                #[allow(unused_imports)]
                use spirv_std::num_traits::Float;
                x.$method()
            }
            #[cfg(not(target_arch = "spirv"))]
            {
                x.$method()
            }
        }
    };
}

float_fn!(/// The largest integer not above `x`.
    floor => floor);
float_fn!(/// The smallest integer not below `x`.
    ceil => ceil);
float_fn!(/// `x` without its fractional part (rounded towards zero).
    trunc => trunc);
float_fn!(/// `|x|`.
    abs => abs);
float_fn!(/// `eˣ`.
    exp => exp);
float_fn!(/// `2ˣ`.
    exp2 => exp2);
float_fn!(/// The natural logarithm.
    ln => ln);
float_fn!(/// The base-2 logarithm.
    log2 => log2);
float_fn!(/// Sine (radians).
    sin => sin);
float_fn!(/// Cosine (radians).
    cos => cos);

/// Arcsine, in `[−π/2, π/2]`; NaN outside `[−1, 1]`. On the GPU as
/// `atan2(x, √((1 − x)(1 + x)))`: drivers' `Asin` may be off by 2⁻¹² (lavapipe's is).
pub fn asin(x: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        atan2(x, sqrt((1.0 - x) * (1.0 + x)))
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        x.asin()
    }
}

/// Arccosine, in `[0, π]`; NaN outside `[−1, 1]`. On the GPU as
/// `atan2(√((1 − x)(1 + x)), x)`, for the reason [`asin`] gives.
pub fn acos(x: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        atan2(sqrt((1.0 - x) * (1.0 + x)), x)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        x.acos()
    }
}
float_fn!(/// Arctangent, in `[−π/2, π/2]`.
    atan => atan);

/// `x` rounded to the nearest integer, halfway cases away from zero (Rust's
/// `round`; GLSL's `Round` leaves the halfway direction to the driver).
pub fn round(x: f32) -> f32 {
    let t = trunc(x);
    // `x − t` is exact: |x − t| < 1 and both share x's exponent or less.
    if abs(x - t) >= 0.5 {
        t + signum(x)
    } else {
        t
    }
}

/// `x − floor(x)`, GLSL's `fract`: in `[0, 1)` for finite `x` (rounded to 1
/// for tiny negative `x`).
pub fn fract(x: f32) -> f32 {
    x - floor(x)
}

/// 1 for `x ≥ +0`, −1 for `x ≤ −0`, NaN for NaN (Rust's `signum`).
pub fn signum(x: f32) -> f32 {
    if x.is_nan() {
        x
    } else {
        f32::from_bits((x.to_bits() & 0x8000_0000) | 1.0f32.to_bits())
    }
}

/// The smaller of `x` and `y`; the other one when one is NaN.
pub fn min(x: f32, y: f32) -> f32 {
    if y < x || x.is_nan() {
        y
    } else {
        x
    }
}

/// The larger of `x` and `y`; the other one when one is NaN.
pub fn max(x: f32, y: f32) -> f32 {
    if y > x || x.is_nan() {
        y
    } else {
        x
    }
}

/// `x` limited to `[lo, hi]`: `min(max(x, lo), hi)`, NaN for NaN `x` (as
/// `f32::clamp`). Never panics (unlike `f32::clamp`): `hi` wins when `lo > hi`.
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x.is_nan() {
        x
    } else {
        min(max(x, lo), hi)
    }
}

/// `a + t (b − a)`: `a` at `t = 0`, `b` at `t = 1` (GLSL's `mix`).
pub fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

/// 0 for `x < edge`, else 1 (GLSL's `step`).
pub fn step(edge: f32, x: f32) -> f32 {
    if x < edge {
        0.0
    } else {
        1.0
    }
}

/// Hermite interpolation from 0 at `edge0` to 1 at `edge1` (GLSL's
/// `smoothstep`, `t² (3 − 2t)` with `t` the clamped position).
pub fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// `1 / √x`, as a division by [`sqrt`] on both sides (the driver's
/// `inversesqrt` may be less precise than the two).
pub fn rsqrt(x: f32) -> f32 {
    1.0 / sqrt(x)
}

/// `atan(y / x)` in the quadrant of `(x, y)`, in `[−π, π]`.
pub fn atan2(y: f32, x: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::num_traits::Float;
        y.atan2(x)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        y.atan2(x)
    }
}

/// Square root.
pub fn sqrt(x: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::num_traits::Float;
        x.sqrt()
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        x.sqrt()
    }
}

/// `x` to the power `y`.
pub fn powf(x: f32, y: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::num_traits::Float;
        x.powf(y)
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        x.powf(y)
    }
}

/// `(sin x, cos x)`.
pub fn sin_cos(x: f32) -> (f32, f32) {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::num_traits::Float;
        (x.sin(), x.cos())
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        x.sin_cos()
    }
}

/// Tangent.
pub fn tan(x: f32) -> f32 {
    #[cfg(target_arch = "spirv")]
    {
        use spirv_std::num_traits::Float;
        x.tan()
    }
    #[cfg(not(target_arch = "spirv"))]
    {
        x.tan()
    }
}
