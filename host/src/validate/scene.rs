//! The SBT fits the scene: every launch checks that no instance of the scenes in
//! its params can select a hit record past the end of the SBT's hit region.
//!
//! Vulkan selects the hit record
//! `instanceShaderBindingTableRecordOffset + geometryIndex × sbtRecordStride + sbtRecordOffset`
//! ("Hit Shaders" in the SBT chapter of the specification); past the region's
//! end the device reads whatever lies there. For each [`Traversable`](raykit_device::Traversable)
//! field of the params that names a live [`Ias`](crate::Ias), raykit takes the
//! instance reaching furthest — its [`Instance::sbt_offset`](crate::Instance::sbt_offset)
//! plus (the geometries of its GAS − 1) × the stride — plus the ray-type offset,
//! for each `(stride, offset)` pair the pipeline's traces use, and refuses the
//! launch with [`Error::SbtTooSmallForScene`] when that record index is not
//! below the SBT's hit record count.
//!
//! What is assumed:
//! * the strides and offsets are the constant operands of the pipeline's
//!   `OpTraceRayKHR` calls, read from the SPIR-V (their low 4 bits, as Vulkan
//!   reads them); a trace whose stride or offset is computed at run time is
//!   assumed to use those of the ray types the pipeline's miss and hit programs
//!   were declared for (`#[closest_hit(ray = R)]`), and goes unchecked when
//!   there are none (programs in GLSL or WGSL with a computed offset);
//! * on the CPU backend, where there is no SPIR-V to read, every raygen, miss,
//!   closest-hit and callable program is assumed to trace those declared ray
//!   types, so the same launches are refused on both backends;
//! * an instance with a mask of 0 is never hit, and selects nothing;
//! * every ray may hit every other instance: cull masks and flags are not
//!   taken into account;
//! * an SBT without hit records (a pipeline without hit groups) has nothing to
//!   overrun: Vulkan then runs no hit programs.
//!
//! Scenes reached otherwise than through the params (a traversable stored in a
//! buffer or an SBT record) are not seen, as for [`crate::validate::handles`].

use std::sync::Arc;

use crate::error::{Error, Result};
use crate::validate::handles::HandleField;
use crate::validate::TraceReach;

/// Refuses the launch of `params` (laid out as `fields` says) with an SBT of
/// `hit_records` hit records when an
/// instance of one of its scenes can select a hit record past the SBT's end, for
/// the traces `reach` describes; `hit_reach` gives what the live IAS at an
/// address can select (`None` for no live IAS: `check_handles` refuses those).
pub(crate) fn check_scene(
    hit_reach: impl Fn(u64) -> Option<Arc<HitReach>>,
    fields: &[HandleField],
    params: &[u8],
    hit_records: usize,
    reach: &TraceReach,
) -> Result<()> {
    if hit_records == 0 || reach.hit_selectors.is_empty() {
        return Ok(());
    }
    for (offset, name) in fields.iter().filter_map(HandleField::traversable) {
        let Some(address) = crate::validate::handles::read_traversable(params, offset) else { continue };
        if address == 0 {
            continue;
        }
        // Not a live IAS: `check_handles` refuses it.
        let Some(scene) = hit_reach(address) else { continue };
        for (stride, ray_offset, program) in &reach.hit_selectors {
            let Some((instance, slot)) = scene.furthest(*stride, *ray_offset) else { continue };
            if slot >= hit_records as u64 {
                let (sbt_offset, geometries) = scene.instance(instance);
                return Err(Error::SbtTooSmallForScene {
                    field: name.to_owned(),
                    instance,
                    sbt_offset,
                    geometries,
                    stride: *stride,
                    ray_offset: *ray_offset,
                    slot,
                    hit_records,
                    program: program.clone(),
                });
            }
        }
    }
    Ok(())
}

/// What an IAS's instances can select in the SBT's hit region: Vulkan's hit
/// record index is `instance SBT offset + geometry index × sbtRecordStride +
/// sbtRecordOffset`, with the stride and offset of the trace (4 bits each).
#[derive(Debug, Default)]
pub(crate) struct HitReach {
    /// Per instance: its SBT offset and geometry count.
    instances: Vec<(u32, u32)>,
    /// For each stride `s` in `0..16`: the instance (by index) with the largest
    /// `sbt_offset + (geometries − 1) × s`, and that value.
    by_stride: [Option<(usize, u64)>; 16],
}

impl HitReach {
    /// The reach of instances given as `(SBT offset, geometry count, mask)`.
    pub(crate) fn from_parts(instances: impl Iterator<Item = (u32, u32, u8)>) -> HitReach {
        let parts: Vec<(u32, u32, u8)> = instances.collect();
        let mut by_stride = [None; 16];
        for (stride, best) in by_stride.iter_mut().enumerate() {
            for (i, &(offset, geometries, mask)) in parts.iter().enumerate() {
                if mask == 0 {
                    continue;
                }
                let last = u64::from(offset) + u64::from(geometries.saturating_sub(1)) * stride as u64;
                if best.is_none_or(|(_, b)| last > b) {
                    *best = Some((i, last));
                }
            }
        }
        HitReach { instances: parts.iter().map(|&(o, g, _)| (o, g)).collect(), by_stride }
    }

    /// The instance reaching the highest hit record for traces with `stride` and
    /// `ray_offset` (their low 4 bits, as Vulkan reads them), and that record's index.
    pub(crate) fn furthest(&self, stride: u32, ray_offset: u32) -> Option<(usize, u64)> {
        let (instance, last) = self.by_stride[(stride & 0xf) as usize]?;
        Some((instance, last + u64::from(ray_offset & 0xf)))
    }

    /// Instance `index`'s SBT offset and geometry count.
    pub(crate) fn instance(&self, index: usize) -> (u32, u32) {
        self.instances.get(index).copied().unwrap_or((0, 0))
    }
}

#[cfg(test)]
mod hit_reach_tests {
    use super::HitReach;

    #[test]
    fn the_furthest_instance_depends_on_the_stride_and_masked_out_ones_reach_nothing() {
        // (offset, geometries, mask): a far offset with one geometry, a near one
        // with many, and a masked-out one further than both.
        let reach = HitReach::from_parts([(10, 1, 0xff), (2, 6, 0xff), (100, 1, 0)].into_iter());
        // Stride 1: 10 against 2 + 5 = 7.
        assert_eq!(reach.furthest(1, 0), Some((0, 10)));
        // Stride 2 with ray offset 1: 10 + 1 against 2 + 10 + 1.
        assert_eq!(reach.furthest(2, 1), Some((1, 13)));
        // Vulkan reads 4 bits of each: stride 18 is stride 2, offset 17 is 1.
        assert_eq!(reach.furthest(18, 17), Some((1, 13)));
        assert_eq!(reach.instance(1), (2, 6));
        assert_eq!(HitReach::from_parts([(5, 1, 0)].into_iter()).furthest(1, 0), None);
    }
}
