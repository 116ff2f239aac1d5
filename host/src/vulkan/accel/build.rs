//! Recording and submitting builds: uploads inputs, shares one scratch buffer
//! among the builds of a batch, records them into one command buffer
//! ([`vkCmdBuildAccelerationStructuresKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdBuildAccelerationStructuresKHR.html)
//! with several infos), and returns the work in flight to wait on; input and
//! scratch memory is released when it has been waited on.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::ResourceError;
use crate::error::{Error, Result};
use crate::types::accel::transform_rows;
use crate::types::accel::AccelSizes;
use crate::types::accel::{BuildInput, Shape};
use crate::vulkan::barrier::memory_barrier;
use crate::vulkan::context::ContextInner;
use crate::vulkan::context::Submission;
use crate::vulkan::conv;
use crate::vulkan::memory::RawBuffer;

/// A geometry whose data is on the device: what `VkAccelerationStructureGeometryKHR` needs.
#[derive(Copy, Clone, Debug)]
pub(crate) enum Geometry {
    Triangles {
        vertices: u64,
        stride: u64,
        max_vertex: u32,
        index_type: vk::IndexType,
        indices: u64,
        transform: u64,
        flags: vk::GeometryFlagsKHR,
    },
    Aabbs {
        data: u64,
        stride: u64,
        flags: vk::GeometryFlagsKHR,
    },
    Instances {
        data: u64,
    },
}

impl Geometry {
    pub(crate) fn vk(&self) -> vk::AccelerationStructureGeometryKHR<'static> {
        let address = |a: u64| vk::DeviceOrHostAddressConstKHR { device_address: a };
        match *self {
            Geometry::Triangles { vertices, stride, max_vertex, index_type, indices, transform, flags } => {
                vk::AccelerationStructureGeometryKHR::default()
                    .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
                    .geometry(vk::AccelerationStructureGeometryDataKHR {
                        triangles: vk::AccelerationStructureGeometryTrianglesDataKHR::default()
                            .vertex_format(vk::Format::R32G32B32_SFLOAT)
                            .vertex_data(address(vertices))
                            .vertex_stride(stride)
                            .max_vertex(max_vertex)
                            .index_type(index_type)
                            .index_data(address(indices))
                            .transform_data(address(transform)),
                    })
                    .flags(flags)
            }
            Geometry::Aabbs { data, stride, flags } => vk::AccelerationStructureGeometryKHR::default()
                .geometry_type(vk::GeometryTypeKHR::AABBS)
                .geometry(vk::AccelerationStructureGeometryDataKHR {
                    aabbs: vk::AccelerationStructureGeometryAabbsDataKHR::default().data(address(data)).stride(stride),
                })
                .flags(flags),
            Geometry::Instances { data } => vk::AccelerationStructureGeometryKHR::default()
                .geometry_type(vk::GeometryTypeKHR::INSTANCES)
                .geometry(vk::AccelerationStructureGeometryDataKHR {
                    instances: vk::AccelerationStructureGeometryInstancesDataKHR::default()
                        .array_of_pointers(false)
                        .data(address(data)),
                }),
        }
    }
}

/// Lays byte ranges out in one host-visible input buffer, each aligned, and
/// copies each once, straight into the mapped memory.
#[derive(Default)]
pub(crate) struct InputPacker<'a> {
    parts: Vec<(u64, std::borrow::Cow<'a, [u8]>)>,
    len: u64,
}

impl<'a> InputPacker<'a> {
    /// Places `data` at the next multiple of `align`; returns its offset.
    pub(crate) fn push(&mut self, data: impl Into<std::borrow::Cow<'a, [u8]>>, align: u64) -> u64 {
        let data = data.into();
        let at = self.len.div_ceil(align) * align;
        self.len = at + data.len() as u64;
        self.parts.push((at, data));
        at
    }

    /// Allocates the buffer and copies every range; address + offset is each range's address.
    pub(crate) fn upload(self, ctx: &Arc<ContextInner>, what: &'static str) -> Result<RawBuffer> {
        let mut buffer = RawBuffer::new(
            ctx,
            what,
            self.len.max(16),
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
            MemoryLocation::CpuToGpu,
            16,
        )?;
        let mapped = buffer.mapped_mut().ok_or(Error::Resource(ResourceError::BufferSize {
            len: self.len as usize,
            element_size: 1,
            reason: "the build-input buffer is not host-visible",
        }))?;
        for (at, data) in &self.parts {
            mapped[*at as usize..*at as usize + data.len()].copy_from_slice(data);
        }
        Ok(buffer)
    }
}

/// Uploads validated GAS inputs into one buffer; returns it and the geometries
/// pointing into it.
pub(crate) fn upload_gas_inputs<'a>(
    ctx: &Arc<ContextInner>,
    inputs: &[BuildInput<'a>],
    shapes: &[Shape],
) -> Result<(RawBuffer, Vec<Geometry>)> {
    // Offsets first, addresses once the buffer exists.
    enum Pending {
        Triangles {
            vertices: u64,
            stride: u64,
            max_vertex: u32,
            index_type: vk::IndexType,
            indices: Option<u64>,
            transform: Option<u64>,
            flags: vk::GeometryFlagsKHR,
        },
        Aabbs {
            data: u64,
            stride: u64,
            flags: vk::GeometryFlagsKHR,
        },
    }
    let mut packer = InputPacker::default();
    let mut pending = Vec::with_capacity(inputs.len());
    for (input, shape) in inputs.iter().zip(shapes) {
        match input {
            BuildInput::Triangles(t) => {
                let used = ((t.vertex_count as u64 - 1) * t.stride + 12) as usize;
                let vertices = packer.push(&t.vertex_bytes[..used], 16);
                let indices = match t.indices.bytes() {
                    [] => None,
                    bytes => Some(packer.push(bytes, 16)),
                };
                let transform = t.transform.map(|m| {
                    let rows = transform_rows(&m);
                    packer.push(bytemuck::cast_slice::<f32, u8>(&rows).to_vec(), 16)
                });
                let index_type = match shape {
                    Shape::Triangles { index, .. } => conv::index_type(*index),
                    Shape::Aabbs { .. } => vk::IndexType::NONE_KHR,
                };
                pending.push(Pending::Triangles {
                    vertices,
                    stride: t.stride,
                    max_vertex: t.vertex_count as u32 - 1,
                    index_type,
                    indices,
                    transform,
                    flags: conv::geometry_flags(t.flags),
                });
            }
            BuildInput::Aabbs(a) => {
                let used = ((a.count as u64 - 1) * a.stride + 24) as usize;
                let data = packer.push(&a.bytes[..used], 16);
                pending.push(Pending::Aabbs { data, stride: a.stride, flags: conv::geometry_flags(a.flags) });
            }
        }
    }
    let buffer = packer.upload(ctx, "GAS build inputs")?;
    let base = buffer.address;
    let geometries = pending
        .into_iter()
        .map(|p| match p {
            Pending::Triangles { vertices, stride, max_vertex, index_type, indices, transform, flags } => {
                Geometry::Triangles {
                    vertices: base + vertices,
                    stride,
                    max_vertex,
                    index_type,
                    indices: indices.map_or(0, |o| base + o),
                    transform: transform.map_or(0, |o| base + o),
                    flags,
                }
            }
            Pending::Aabbs { data, stride, flags } => Geometry::Aabbs { data: base + data, stride, flags },
        })
        .collect();
    Ok((buffer, geometries))
}

/// Queries the sizes a build of `geometries` needs.
pub(crate) fn query_sizes(
    ctx: &ContextInner,
    ty: vk::AccelerationStructureTypeKHR,
    flags: vk::BuildAccelerationStructureFlagsKHR,
    geometries: &[Geometry],
    counts: &[u32],
) -> AccelSizes {
    let vk_geometries: Vec<_> = geometries.iter().map(Geometry::vk).collect();
    let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(ty)
        .flags(flags)
        .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        .geometries(&vk_geometries);
    let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
    // SAFETY: `info` describes validated geometry (addresses are ignored by the
    // query); `counts` has one entry per geometry.
    unsafe {
        ctx.accel.get_acceleration_structure_build_sizes(
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            &info,
            counts,
            &mut sizes,
        )
    };
    AccelSizes {
        structure: sizes.acceleration_structure_size,
        build_scratch: sizes.build_scratch_size,
        update_scratch: sizes.update_scratch_size,
    }
}

/// One build or update to record.
pub(crate) struct Job {
    pub(crate) ty: vk::AccelerationStructureTypeKHR,
    pub(crate) flags: vk::BuildAccelerationStructureFlagsKHR,
    /// `Some(src)` for an update (in place when `src == dst`).
    pub(crate) update_from: Option<vk::AccelerationStructureKHR>,
    pub(crate) dst: vk::AccelerationStructureKHR,
    pub(crate) geometries: Vec<Geometry>,
    pub(crate) counts: Vec<u32>,
    pub(crate) scratch: u64,
    /// Query the compacted size after the build.
    pub(crate) query_compacted: bool,
}

/// A query pool, destroyed on drop.
pub(crate) struct QueryPool {
    ctx: Arc<ContextInner>,
    pub(crate) pool: vk::QueryPool,
    count: u32,
}

impl QueryPool {
    pub(crate) fn compacted_sizes(ctx: &Arc<ContextInner>, count: u32) -> Result<QueryPool> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR)
            .query_count(count);
        // SAFETY: valid create info on a live device.
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }.map_err(Error::vk("vkCreateQueryPool"))?;
        Ok(QueryPool { ctx: ctx.clone(), pool, count })
    }

    /// The results, once the submission that wrote them has finished.
    pub(crate) fn results(&self) -> Result<Vec<u64>> {
        let mut data = vec![0u64; self.count as usize];
        // SAFETY: every query was reset and written by a finished submission; the
        // slice holds one u64 per query.
        unsafe {
            self.ctx.device.get_query_pool_results(
                self.pool,
                0,
                &mut data,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(Error::vk("vkGetQueryPoolResults"))?;
        Ok(data)
    }
}

impl Drop for QueryPool {
    fn drop(&mut self) {
        // Destroyed once the submission writing it has finished.
        self.ctx.retire(crate::vulkan::timeline::Retired::QueryPool(self.pool));
    }
}

/// The memory barrier after builds: their writes are visible to later builds,
/// copies, queries and ray-tracing shaders.
pub(crate) fn build_barrier(ctx: &ContextInner, cmd: vk::CommandBuffer) {
    // SAFETY: `cmd` is in the recording state.
    unsafe {
        memory_barrier(
            &ctx.device,
            cmd,
            vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
            vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
            vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR | vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
            vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR | vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
        )
    };
}

/// The memory barrier before builds, refits and copies: they start only after
/// earlier submissions (launches that trace the structures among them) have
/// finished reading and writing, so a refit never changes a structure under a
/// trace in flight.
pub(crate) fn after_earlier_work_barrier(ctx: &ContextInner, cmd: vk::CommandBuffer) {
    // SAFETY: `cmd` is in the recording state.
    unsafe {
        memory_barrier(
            &ctx.device,
            cmd,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE,
            vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
            vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR | vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
        )
    };
}

/// The in-flight part of a build: the submission and what it uses.
pub(crate) struct InFlight {
    // Field order matters: the submission (which waits when dropped) goes first.
    submission: Submission,
    _buffers: Vec<RawBuffer>,
    queries: Option<QueryPool>,
}

/// Records `jobs` into one command buffer with one shared scratch buffer and
/// submits them. `buffers` (the inputs) stay alive until the work finished.
pub(crate) fn submit(ctx: &Arc<ContextInner>, jobs: &[Job], mut buffers: Vec<RawBuffer>) -> Result<InFlight> {
    let align = (ctx.limits.min_scratch_alignment as u64).max(1);
    let mut offsets = Vec::with_capacity(jobs.len());
    let mut total = 0u64;
    for job in jobs {
        total = total.div_ceil(align) * align;
        offsets.push(total);
        total += job.scratch.max(1);
    }
    let scratch = RawBuffer::new(
        ctx,
        "acceleration structure scratch",
        total.max(1),
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuOnly,
        align,
    )?;
    let query_count = jobs.iter().filter(|j| j.query_compacted).count() as u32;
    let queries = if query_count > 0 { Some(QueryPool::compacted_sizes(ctx, query_count)?) } else { None };

    let vk_geometries: Vec<Vec<vk::AccelerationStructureGeometryKHR<'static>>> =
        jobs.iter().map(|j| j.geometries.iter().map(Geometry::vk).collect()).collect();
    let infos: Vec<vk::AccelerationStructureBuildGeometryInfoKHR<'_>> = jobs
        .iter()
        .zip(&vk_geometries)
        .zip(&offsets)
        .map(|((job, geometries), &offset)| {
            let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(job.ty)
                .flags(job.flags)
                .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                .dst_acceleration_structure(job.dst)
                .geometries(geometries)
                .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch.address + offset });
            if let Some(src) = job.update_from {
                info = info.mode(vk::BuildAccelerationStructureModeKHR::UPDATE).src_acceleration_structure(src);
            }
            info
        })
        .collect();
    let ranges: Vec<Vec<vk::AccelerationStructureBuildRangeInfoKHR>> = jobs
        .iter()
        .map(|j| {
            j.counts.iter().map(|&c| vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(c)).collect()
        })
        .collect();
    let range_refs: Vec<&[vk::AccelerationStructureBuildRangeInfoKHR]> = ranges.iter().map(Vec::as_slice).collect();
    let compacted: Vec<vk::AccelerationStructureKHR> =
        jobs.iter().filter(|j| j.query_compacted).map(|j| j.dst).collect();

    let submission = ctx.submit("an acceleration structure build", |cmd| {
        // SAFETY: every buffer and structure `infos` names is alive until the
        // submission has finished (held by the returned `InFlight` and by the
        // caller's result); scratch ranges do not overlap; destinations are distinct.
        unsafe {
            after_earlier_work_barrier(ctx, cmd);
            if let Some(q) = &queries {
                ctx.device.cmd_reset_query_pool(cmd, q.pool, 0, q.count);
            }
            ctx.accel.cmd_build_acceleration_structures(cmd, &infos, &range_refs);
            build_barrier(ctx, cmd);
            if let Some(q) = &queries {
                ctx.accel.cmd_write_acceleration_structures_properties(
                    cmd,
                    &compacted,
                    vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                    q.pool,
                    0,
                );
            }
        }
    })?;
    buffers.push(scratch);
    Ok(InFlight { submission, _buffers: buffers, queries })
}

impl InFlight {
    /// Waits; returns the compacted sizes queried, in job order of the jobs that asked.
    pub(crate) fn wait(mut self) -> Result<Vec<u64>> {
        self.submission.wait()?;
        match &self.queries {
            Some(q) => q.results(),
            None => Ok(Vec::new()),
        }
    }

    pub(crate) fn is_done(&self) -> Result<bool> {
        self.submission.is_done()
    }
}
