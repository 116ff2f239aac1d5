//! The same material code in two program layouts (the MDL SDK's two modes for
//! OptiX): [`Material`] implementations compute a surface colour; the
//! `material_programs!` invocation below emits, for each, a direct callable
//! (`__direct_callable__mat_*`, called by one closest-hit, `ch_callables`,
//! through the callable index in the hit record) and a closest-hit of its own
//! (`__closesthit__ch_mat_*`, the material inlined, one hit group per material).
//! Both call the one generic [`shade`], so the two modes compute the same bits.

use raykit_device::glam::{Vec2, Vec3};
use raykit_device::math::sin_cos;

/// A material: the colour of a surface point from its texture coordinates.
pub trait Material {
    /// The colour at `uv`.
    fn color(uv: Vec2) -> Vec3;
}

/// What `ch_callables` hands a material callable, and gets back.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default)]
pub struct ShadeCall {
    /// Texture coordinates.
    pub uv: Vec2,
    /// Padding.
    pub _pad: Vec2,
    /// The colour.
    pub color: Vec3,
}

/// The colour material `M` gives `uv`, as both modes compute it.
pub fn shade<M: Material>(uv: Vec2) -> Vec3 {
    M::color(uv).clamp(Vec3::ZERO, Vec3::ONE)
}

fn frac(x: f32) -> f32 {
    x - (x as i32) as f32 + if x < 0.0 { 1.0 } else { 0.0 }
}

macro_rules! materials {
    ($($(#[$doc:meta])* $name:ident => |$uv:ident| $body:expr;)*) => {
        $($(#[$doc])* pub struct $name;
        impl Material for $name {
            fn color($uv: Vec2) -> Vec3 {
                $body
            }
        })*
    };
}

materials! {
    /// Red and white checks, 4 per unit.
    Checks => |uv| if (frac(uv.x * 2.0) < 0.5) == (frac(uv.y * 2.0) < 0.5) { Vec3::new(0.9, 0.1, 0.1) } else { Vec3::ONE };
    /// Horizontal stripes.
    Stripes => |uv| Vec3::new(0.2, 0.3, 0.9) * (0.5 + 0.5 * sin_cos(uv.y * 40.0).0);
    /// A gradient.
    Gradient => |uv| Vec3::new(frac(uv.x), frac(uv.y), 0.5);
    /// Concentric rings.
    Rings => |uv| {
        let d = (uv - Vec2::splat(0.5)).length();
        Vec3::new(0.1, 0.8, 0.3) * (0.5 + 0.5 * sin_cos(d * 60.0).1)
    };
    /// A dot grid.
    Dots => |uv| {
        let c = Vec2::new(frac(uv.x * 5.0), frac(uv.y * 5.0)) - Vec2::splat(0.5);
        if c.length() < 0.3 { Vec3::new(1.0, 0.8, 0.1) } else { Vec3::splat(0.1) }
    };
    /// Diagonal bands.
    Bands => |uv| if frac((uv.x + uv.y) * 3.0) < 0.5 { Vec3::new(0.6, 0.2, 0.8) } else { Vec3::splat(0.3) };
    /// A warped pattern.
    Waves => |uv| {
        let (s, c) = sin_cos(uv.x * 12.0 + sin_cos(uv.y * 9.0).0 * 2.0);
        Vec3::new(0.5 + 0.5 * s, 0.5 + 0.5 * c, 0.6)
    };
    /// A grid of lines.
    Grid => |uv| {
        let g = Vec2::new(frac(uv.x * 8.0), frac(uv.y * 8.0));
        if g.x < 0.1 || g.y < 0.1 { Vec3::ZERO } else { Vec3::new(0.95, 0.95, 0.8) }
    };
}

/// The number of materials.
pub const MATERIAL_COUNT: u32 = 8;

/// Material `index`'s colour at `uv` (host side: the CPU reference of both modes).
pub fn color_of(index: u32, uv: Vec2) -> Vec3 {
    match index % MATERIAL_COUNT {
        0 => shade::<Checks>(uv),
        1 => shade::<Stripes>(uv),
        2 => shade::<Gradient>(uv),
        3 => shade::<Rings>(uv),
        4 => shade::<Dots>(uv),
        5 => shade::<Bands>(uv),
        6 => shade::<Waves>(uv),
        _ => shade::<Grid>(uv),
    }
}
