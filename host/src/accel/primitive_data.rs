//! What a GAS keeps in device memory for its programs besides the structure:
//! the spheres of [`Gas::spheres`](super::Gas::spheres) and
//! [`Gas::moving_spheres`](super::Gas::moving_spheres) for their intersection
//! program, or the mesh of [`Gas::mesh`](super::Gas::mesh) for
//! `raykit_device::triangle::surface`. An [`Ias`](super::Ias) over the GAS keeps
//! it alive too.

use glam::{Vec2, Vec3, Vec4};
use raykit_device::triangle::{MeshData, HAS_NORMALS, HAS_UVS};

use crate::context::Context;
use crate::error::Result;
use crate::memory::DeviceBuffer;
use crate::types::mesh::Mesh;

/// A GAS's primitives in device memory.
pub(crate) enum PrimitiveData {
    /// Built-in spheres: centre in `xyz`, radius in `w`, by primitive.
    Spheres(DeviceBuffer<Vec4>),
    /// Moving spheres: sphere `i` at time 0 at `2i`, at time 1 at `2i + 1`.
    MovingSpheres(DeviceBuffer<Vec4>),
    /// A triangle mesh's vertices and attributes.
    Mesh(Box<MeshBuffers>),
}

/// [`Mesh`] in device memory.
pub(crate) struct MeshBuffers {
    positions: DeviceBuffer<Vec3>,
    indices: DeviceBuffer<u32>,
    normals: Option<DeviceBuffer<Vec3>>,
    uvs: Option<DeviceBuffer<Vec2>>,
}

impl MeshBuffers {
    /// Uploads a checked mesh.
    pub(crate) fn new(ctx: &Context, mesh: &Mesh) -> Result<MeshBuffers> {
        Ok(MeshBuffers {
            positions: DeviceBuffer::from_slice(ctx, &mesh.positions)?,
            indices: DeviceBuffer::from_slice(ctx, &mesh.indices)?,
            normals: mesh.normals.as_deref().map(|n| DeviceBuffer::from_slice(ctx, n)).transpose()?,
            uvs: mesh.uvs.as_deref().map(|uv| DeviceBuffer::from_slice(ctx, uv)).transpose()?,
        })
    }

    /// The handles device programs read the mesh through.
    pub(crate) fn data(&self) -> MeshData {
        // Absent attributes get the null handle (slot 0: reads give zero), and
        // `HAS_NORMALS`/`HAS_UVS` say not to read them.
        use raykit_device::Buffer;
        MeshData {
            positions: self.positions.handle(),
            indices: self.indices.handle(),
            normals: self.normals.as_ref().map_or(Buffer::from_table_index(0), |b| b.handle()),
            uvs: self.uvs.as_ref().map_or(Buffer::from_table_index(0), |b| b.handle()),
            attributes: if self.normals.is_some() { HAS_NORMALS } else { 0 }
                | if self.uvs.is_some() { HAS_UVS } else { 0 },
        }
    }
}
