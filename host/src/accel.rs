//! Acceleration structures: OptiX's GAS (geometry) and IAS (instances) on
//! [`VK_KHR_acceleration_structure`](https://registry.khronos.org/vulkan/specs/latest/man/html/VK_KHR_acceleration_structure.html).
//!
//! Building follows OptiX's steps: validate the input, query the memory sizes,
//! allocate the structure and scratch memory, build, free the scratch. Every input
//! is checked before the GPU sees it. An [`Ias`] keeps the [`Gas`]es it instances
//! alive, so an instance can never point at a destroyed GAS.

use std::sync::Arc;

use ash::vk;
use glam::{Affine3A, Vec3};
use gpu_allocator::MemoryLocation;
use raykit_device::Traversable;

use crate::context::{Context, ContextInner};
use crate::error::{Error, Result};
use crate::memory::RawBuffer;

/// An acceleration structure with its storage.
struct AccelStructure {
    ctx: Arc<ContextInner>,
    handle: vk::AccelerationStructureKHR,
    address: u64,
    _storage: RawBuffer,
}

impl Drop for AccelStructure {
    fn drop(&mut self) {
        // SAFETY: builds and launches are blocking, so nothing uses it; instances
        // that reference it hold an `Arc` to its owner.
        unsafe { self.ctx.accel.destroy_acceleration_structure(self.handle, None) };
    }
}

/// Builds one acceleration structure from `geometries` and waits for it.
fn build(
    ctx: &Arc<ContextInner>,
    ty: vk::AccelerationStructureTypeKHR,
    geometries: &[vk::AccelerationStructureGeometryKHR<'_>],
    primitive_counts: &[u32],
) -> Result<AccelStructure> {
    let flags = vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE;
    let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(ty)
        .flags(flags)
        .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        .geometries(geometries);
    let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
    // SAFETY: `info` describes valid geometry; counts match `geometries`.
    unsafe {
        ctx.accel.get_acceleration_structure_build_sizes(
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            &info,
            primitive_counts,
            &mut sizes,
        )
    };
    let storage = RawBuffer::new(
        ctx,
        "acceleration structure",
        sizes.acceleration_structure_size,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
        MemoryLocation::GpuOnly,
        256,
    )?;
    let create = vk::AccelerationStructureCreateInfoKHR::default()
        .buffer(storage.buffer)
        .size(sizes.acceleration_structure_size)
        .ty(ty);
    // SAFETY: the storage buffer is large enough and has the storage usage.
    let handle = unsafe { ctx.accel.create_acceleration_structure(&create, None) }
        .map_err(Error::vk("vkCreateAccelerationStructureKHR"))?;
    let address_info = vk::AccelerationStructureDeviceAddressInfoKHR::default().acceleration_structure(handle);
    // SAFETY: `handle` is a live acceleration structure.
    let address = unsafe { ctx.accel.get_acceleration_structure_device_address(&address_info) };
    let accel = AccelStructure { ctx: ctx.clone(), handle, address, _storage: storage };

    let scratch = RawBuffer::new(
        ctx,
        "acceleration structure scratch",
        sizes.build_scratch_size.max(1),
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuOnly,
        ctx.limits.min_scratch_alignment.max(1) as u64,
    )?;
    info = info.dst_acceleration_structure(handle).scratch_data(vk::DeviceOrHostAddressKHR {
        device_address: scratch.address,
    });
    let ranges: Vec<vk::AccelerationStructureBuildRangeInfoKHR> = primitive_counts
        .iter()
        .map(|&count| vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count))
        .collect();
    ctx.submit_and_wait("an acceleration structure build", |cmd| {
        // SAFETY: all buffers referenced by `info` are alive until the wait ends;
        // the ranges match the geometries.
        unsafe {
            ctx.accel.cmd_build_acceleration_structures(cmd, &[info], &[&ranges]);
            let barrier = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR)
                .dst_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR);
            ctx.device.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR | vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                vk::DependencyFlags::empty(),
                &[barrier],
                &[],
                &[],
            );
        }
    })?;
    drop(scratch);
    Ok(accel)
}

/// A geometry acceleration structure (bottom level) over triangles.
#[derive(Clone)]
pub struct Gas {
    inner: Arc<AccelStructure>,
}

impl Gas {
    /// Builds a GAS over triangles: `vertices`, and `indices` (three per
    /// triangle) or, when `None`, every three consecutive vertices.
    pub fn triangles(ctx: &Context, vertices: &[Vec3], indices: Option<&[u32]>) -> Result<Gas> {
        let inner = &ctx.inner;
        if vertices.is_empty() {
            return Err(Error::Geometry("no vertices: a GAS needs at least one triangle".to_owned()));
        }
        if let Some(i) = vertices.iter().position(|v| !v.is_finite()) {
            return Err(Error::Geometry(format!("vertex {i} is not finite: {:?}", vertices[i])));
        }
        let triangle_count = match indices {
            Some(indices) => {
                if indices.is_empty() || indices.len() % 3 != 0 {
                    return Err(Error::Geometry(format!(
                        "{} indices is not a positive multiple of 3 (three per triangle)",
                        indices.len()
                    )));
                }
                if let Some(i) = indices.iter().position(|&ix| ix as usize >= vertices.len()) {
                    return Err(Error::Geometry(format!(
                        "index {i} is {}, out of range for {} vertices",
                        indices[i],
                        vertices.len()
                    )));
                }
                indices.len() / 3
            }
            None => {
                if vertices.len() % 3 != 0 {
                    return Err(Error::Geometry(format!(
                        "{} vertices without indices is not a multiple of 3 (three per triangle)",
                        vertices.len()
                    )));
                }
                vertices.len() / 3
            }
        };
        if triangle_count as u64 > inner.limits.max_primitive_count {
            return Err(Error::Geometry(format!(
                "{triangle_count} triangles exceed this device's maxPrimitiveCount {}",
                inner.limits.max_primitive_count
            )));
        }
        let input_usage = vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR;
        let vertex_data: Vec<[f32; 3]> = vertices.iter().map(|v| v.to_array()).collect();
        let vertex_bytes: &[u8] = bytemuck::cast_slice(&vertex_data);
        let mut vertex_buffer =
            RawBuffer::new(inner, "GAS vertices", vertex_bytes.len() as u64, input_usage, MemoryLocation::CpuToGpu, 16)?;
        vertex_buffer.write_bytes(vertex_bytes)?;
        let index_buffer = match indices {
            Some(indices) => {
                let bytes: &[u8] = bytemuck::cast_slice(indices);
                let mut b = RawBuffer::new(inner, "GAS indices", bytes.len() as u64, input_usage, MemoryLocation::CpuToGpu, 16)?;
                b.write_bytes(bytes)?;
                Some(b)
            }
            None => None,
        };
        let mut triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR { device_address: vertex_buffer.address })
            .vertex_stride(12)
            .max_vertex(vertices.len() as u32 - 1)
            .index_type(vk::IndexType::NONE_KHR);
        if let Some(b) = &index_buffer {
            triangles = triangles
                .index_type(vk::IndexType::UINT32)
                .index_data(vk::DeviceOrHostAddressConstKHR { device_address: b.address });
        }
        let geometry = vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })
            .flags(vk::GeometryFlagsKHR::OPAQUE);
        let accel = build(inner, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, &[geometry], &[triangle_count as u32])?;
        drop(vertex_buffer);
        drop(index_buffer);
        Ok(Gas { inner: Arc::new(accel) })
    }
}

/// One instance of a [`Gas`] in an [`Ias`].
#[derive(Clone)]
pub struct Instance {
    /// The geometry.
    pub gas: Gas,
    /// Object-to-world transform.
    pub transform: Affine3A,
    /// `optixGetInstanceId`-style custom index (24 bits).
    pub custom_index: u32,
    /// Visibility mask tested against the ray's cull mask (8 bits).
    pub mask: u8,
    /// Offset of this instance's hit records in the SBT (24 bits).
    pub sbt_offset: u32,
}

impl Instance {
    /// `gas` at the identity transform, mask 0xff, offset 0.
    pub fn new(gas: &Gas) -> Instance {
        Instance { gas: gas.clone(), transform: Affine3A::IDENTITY, custom_index: 0, mask: 0xff, sbt_offset: 0 }
    }
}

/// An instance acceleration structure (top level): what device programs trace.
pub struct Ias {
    accel: AccelStructure,
    _instances: Vec<Gas>,
}

impl Ias {
    /// An IAS over one instance of `gas` at the identity transform.
    pub fn single(ctx: &Context, gas: &Gas) -> Result<Ias> {
        Ias::new(ctx, &[Instance::new(gas)])
    }

    /// An IAS over `instances`.
    pub fn new(ctx: &Context, instances: &[Instance]) -> Result<Ias> {
        let inner = &ctx.inner;
        if instances.is_empty() {
            return Err(Error::Geometry("no instances: an IAS needs at least one".to_owned()));
        }
        if instances.len() as u64 > inner.limits.max_instance_count {
            return Err(Error::Geometry(format!(
                "{} instances exceed this device's maxInstanceCount {}",
                instances.len(),
                inner.limits.max_instance_count
            )));
        }
        for (i, instance) in instances.iter().enumerate() {
            if !Arc::ptr_eq(&instance.gas.inner.ctx, inner) {
                return Err(Error::ContextMismatch);
            }
            if instance.custom_index >= 1 << 24 || instance.sbt_offset >= 1 << 24 {
                return Err(Error::Geometry(format!("instance {i}: custom_index and sbt_offset must fit in 24 bits")));
            }
            if !instance.transform.is_finite() {
                return Err(Error::Geometry(format!("instance {i}: transform is not finite")));
            }
        }
        let records: Vec<vk::AccelerationStructureInstanceKHR> = instances
            .iter()
            .map(|instance| {
                let m = instance.transform;
                let (x, y, z, t) = (m.matrix3.x_axis, m.matrix3.y_axis, m.matrix3.z_axis, m.translation);
                vk::AccelerationStructureInstanceKHR {
                    transform: vk::TransformMatrixKHR {
                        matrix: [x.x, y.x, z.x, t.x, x.y, y.y, z.y, t.y, x.z, y.z, z.z, t.z],
                    },
                    instance_custom_index_and_mask: vk::Packed24_8::new(instance.custom_index, instance.mask),
                    instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(instance.sbt_offset, 0),
                    acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
                        device_handle: instance.gas.inner.address,
                    },
                }
            })
            .collect();
        // SAFETY: `AccelerationStructureInstanceKHR` is plain data (floats, packed
        // integers and a u64 address) with no padding: 64 bytes.
        let bytes = unsafe {
            std::slice::from_raw_parts(
                records.as_ptr() as *const u8,
                records.len() * std::mem::size_of::<vk::AccelerationStructureInstanceKHR>(),
            )
        };
        let mut instance_buffer = RawBuffer::new(
            inner,
            "IAS instances",
            bytes.len() as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
            MemoryLocation::CpuToGpu,
            16,
        )?;
        instance_buffer.write_bytes(bytes)?;
        let geometry = vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::INSTANCES)
            .geometry(vk::AccelerationStructureGeometryDataKHR {
                instances: vk::AccelerationStructureGeometryInstancesDataKHR::default()
                    .array_of_pointers(false)
                    .data(vk::DeviceOrHostAddressConstKHR { device_address: instance_buffer.address }),
            });
        let accel = build(inner, vk::AccelerationStructureTypeKHR::TOP_LEVEL, &[geometry], &[records.len() as u32])?;
        drop(instance_buffer);
        Ok(Ias { accel, _instances: instances.iter().map(|i| i.gas.clone()).collect() })
    }

    /// The handle device programs trace against (put it in the launch params).
    pub fn handle(&self) -> Traversable {
        Traversable::from_device_address(self.accel.address)
    }
}
