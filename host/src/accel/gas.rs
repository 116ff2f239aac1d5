//! Geometry acceleration structures (bottom level), OptiX's GAS: built from
//! [`BuildInput`]s with [`GasBuilder`], refitted with [`Gas::update`], compacted
//! with [`Gas::compact`] ([`vkCmdCopyAccelerationStructureKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdCopyAccelerationStructureKHR.html)
//! in `COMPACT` mode, after a
//! [compacted-size query](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdWriteAccelerationStructuresPropertiesKHR.html)).

use std::sync::Arc;

use ash::vk;
use glam::Vec3;

use super::input::{self, Aabb, Aabbs, BuildInput, Shape, Triangles};
use super::PendingBuild;
use super::{AccelSizes, BuildOptions};
use crate::context::{Context, ContextInner};
use crate::error::{Error, Result};
use crate::vulkan::accel::build::{self, Geometry, Job};
use crate::vulkan::accel::structure::AccelStructure;
use crate::vulkan::memory::RawBuffer;

const BOTTOM: vk::AccelerationStructureTypeKHR = vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL;

/// Sizes before and after [`Gas::compact`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct Compaction {
    /// Bytes of the structure as built.
    pub before: u64,
    /// Bytes of the compacted structure.
    pub after: u64,
}

/// A geometry acceleration structure (bottom level) over one or more geometries
/// of one kind (triangles or AABBs). Instance it in an [`Ias`](super::Ias) to
/// trace it.
pub struct Gas {
    pub(crate) accel: GasAccel,
    shapes: Vec<Shape>,
    options: BuildOptions,
    sizes: AccelSizes,
    compacted_size: Option<u64>,
    compaction: Option<Compaction>,
}

/// What a [`Gas`] is underneath.
#[derive(Clone)]
pub(crate) enum GasAccel {
    /// A Vulkan acceleration structure.
    Vulkan(Arc<AccelStructure>),
    /// A tree of the CPU backend.
    Cpu(Arc<crate::cpu::accel::CpuGas>),
}

impl GasAccel {
    /// The version every refit bumps (see [`crate::handles`]).
    pub(crate) fn version(&self) -> &Arc<std::sync::atomic::AtomicU64> {
        match self {
            GasAccel::Vulkan(accel) => &accel.version,
            GasAccel::Cpu(cpu) => &cpu.version,
        }
    }

    /// The context it was built on.
    pub(crate) fn context(&self) -> Context {
        match self {
            GasAccel::Vulkan(accel) => Context::from_vulkan(accel.ctx.clone()),
            GasAccel::Cpu(cpu) => Context::from_cpu(cpu.ctx.clone()),
        }
    }
}

/// Describes a GAS build: its inputs and options (OptiX's `OptixBuildInput`s and
/// `OptixAccelBuildOptions`).
#[must_use]
#[derive(Clone, Debug, Default)]
pub struct GasBuilder<'a> {
    inputs: Vec<BuildInput<'a>>,
    options: BuildOptions,
}

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
    let sizes = build::query_sizes(ctx, BOTTOM, options.vk_flags(), &geometries, &counts);
    Ok(Prepared { shapes, counts, input_buffer, geometries, sizes })
}

impl<'a> GasBuilder<'a> {
    /// Adds a geometry; its SBT index is the number of geometries added before it.
    pub fn input(mut self, input: impl Into<BuildInput<'a>>) -> Self {
        self.inputs.push(input.into());
        self
    }

    /// Adds a triangle geometry.
    pub fn triangles(self, triangles: Triangles<'a>) -> Self {
        self.input(triangles)
    }

    /// Adds an AABB geometry.
    pub fn aabbs(self, aabbs: Aabbs<'a>) -> Self {
        self.input(aabbs)
    }

    /// Sets the build options.
    pub fn options(mut self, options: BuildOptions) -> Self {
        self.options = options;
        self
    }

    /// Validates the inputs and queries the memory the build needs, without
    /// building (OptiX's `optixAccelComputeMemoryUsage`).
    ///
    /// On the CPU backend the tree is built to measure it; both scratch sizes are 0.
    pub fn sizes(&self, ctx: &Context) -> Result<AccelSizes> {
        if ctx.cpu().is_some() {
            input::validate(&self.inputs, ctx.limits(), false)?;
            let size = crate::cpu::accel::GasData::build(&self.inputs).size();
            return Ok(AccelSizes { structure: size, build_scratch: 0, update_scratch: 0 });
        }
        let inner = ctx.vulkan("a GAS size query")?;
        let shapes = input::validate(&self.inputs, &inner.limits, false)?;
        let counts: Vec<u32> = shapes.iter().map(Shape::primitives).collect();
        // The size query ignores addresses (only a transform's presence counts):
        // describe the geometry without uploading it.
        let geometries: Vec<Geometry> = self.inputs.iter().zip(&shapes).map(|(i, s)| describe(i, s)).collect();
        Ok(build::query_sizes(inner, BOTTOM, self.options.vk_flags(), &geometries, &counts))
    }

    /// Builds and waits.
    pub fn build(self, ctx: &Context) -> Result<Gas> {
        self.submit(ctx)?.wait()
    }

    /// Submits the build and returns without waiting.
    pub fn submit(self, ctx: &Context) -> Result<PendingBuild<Gas>> {
        if let Some(cpu) = ctx.cpu() {
            let gas = crate::cpu::accel::build_gas(cpu, &self.inputs, self.options)?;
            return Ok(PendingBuild::ready(gas));
        }
        let (in_flight, mut gases) = submit_gases(ctx.vulkan("a GAS build")?, std::slice::from_ref(&self))?;
        let gas = gases.pop().ok_or(Error::AccelEmpty { what: "the batch has no GAS builds".to_owned() })?;
        Ok(PendingBuild::new(in_flight, gas, |gas, sizes| {
            if gas.options.allow_compaction {
                gas.compacted_size = sizes.first().copied();
            }
        }))
    }
}

/// A geometry as the size query sees it: formats, counts and strides, no data.
fn describe(input: &BuildInput<'_>, shape: &Shape) -> Geometry {
    match input {
        BuildInput::Triangles(t) => Geometry::Triangles {
            vertices: 0,
            stride: t.stride,
            max_vertex: t.vertex_count.saturating_sub(1) as u32,
            index_type: match shape {
                Shape::Triangles { index, .. } => index.vk(),
                Shape::Aabbs { .. } => vk::IndexType::NONE_KHR,
            },
            indices: 0,
            transform: u64::from(t.transform.is_some()),
            flags: t.flags.vk(),
        },
        BuildInput::Aabbs(a) => Geometry::Aabbs { data: 0, stride: a.stride, flags: a.flags.vk() },
    }
}

/// Validates, uploads and submits `builds` in one command buffer.
fn submit_gases(ctx: &Arc<ContextInner>, builds: &[GasBuilder<'_>]) -> Result<(build::InFlight, Vec<Gas>)> {
    if builds.is_empty() {
        return Err(Error::AccelEmpty { what: "the batch has no GAS builds".to_owned() });
    }
    // Validate everything before allocating anything.
    let validated = builds
        .iter()
        .map(|b| input::validate(&b.inputs, &ctx.limits, b.options.allow_update))
        .collect::<Result<Vec<_>>>()?;
    let mut gases = Vec::with_capacity(builds.len());
    let mut jobs = Vec::with_capacity(builds.len());
    let mut buffers = Vec::with_capacity(builds.len());
    for (b, shapes) in builds.iter().zip(validated) {
        let p = prepare(ctx, &b.inputs, shapes, b.options)?;
        let accel = AccelStructure::new(ctx, BOTTOM, p.sizes.structure)?;
        jobs.push(Job {
            ty: BOTTOM,
            flags: b.options.vk_flags(),
            update_from: None,
            dst: accel.handle,
            geometries: p.geometries,
            counts: p.counts,
            scratch: p.sizes.build_scratch,
            query_compacted: b.options.allow_compaction,
        });
        buffers.push(p.input_buffer);
        gases.push(Gas {
            accel: GasAccel::Vulkan(Arc::new(accel)),
            shapes: p.shapes,
            options: b.options,
            sizes: p.sizes,
            compacted_size: None,
            compaction: None,
        });
    }
    let in_flight = build::submit(ctx, &jobs, buffers)?;
    Ok((in_flight, gases))
}

impl Gas {
    /// Starts describing a build.
    pub fn builder<'a>() -> GasBuilder<'a> {
        GasBuilder::default()
    }

    /// A GAS over `vertices` and, when given, `indices` (three per triangle), or
    /// every three consecutive vertices. Built for fast trace, and waited for.
    pub fn triangles(ctx: &Context, vertices: &[Vec3], indices: Option<&[u32]>) -> Result<Gas> {
        let mut triangles = Triangles::new(vertices);
        if let Some(indices) = indices {
            triangles = triangles.indices_u32(indices);
        }
        Gas::builder().triangles(triangles).build(ctx)
    }

    /// A GAS over boxes for an intersection program, built and waited for.
    pub fn aabbs(ctx: &Context, boxes: &[Aabb]) -> Result<Gas> {
        Gas::builder().aabbs(Aabbs::new(boxes)).build(ctx)
    }

    /// Builds several GASes in one submission and waits for all of them.
    pub fn build_many(ctx: &Context, builds: Vec<GasBuilder<'_>>) -> Result<Vec<Gas>> {
        Gas::submit_many(ctx, builds)?.wait()
    }

    /// Builds several GASes in one submission (one command buffer, one shared
    /// scratch buffer) without waiting. Every input is validated before anything
    /// is submitted.
    pub fn submit_many(ctx: &Context, builds: Vec<GasBuilder<'_>>) -> Result<PendingBuild<Vec<Gas>>> {
        if let Some(cpu) = ctx.cpu() {
            if builds.is_empty() {
                return Err(Error::AccelEmpty { what: "the batch has no GAS builds".to_owned() });
            }
            for b in &builds {
                input::validate(&b.inputs, ctx.limits(), b.options.allow_update)?;
            }
            let gases = builds
                .iter()
                .map(|b| crate::cpu::accel::build_gas(cpu, &b.inputs, b.options))
                .collect::<Result<Vec<_>>>()?;
            return Ok(PendingBuild::ready(gases));
        }
        let (in_flight, gases) = submit_gases(ctx.vulkan("a GAS build")?, &builds)?;
        Ok(PendingBuild::new(in_flight, gases, |gases, sizes| {
            let mut sizes = sizes.iter();
            for gas in gases.iter_mut().filter(|g| g.options.allow_compaction) {
                gas.compacted_size = sizes.next().copied();
            }
        }))
    }

    /// Refits the GAS in place to `inputs` (OptiX's `OPTIX_BUILD_OPERATION_UPDATE`):
    /// vertex positions, AABBs and transforms may change; counts, formats, index
    /// data and flags may not. Refused with [`Error::UpdateRefused`], saying why,
    /// when the build did not allow updates or the topology changed. Update or
    /// rebuild the [`Ias`](super::Ias)es that instance this GAS afterwards, so
    /// their bounds follow.
    pub fn update(&mut self, inputs: &[BuildInput<'_>]) -> Result<()> {
        if !self.options.allow_update {
            return Err(Error::UpdateRefused {
                what: "GAS",
                reason: "it was built without BuildOptions::allow_update".to_owned(),
            });
        }
        let accel = match &self.accel {
            GasAccel::Vulkan(accel) => accel.clone(),
            GasAccel::Cpu(cpu) => {
                let shapes = input::validate(inputs, &crate::cpu::LIMITS, true)?;
                if let Some(reason) = input::update_refusal(&self.shapes, &shapes) {
                    return Err(Error::UpdateRefused { what: "GAS", reason });
                }
                cpu.refit(inputs);
                self.compacted_size = None;
                return Ok(());
            }
        };
        let ctx = accel.ctx.clone();
        let shapes = input::validate(inputs, &ctx.limits, true)?;
        if let Some(reason) = input::update_refusal(&self.shapes, &shapes) {
            return Err(Error::UpdateRefused { what: "GAS", reason });
        }
        let p = prepare(&ctx, inputs, shapes, self.options)?;
        let job = Job {
            ty: BOTTOM,
            flags: self.options.vk_flags(),
            update_from: Some(accel.handle),
            dst: accel.handle,
            geometries: p.geometries,
            counts: p.counts,
            scratch: p.sizes.update_scratch,
            query_compacted: false,
        };
        build::submit(&ctx, &[job], vec![p.input_buffer])?.wait()?;
        accel.version.fetch_add(1, std::sync::atomic::Ordering::AcqRel);
        self.compacted_size = None;
        Ok(())
    }

    /// Rebuilds the GAS from `inputs` with its options; the topology may change.
    /// The structure may move: rebuild the [`Ias`](super::Ias)es that instance it.
    pub fn rebuild(&mut self, inputs: &[BuildInput<'_>]) -> Result<()> {
        let ctx = self.accel.context();
        let rebuilt = GasBuilder { inputs: inputs.to_vec(), options: self.options }.build(&ctx)?;
        *self = rebuilt;
        Ok(())
    }

    /// Copies the GAS into a structure of its compacted size and frees the
    /// original (unless an [`Ias`](super::Ias) still holds it). Needs
    /// [`BuildOptions::allow_compaction`]; the sizes are in [`Gas::compaction`].
    pub fn compact(self) -> Result<Gas> {
        if !self.options.allow_compaction {
            return Err(Error::CompactionNotAllowed);
        }
        let accel = match &self.accel {
            GasAccel::Vulkan(accel) => accel.clone(),
            GasAccel::Cpu(_) => {
                // The CPU tree is as small as it gets: compaction keeps it.
                let size = self.size();
                return Ok(Gas { compaction: Some(Compaction { before: size, after: size }), ..self });
            }
        };
        let ctx = accel.ctx.clone();
        let compacted_size = match self.compacted_size {
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
        Ok(Gas {
            compaction: Some(Compaction { before: accel.size, after: compacted.size }),
            accel: GasAccel::Vulkan(Arc::new(compacted)),
            shapes: self.shapes,
            options: self.options,
            sizes: self.sizes,
            compacted_size: Some(compacted_size),
        })
    }

    /// Bytes of device memory the structure takes.
    pub fn size(&self) -> u64 {
        match &self.accel {
            GasAccel::Vulkan(accel) => accel.size,
            GasAccel::Cpu(cpu) => cpu.data().size(),
        }
    }

    /// The sizes the driver reported for the last full build.
    pub fn build_sizes(&self) -> AccelSizes {
        self.sizes
    }

    /// The compacted size, queried after the build when it allowed compaction.
    pub fn compacted_size(&self) -> Option<u64> {
        self.compacted_size
    }

    /// Sizes before and after, when this GAS is the result of [`Gas::compact`].
    pub fn compaction(&self) -> Option<Compaction> {
        self.compaction
    }

    /// The options it was built with.
    pub fn options(&self) -> BuildOptions {
        self.options
    }

    /// Number of geometries (and SBT records per ray type it spans).
    pub fn geometry_count(&self) -> usize {
        self.shapes.len()
    }

    /// Number of triangles or AABBs over all geometries.
    pub fn primitive_count(&self) -> u64 {
        self.shapes.iter().map(|s| s.primitives() as u64).sum()
    }

    /// The structure's device address (0 on the CPU backend, where
    /// structures have none).
    pub fn device_address(&self) -> u64 {
        match &self.accel {
            GasAccel::Vulkan(accel) => accel.address,
            GasAccel::Cpu(_) => 0,
        }
    }

    /// A GAS of the CPU backend built from validated inputs.
    pub(crate) fn from_cpu(
        accel: Arc<crate::cpu::accel::CpuGas>,
        shapes: Vec<Shape>,
        options: BuildOptions,
        size: u64,
    ) -> Gas {
        let sizes = AccelSizes { structure: size, build_scratch: 0, update_scratch: 0 };
        let compacted_size = options.allow_compaction.then_some(size);
        Gas { accel: GasAccel::Cpu(accel), shapes, options, sizes, compacted_size, compaction: None }
    }
}

impl std::fmt::Debug for Gas {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Gas")
            .field("geometries", &self.shapes.len())
            .field("primitives", &self.primitive_count())
            .field("size", &self.size())
            .field("options", &self.options)
            .finish()
    }
}
