//! Buffer elements: user structs in `Buffer<T>`s, read and written by a program.
//!
//! [`Sphere`] nests [`Material`] and holds every kind of element field (vectors
//! of floats and integers, a float, a 64-bit integer, a buffer handle); the
//! program [`RG_ELEMENTS`] reads sphere `i`, changes every field in a way whose
//! result is exact, and writes it to the output buffer. [`Shifted`] differs
//! between the host and the SPIR-V target on purpose, so the host must refuse it.

use raykit_device::glam::{IVec2, Vec3};
use raykit_device::{raygen, Buffer, Element, LaunchParams, Raygen};

/// A material as a buffer holds it: 4 words.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable, Element)]
pub struct Material {
    /// A colour.
    pub albedo: Vec3,
    /// What kind of material.
    pub kind: u32,
}

/// A sphere as a buffer holds it: 14 words.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable, Element)]
pub struct Sphere {
    /// Its centre.
    pub centre: Vec3,
    /// Its radius.
    pub radius: f32,
    /// A 64-bit identifier (two words).
    pub id: u64,
    /// Its material, nested.
    pub material: Material,
    /// Two signed integers.
    pub neighbours: IVec2,
    /// A buffer handle, stored as it is.
    pub texels: Buffer<u32>,
    /// A signed integer at the end.
    pub bias: i32,
}

impl Sphere {
    /// What [`RG_ELEMENTS`] makes of sphere `index`: every field changed, exactly.
    pub fn transformed(self, index: u32) -> Sphere {
        Sphere {
            centre: self.centre * 2.0,
            radius: self.radius + 0.5,
            id: self.id.wrapping_add(u64::from(index) << 32),
            material: Material {
                albedo: Vec3::new(self.material.albedo.z, self.material.albedo.y, self.material.albedo.x),
                kind: self.material.kind + index,
            },
            neighbours: IVec2::new(-self.neighbours.y, self.neighbours.x),
            texels: Buffer::from_table_index(self.texels.raw() + 1),
            bias: self.bias - index as i32,
        }
    }
}

/// The spheres in, and where the changed ones go.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct ElementParams {
    /// The spheres the program reads.
    pub spheres: Buffer<Sphere>,
    /// Where it writes them, changed.
    pub out: Buffer<Sphere>,
    /// Where it writes each sphere's material alone.
    pub materials: Buffer<Material>,
}

/// Reads sphere `i` (the launch index), writes it changed to `out` and its
/// changed material to `materials`.
#[raygen]
fn rg_elements(ctx: &mut Raygen, #[params] p: &ElementParams) {
    let i = ctx.launch_index().x;
    let sphere = ctx.load(p.spheres, i).transformed(i);
    ctx.store(p.out, i, sphere);
    ctx.store(p.materials, i, sphere.material);
}

/// A buffer element laid out differently on the host and on the SPIR-V target,
/// as a field behind `cfg` makes it: `value` is word 0 on the host and word 1 on
/// the device. No build-time test: the host test expects `check_element`'s error.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, Element)]
#[element(skip_layout_test)]
pub struct Shifted {
    /// Only on the device.
    #[cfg(target_arch = "spirv")]
    pub device_only: u32,
    /// The value.
    pub value: f32,
}
