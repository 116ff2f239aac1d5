//! A crate whose only dependency is `raykit`: `#[derive(LaunchParams)]`, the
//! program macros and bytemuck's derives all reach raykit-device and bytemuck
//! through it.

use raykit::bytemuck::{Pod, Zeroable};
use raykit::device::{raygen, Raygen};
use raykit::glam::{UVec2, Vec3};
use raykit::{Buffer, LaunchParams};

/// Launch params shared with a device crate.
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable, LaunchParams)]
#[bytemuck(crate = "raykit::bytemuck")]
pub struct Params {
    /// The image.
    pub image: Buffer<u32>,
    /// Its size.
    pub size: UVec2,
    /// A colour.
    pub color: Vec3,
    /// Padding.
    pub _pad: u32,
}

/// A raygen program written against `raykit::device` only (never built to
/// SPIR-V here, so without the params check that needs its module).
#[raygen(skip_params_check)]
fn fill(ctx: &mut Raygen, #[params] params: &Params) {
    let pixel = ctx.launch_linear_index();
    ctx.store(params.image, pixel, params.color.x as u32);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_derive_records_the_layout_through_raykit() {
        let layout = <Params as LaunchParams>::LAYOUT;
        let fields: Vec<(&str, u32)> = layout.fields.iter().map(|f| (f.name, f.offset)).collect();
        assert_eq!(fields, [("image", 0), ("size", 4), ("color", 12), ("_pad", 24)]);
        assert_eq!(layout.size, 28);
    }

    #[test]
    fn the_program_macro_names_the_entry_point() {
        assert_eq!(FILL.name, "__raygen__fill");
        assert_eq!(FILL.kind, raykit::ProgramKind::Raygen);
    }

    #[test]
    fn bytemuck_is_reexported() {
        let params = Params::zeroed();
        assert_eq!(raykit::bytemuck::bytes_of(&params).len(), 28);
    }
}
