//! IAS builds on Vulkan: instance records (`VkAccelerationStructureInstanceKHR`)
//! uploaded, top-level builds and refits recorded (see [`Ias`](crate::Ias)).

use std::sync::Arc;

use ash::vk;

use super::build::{self, Geometry, InputPacker, Job};
use super::structure::AccelStructure;
use crate::error::Result;
use crate::types::accel::{AccelSizes, BuildOptions, InstancePlacement};
use crate::vulkan::context::ContextInner;
use crate::vulkan::conv;

const TOP: vk::AccelerationStructureTypeKHR = vk::AccelerationStructureTypeKHR::TOP_LEVEL;

/// The device record of an instance placing the GAS at device address `gas`.
fn record(&(placement, gas): &(InstancePlacement, u64)) -> vk::AccelerationStructureInstanceKHR {
    vk::AccelerationStructureInstanceKHR {
        transform: vk::TransformMatrixKHR { matrix: placement.transform },
        instance_custom_index_and_mask: vk::Packed24_8::new(placement.custom_index, placement.mask),
        instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
            placement.sbt_offset,
            conv::instance_flags(placement.flags),
        ),
        acceleration_structure_reference: vk::AccelerationStructureReferenceKHR { device_handle: gas },
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
    instances: &[(InstancePlacement, u64)],
    options: BuildOptions,
) -> Result<(AccelStructure, AccelSizes, build::InFlight)> {
    let records: Vec<_> = instances.iter().map(record).collect();
    let (buffer, geometry) = upload(inner, &records)?;
    let counts = [records.len() as u32];
    let sizes = build::query_sizes(inner, TOP, conv::build_flags(options), &[geometry], &counts);
    let accel = AccelStructure::new(inner, TOP, sizes.structure)?;
    let job = Job {
        ty: TOP,
        flags: conv::build_flags(options),
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
pub(crate) fn refit(
    accel: &AccelStructure,
    instances: &[(InstancePlacement, u64)],
    options: BuildOptions,
) -> Result<()> {
    let (ctx, handle) = (&accel.ctx, accel.handle);
    let records: Vec<_> = instances.iter().map(record).collect();
    let (buffer, geometry) = upload(ctx, &records)?;
    let counts = [records.len() as u32];
    let sizes = build::query_sizes(ctx, TOP, conv::build_flags(options), &[geometry], &counts);
    let job = Job {
        ty: TOP,
        flags: conv::build_flags(options),
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
