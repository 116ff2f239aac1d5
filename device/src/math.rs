//! Floating-point functions that device programs and the host share: on the
//! SPIR-V target through spirv-std's `Float` (GLSL.std.450), on the host
//! through `std`. Code that runs on both sides (camera models, sampling, the
//! CPU references of tests) calls these instead of repeating the `cfg` split.

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
