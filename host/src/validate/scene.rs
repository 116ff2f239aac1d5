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
//! launch with [`LaunchError::SbtTooSmallForScene`](crate::LaunchError::SbtTooSmallForScene) when that record index is not
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
//! The same launches check that every hit record an instance selects holds a
//! hit group of its geometry's kind: a procedural one (with an intersection
//! program) for AABBs, a triangles one for triangles
//! ([`LaunchError::HitGroupKind`](crate::LaunchError::HitGroupKind); Vulkan leaves
//! the other kind undefined). This costs nothing more when the SBT's hit groups
//! are all of the one kind the scene's geometry has; otherwise it looks at one
//! record per geometry of each hittable instance, per `(stride, offset)` pair.
//!
//! Scenes reached otherwise than through the params (a traversable stored in a
//! buffer or an SBT record) are not seen, as for [`crate::validate::handles`].

use std::sync::Arc;

use crate::error::LaunchError;
use crate::error::{Error, Result};
use crate::validate::handles::HandleField;
use crate::validate::hit_reach::HitReach;
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
    hit_kinds: &crate::validate::records::HitKinds,
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
                return Err(Error::Launch(LaunchError::SbtTooSmallForScene {
                    field: name.to_owned(),
                    instance,
                    sbt_offset,
                    geometries,
                    stride: *stride,
                    ray_offset: *ray_offset,
                    slot,
                    hit_records,
                    program: program.clone(),
                }));
            }
            if let Some((instance, geometry, slot, procedural)) = scene.kind_mismatch(hit_kinds, *stride, *ray_offset) {
                return Err(Error::Launch(LaunchError::HitGroupKind {
                    field: name.to_owned(),
                    instance,
                    geometry,
                    aabbs: procedural,
                    slot,
                    stride: *stride,
                    ray_offset: *ray_offset,
                    program: program.clone(),
                }));
            }
        }
    }
    Ok(())
}
