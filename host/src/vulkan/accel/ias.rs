//! IAS builds on Vulkan: instance records (`VkAccelerationStructureInstanceKHR`)
//! uploaded, top-level builds and refits recorded (see [`crate::accel::ias`]).

use std::sync::Arc;

use ash::vk;

use crate::accel::gas::GasAccel;
use crate::accel::Instance;
use crate::accel::{AccelSizes, BuildOptions};
use crate::context::ContextInner;
use crate::error::Result;
use crate::vulkan::accel::build::{self, Geometry, InputPacker, Job};
use crate::vulkan::accel::structure::AccelStructure;

const TOP: vk::AccelerationStructureTypeKHR = vk::AccelerationStructureTypeKHR::TOP_LEVEL;

/// `VK_GEOMETRY_INSTANCE_TRIANGLE_FACING_CULL_DISABLE_BIT_KHR`, as [`crate::InstanceFlags`] holds it.
pub(crate) const TRIANGLE_FACING_CULL_DISABLE: u8 =
    vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE.as_raw() as u8;
/// `VK_GEOMETRY_INSTANCE_TRIANGLE_FLIP_FACING_BIT_KHR`.
pub(crate) const TRIANGLE_FLIP_FACING: u8 = vk::GeometryInstanceFlagsKHR::TRIANGLE_FLIP_FACING.as_raw() as u8;
/// `VK_GEOMETRY_INSTANCE_FORCE_OPAQUE_BIT_KHR`.
pub(crate) const FORCE_OPAQUE: u8 = vk::GeometryInstanceFlagsKHR::FORCE_OPAQUE.as_raw() as u8;
/// `VK_GEOMETRY_INSTANCE_FORCE_NO_OPAQUE_BIT_KHR`.
pub(crate) const FORCE_NO_OPAQUE: u8 = vk::GeometryInstanceFlagsKHR::FORCE_NO_OPAQUE.as_raw() as u8;

/// The device record of `instance` (checked).
fn record(instance: &Instance) -> vk::AccelerationStructureInstanceKHR {
    vk::AccelerationStructureInstanceKHR {
        transform: vk::TransformMatrixKHR { matrix: instance.transform },
        instance_custom_index_and_mask: vk::Packed24_8::new(instance.custom_index, instance.mask),
        instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
            instance.sbt_offset,
            instance.flags.0,
        ),
        acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
            device_handle: match &instance.accel {
                GasAccel::Vulkan(accel) => accel.address,
                GasAccel::Cpu(_) => 0,
            },
        },
    }
}

/// Uploads instance records; returns the buffer and the geometry naming it.
fn upload(
    ctx: &Arc<ContextInner>,
    records: &[vk::AccelerationStructureInstanceKHR],
) -> Result<(crate::vulkan::memory::RawBuffer, Geometry)> {
    // SAFETY: `AccelerationStructureInstanceKHR` is plain data (floats, packed
    // integers and a u64 address) with no padding: 64 bytes each.
    let bytes = unsafe { std::slice::from_raw_parts(records.as_ptr() as *const u8, std::mem::size_of_val(records)) };
    let mut packer = InputPacker::default();
    let at = packer.push(bytes, 16);
    let buffer = packer.upload(ctx, "IAS instances")?;
    let geometry = Geometry::Instances { data: buffer.address + at };
    Ok((buffer, geometry))
}

/// Uploads the records of validated `instances`, creates the structure and
/// submits its build; returns the structure, its sizes and the work in flight.
pub(crate) fn submit(
    inner: &Arc<ContextInner>,
    instances: &[Instance],
    options: BuildOptions,
) -> Result<(AccelStructure, AccelSizes, build::InFlight)> {
    let records: Vec<_> = instances.iter().map(record).collect();
    let (buffer, geometry) = upload(inner, &records)?;
    let counts = [records.len() as u32];
    let sizes = build::query_sizes(inner, TOP, options.vk_flags(), &[geometry], &counts);
    let accel = AccelStructure::new(inner, TOP, sizes.structure)?;
    let job = Job {
        ty: TOP,
        flags: options.vk_flags(),
        update_from: None,
        dst: accel.handle,
        geometries: vec![geometry],
        counts: counts.to_vec(),
        scratch: sizes.build_scratch,
        query_compacted: false,
    };
    let in_flight = build::submit(inner, &[job], vec![buffer])?;
    Ok((accel, sizes, in_flight))
}

/// Refits `accel` in place to validated `instances` (as many as it was built over) and waits.
pub(crate) fn refit(accel: &AccelStructure, instances: &[Instance], options: BuildOptions) -> Result<()> {
    let (ctx, handle) = (&accel.ctx, accel.handle);
    let records: Vec<_> = instances.iter().map(record).collect();
    let (buffer, geometry) = upload(ctx, &records)?;
    let counts = [records.len() as u32];
    let sizes = build::query_sizes(ctx, TOP, options.vk_flags(), &[geometry], &counts);
    let job = Job {
        ty: TOP,
        flags: options.vk_flags(),
        update_from: Some(handle),
        dst: handle,
        geometries: vec![geometry],
        counts: counts.to_vec(),
        scratch: sizes.update_scratch,
        query_compacted: false,
    };
    build::submit(ctx, &[job], vec![buffer])?.wait()?;
    Ok(())
}
