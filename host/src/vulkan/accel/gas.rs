//! GAS builds on Vulkan: inputs uploaded, sizes queried, bottom-level builds
//! and refits recorded, and compaction (see [`Gas`](crate::Gas)).

use std::sync::Arc;

use ash::vk;

use crate::error::Result;
use crate::types::accel::{AccelSizes, BuildOptions};
use crate::types::accel::{BuildInput, Shape};
use crate::vulkan::accel::build::{self, Geometry, Job};
use crate::vulkan::accel::structure::AccelStructure;
use crate::vulkan::context::ContextInner;
use crate::vulkan::conv;
use crate::vulkan::memory::RawBuffer;

const BOTTOM: vk::AccelerationStructureTypeKHR = vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL;

/// A validated build, ready to record.
struct Prepared {
    shapes: Vec<Shape>,
    counts: Vec<u32>,
    input_buffer: RawBuffer,
    geometries: Vec<Geometry>,
    sizes: AccelSizes,
}

/// Uploads validated inputs and queries their sizes.
fn prepare(
    ctx: &Arc<ContextInner>,
    inputs: &[BuildInput<'_>],
    shapes: Vec<Shape>,
    options: BuildOptions,
) -> Result<Prepared> {
    let counts: Vec<u32> = shapes.iter().map(Shape::primitives).collect();
    let (input_buffer, geometries) = build::upload_gas_inputs(ctx, inputs, &shapes)?;
    let sizes = build::query_sizes(ctx, BOTTOM, conv::build_flags(options), &geometries, &counts);
    Ok(Prepared { shapes, counts, input_buffer, geometries, sizes })
}

/// The sizes a build of validated `inputs` (of `shapes`) needs, queried without
/// uploading anything.
pub(crate) fn sizes(
    ctx: &ContextInner,
    inputs: &[BuildInput<'_>],
    shapes: &[Shape],
    options: BuildOptions,
) -> AccelSizes {
    let counts: Vec<u32> = shapes.iter().map(Shape::primitives).collect();
    // The size query ignores addresses (only a transform's presence counts):
    // describe the geometry without uploading it.
    let geometries: Vec<Geometry> = inputs.iter().zip(shapes).map(|(i, s)| describe(i, s)).collect();
    build::query_sizes(ctx, BOTTOM, conv::build_flags(options), &geometries, &counts)
}

/// A geometry as the size query sees it: formats, counts and strides, no data.
fn describe(input: &BuildInput<'_>, shape: &Shape) -> Geometry {
    match input {
        BuildInput::Triangles(t) => Geometry::Triangles {
            vertices: 0,
            stride: t.stride,
            max_vertex: t.vertex_count.saturating_sub(1) as u32,
            index_type: match shape {
                Shape::Triangles { index, .. } => conv::index_type(*index),
                Shape::Aabbs { .. } => vk::IndexType::NONE_KHR,
            },
            indices: 0,
            transform: u64::from(t.transform.is_some()),
            flags: conv::geometry_flags(t.flags),
        },
        BuildInput::Aabbs(a) => Geometry::Aabbs { data: 0, stride: a.stride, flags: conv::geometry_flags(a.flags) },
    }
}

/// One GAS of a submitted batch: its structure, shapes and sizes.
pub(crate) struct Built {
    pub(crate) accel: AccelStructure,
    pub(crate) shapes: Vec<Shape>,
    pub(crate) sizes: AccelSizes,
}

/// Uploads and submits validated builds (inputs, shapes, options) in one command buffer.
pub(crate) fn submit<'i, 'a: 'i>(
    ctx: &Arc<ContextInner>,
    builds: impl ExactSizeIterator<Item = (&'i [BuildInput<'a>], Vec<Shape>, BuildOptions)>,
) -> Result<(build::InFlight, Vec<Built>)> {
    let mut built = Vec::with_capacity(builds.len());
    let mut jobs = Vec::with_capacity(builds.len());
    let mut buffers = Vec::with_capacity(builds.len());
    for (inputs, shapes, options) in builds {
        let p = prepare(ctx, inputs, shapes, options)?;
        let accel = AccelStructure::new(ctx, BOTTOM, p.sizes.structure)?;
        jobs.push(Job {
            ty: BOTTOM,
            flags: conv::build_flags(options),
            update_from: None,
            dst: accel.handle,
            geometries: p.geometries,
            counts: p.counts,
            scratch: p.sizes.build_scratch,
            query_compacted: options.allow_compaction,
        });
        buffers.push(p.input_buffer);
        built.push(Built { accel, shapes: p.shapes, sizes: p.sizes });
    }
    let in_flight = build::submit(ctx, &jobs, buffers)?;
    Ok((in_flight, built))
}

/// Refits `accel` in place to validated `inputs` (checked against its build) and waits.
pub(crate) fn refit(
    accel: &AccelStructure,
    inputs: &[BuildInput<'_>],
    shapes: Vec<Shape>,
    options: BuildOptions,
) -> Result<()> {
    let ctx = &accel.ctx;
    let p = prepare(ctx, inputs, shapes, options)?;
    let job = Job {
        ty: BOTTOM,
        flags: conv::build_flags(options),
        update_from: Some(accel.handle),
        dst: accel.handle,
        geometries: p.geometries,
        counts: p.counts,
        scratch: p.sizes.update_scratch,
        query_compacted: false,
    };
    build::submit(ctx, &[job], vec![p.input_buffer])?.wait()?;
    accel.version.fetch_add(1, std::sync::atomic::Ordering::AcqRel);
    Ok(())
}

/// Copies `accel` into a structure of its compacted size (`compacted_size`, or
/// queried again when `None`) and waits; returns the copy and that size.
pub(crate) fn compact(accel: &AccelStructure, compacted_size: Option<u64>) -> Result<(AccelStructure, u64)> {
    let ctx = accel.ctx.clone();
    let compacted_size = match compacted_size {
        Some(size) => size,
        None => {
            // Updated since the build: ask again.
            let pool = build::QueryPool::compacted_sizes(&ctx, 1)?;
            let handle = accel.handle;
            let mut submission = ctx.submit("a compacted-size query", |cmd| {
                // SAFETY: the structure is built and alive; the pool has one query.
                unsafe {
                    build::after_earlier_work_barrier(&ctx, cmd);
                    ctx.device.cmd_reset_query_pool(cmd, pool.pool, 0, 1);
                    ctx.accel.cmd_write_acceleration_structures_properties(
                        cmd,
                        &[handle],
                        vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                        pool.pool,
                        0,
                    );
                }
            })?;
            submission.wait()?;
            drop(submission);
            pool.results()?.first().copied().unwrap_or(accel.size)
        }
    };
    let compacted = AccelStructure::new(&ctx, BOTTOM, compacted_size.max(1))?;
    let info = vk::CopyAccelerationStructureInfoKHR::default()
        .src(accel.handle)
        .dst(compacted.handle)
        .mode(vk::CopyAccelerationStructureModeKHR::COMPACT);
    let mut submission = ctx.submit("an acceleration structure compaction", |cmd| {
        // SAFETY: both structures are alive until the wait below; the
        // destination is at least the queried compacted size.
        unsafe {
            build::after_earlier_work_barrier(&ctx, cmd);
            ctx.accel.cmd_copy_acceleration_structure(cmd, &info);
            build::build_barrier(&ctx, cmd);
        }
    })?;
    submission.wait()?;
    drop(submission);
    Ok((compacted, compacted_size))
}
