//! Geometry acceleration structures (bottom level), OptiX's GAS: built from
//! [`BuildInput`]s with [`GasBuilder`], refitted with [`Gas::update`], compacted
//! with [`Gas::compact`] ([`vkCmdCopyAccelerationStructureKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdCopyAccelerationStructureKHR.html)
//! in `COMPACT` mode, after a
//! [compacted-size query](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdWriteAccelerationStructuresPropertiesKHR.html)).

use std::sync::Arc;

use glam::{Vec3, Vec4};

use super::primitive_data::{MeshBuffers, PrimitiveData};
use super::PendingBuild;
use super::{AccelSizes, BuildOptions};
use crate::context::{Context, ContextRepr};
use crate::error::AccelError;
use crate::error::{Error, Result};
use crate::memory::DeviceBuffer;
use crate::types::accel::{Aabb, Aabbs, BuildInput, Shape, Triangles};
use crate::types::mesh::Mesh;
use crate::validate::accel as input;
use crate::vulkan::accel::build;
use crate::vulkan::accel::structure::AccelStructure;
use crate::vulkan::context::ContextInner;

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
    pub(crate) repr: GasRepr,
    /// The spheres of [`Gas::spheres`] or [`Gas::moving_spheres`], or the mesh of [`Gas::mesh`], for its programs.
    pub(crate) primitives: Option<Arc<PrimitiveData>>,
    shapes: Vec<Shape>,
    options: BuildOptions,
    sizes: AccelSizes,
    compacted_size: Option<u64>,
    compaction: Option<Compaction>,
}

/// What a [`Gas`] is underneath.
#[derive(Clone)]
pub(crate) enum GasRepr {
    /// A Vulkan acceleration structure.
    Vulkan(Arc<AccelStructure>),
    /// A tree of the CPU backend.
    Cpu(Arc<crate::cpu::accel::CpuGas>),
}

impl GasRepr {
    /// The version every refit bumps (see [`crate::validate::handles`]).
    pub(crate) fn version(&self) -> &Arc<std::sync::atomic::AtomicU64> {
        match self {
            GasRepr::Vulkan(accel) => &accel.version,
            GasRepr::Cpu(cpu) => &cpu.version,
        }
    }

    /// The context it was built on.
    pub(crate) fn context(&self) -> Context {
        match self {
            GasRepr::Vulkan(accel) => Context::from_vulkan(accel.ctx.clone()),
            GasRepr::Cpu(cpu) => Context::from_cpu(cpu.ctx.clone()),
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
    #[doc(alias("optixAccelComputeMemoryUsage", "vkGetAccelerationStructureBuildSizesKHR"))]
    pub fn sizes(&self, ctx: &Context) -> Result<AccelSizes> {
        let shapes = input::validate(&self.inputs, ctx.limits(), false)?;
        Ok(match ctx.repr() {
            ContextRepr::Vulkan(inner) => crate::vulkan::accel::gas::sizes(inner, &self.inputs, &shapes, self.options),
            ContextRepr::Cpu(_) => {
                let size = crate::cpu::accel::GasData::build(&self.inputs).size();
                AccelSizes { structure: size, build_scratch: 0, update_scratch: 0 }
            }
        })
    }

    /// Validates the inputs for a build with this builder's options: their
    /// shapes, what a later refit must keep.
    fn validate(&self, ctx: &Context) -> Result<Vec<Shape>> {
        input::validate(&self.inputs, ctx.limits(), self.options.allow_update)
    }

    /// Builds and waits.
    #[doc(alias("optixAccelBuild", "vkCmdBuildAccelerationStructuresKHR"))]
    pub fn build(self, ctx: &Context) -> Result<Gas> {
        self.submit(ctx)?.wait()
    }

    /// Submits the build and returns without waiting.
    #[doc(alias("optixAccelBuild"))]
    pub fn submit(self, ctx: &Context) -> Result<PendingBuild<Gas>> {
        let shapes = self.validate(ctx)?;
        match ctx.repr() {
            ContextRepr::Vulkan(inner) => {
                let (in_flight, mut gases) = submit_gases(inner, std::slice::from_ref(&self), vec![shapes])?;
                let empty = || Error::Accel(AccelError::Empty { what: "the batch has no GAS builds".to_owned() });
                let gas = gases.pop().ok_or_else(empty)?;
                Ok(PendingBuild::new(in_flight, gas, |gas, sizes| {
                    if gas.options.allow_compaction {
                        gas.compacted_size = sizes.first().copied();
                    }
                }))
            }
            ContextRepr::Cpu(cpu) => {
                let (gas, size) = crate::cpu::accel::build_gas(cpu, &self.inputs);
                Ok(PendingBuild::ready(Gas::from_cpu(gas, shapes, self.options, size)))
            }
        }
    }
}

/// Uploads and submits the checked `builds` (with their `shapes`) in one command buffer.
fn submit_gases(
    ctx: &Arc<ContextInner>,
    builds: &[GasBuilder<'_>],
    shapes: Vec<Vec<Shape>>,
) -> Result<(build::InFlight, Vec<Gas>)> {
    let batch = builds.iter().zip(shapes).map(|(b, shapes)| (&b.inputs[..], shapes, b.options));
    let (in_flight, built) = crate::vulkan::accel::gas::submit(ctx, batch)?;
    let gases = built
        .into_iter()
        .zip(builds)
        .map(|(b, builder)| Gas {
            repr: GasRepr::Vulkan(Arc::new(b.accel)),
            primitives: None,
            shapes: b.shapes,
            options: builder.options,
            sizes: b.sizes,
            compacted_size: None,
            compaction: None,
        })
        .collect();
    Ok((in_flight, gases))
}

impl Gas {
    /// Starts describing a build.
    #[doc(alias("optixAccelBuild", "BLAS"))]
    pub fn builder<'a>() -> GasBuilder<'a> {
        GasBuilder::default()
    }

    /// A GAS over `vertices` and, when given, `indices` (three per triangle), or
    /// every three consecutive vertices. Built for fast trace, and waited for.
    #[doc(alias("optixAccelBuild", "OPTIX_BUILD_INPUT_TYPE_TRIANGLES"))]
    pub fn triangles(ctx: &Context, vertices: &[Vec3], indices: Option<&[u32]>) -> Result<Gas> {
        let mut triangles = Triangles::new(vertices);
        if let Some(indices) = indices {
            triangles = triangles.indices_u32(indices);
        }
        Gas::builder().triangles(triangles).build(ctx)
    }

    /// A GAS over boxes for an intersection program, built and waited for.
    #[doc(alias("optixAccelBuild", "OPTIX_BUILD_INPUT_TYPE_CUSTOM_PRIMITIVES"))]
    pub fn aabbs(ctx: &Context, boxes: &[Aabb]) -> Result<Gas> {
        Gas::builder().aabbs(Aabbs::new(boxes)).build(ctx)
    }

    /// A GAS of built-in spheres (OptiX's `OPTIX_PRIMITIVE_TYPE_SPHERE`): sphere
    /// `i` has centre `centres[i]` and radius `radii[i]`, and is primitive `i`
    /// of the GAS's one geometry. Vulkan has no sphere primitive, so each is an
    /// AABB (its box rounded outwards) hit through an intersection program, and
    /// the GAS keeps the spheres in device memory for it: put
    /// [`Gas::sphere_buffer`] in the launch params or the hit group's record and
    /// call `raykit_device::sphere::report` from the hit group's
    /// `#[intersection]` program (see `raykit_device::sphere` for the test and
    /// the hit attributes). Built for fast trace, and waited for.
    ///
    /// Refused with [`AccelError::SphereCount`](crate::AccelError::SphereCount)
    /// when the counts differ, [`AccelError::InvalidSphere`](crate::AccelError::InvalidSphere)
    /// for a centre that is not finite or a radius that is NaN, infinite or
    /// negative, and [`AccelError::Empty`](crate::AccelError::Empty) for no spheres.
    /// A radius of 0 is a sphere no ray hits.
    ///
    /// ```
    /// use raykit::glam::Vec3;
    /// use raykit::{AccelError, Backend, Context, ContextOptions, Error, Gas, Ias};
    /// let ctx = Context::new(ContextOptions { backend: Some(Backend::Cpu), ..Default::default() })?;
    /// let gas = Gas::spheres(&ctx, &[Vec3::new(0.0, -1000.0, 0.0), Vec3::Y], &[1000.0, 1.0])?;
    /// let spheres = gas.sphere_buffer(); // Some(Buffer<Vec4>): centre xyz, radius w
    /// let scene = Ias::single(&ctx, &gas)?; // keeps the spheres alive with the GAS
    /// let refused = Gas::spheres(&ctx, &[Vec3::ZERO], &[-1.0]);
    /// assert!(matches!(refused, Err(Error::Accel(AccelError::InvalidSphere { sphere: 0, .. }))));
    /// # let _ = (spheres, scene);
    /// # Ok::<(), raykit::Error>(())
    /// ```
    #[doc(alias("optixAccelBuild", "OPTIX_BUILD_INPUT_TYPE_SPHERES", "OPTIX_PRIMITIVE_TYPE_SPHERE"))]
    pub fn spheres(ctx: &Context, centres: &[Vec3], radii: &[f32]) -> Result<Gas> {
        input::spheres(centres, radii)?;
        let boxes: Vec<Aabb> = centres.iter().zip(radii).map(|(&c, &r)| Aabb::around_sphere(c, r)).collect();
        let data: Vec<Vec4> = centres.iter().zip(radii).map(|(&c, &r)| c.extend(r)).collect();
        let mut gas = Gas::aabbs(ctx, &boxes)?;
        gas.primitives = Some(Arc::new(PrimitiveData::Spheres(DeviceBuffer::from_slice(ctx, &data)?)));
        Ok(gas)
    }

    /// A GAS of moving spheres, for motion blur: sphere `i` has radius
    /// `radii[i]` and moves linearly from `start[i]` at time 0 to `end[i]` at
    /// time 1. Each is the box around its whole sweep (the union of its boxes at
    /// the two ends, which holds every position between, rounded outwards by a
    /// few more ulps for the device's interpolation), hit through an
    /// intersection program that calls `raykit_device::sphere::report_moving`
    /// with [`Gas::moving_sphere_buffer`] and the ray's time
    /// (`raykit_device::motion`). Built for fast trace, and waited for.
    ///
    /// Refused as [`Gas::spheres`] refuses either end, and with
    /// [`AccelError::MovingSphereCount`](crate::AccelError::MovingSphereCount)
    /// when the two ends' counts differ.
    ///
    /// ```
    /// use raykit::glam::Vec3;
    /// use raykit::{Backend, Context, ContextOptions, Gas};
    /// let ctx = Context::new(ContextOptions { backend: Some(Backend::Cpu), ..Default::default() })?;
    /// let start = [Vec3::new(400.0, 400.0, 200.0)];
    /// let gas = Gas::moving_spheres(&ctx, &start, &[start[0] + Vec3::new(30.0, 0.0, 0.0)], &[50.0])?;
    /// let spheres = gas.moving_sphere_buffer(); // Some(Buffer<Vec4>): two per sphere
    /// assert!(gas.sphere_buffer().is_none()); // `sphere::report` would read it wrongly
    /// # let _ = spheres;
    /// # Ok::<(), raykit::Error>(())
    /// ```
    #[doc(alias("OptixMotionOptions", "motion blur"))]
    pub fn moving_spheres(ctx: &Context, start: &[Vec3], end: &[Vec3], radii: &[f32]) -> Result<Gas> {
        input::moving_spheres(start, end, radii)?;
        let boxes: Vec<Aabb> =
            start.iter().zip(end).zip(radii).map(|((&s, &e), &r)| Aabb::around_sweep(s, e, r)).collect();
        let data: Vec<Vec4> =
            start.iter().zip(end).zip(radii).flat_map(|((&s, &e), &r)| [s.extend(r), e.extend(r)]).collect();
        let mut gas = Gas::aabbs(ctx, &boxes)?;
        gas.primitives = Some(Arc::new(PrimitiveData::MovingSpheres(DeviceBuffer::from_slice(ctx, &data)?)));
        Ok(gas)
    }

    /// A GAS over a triangle [`Mesh`] (quads and boxes are meshes too:
    /// [`Mesh::quad`], [`Mesh::cuboid`]), which it keeps in device memory with its
    /// normals and texture coordinates: put [`Gas::mesh_data`] in the hit group's
    /// record or the launch params and call `raykit_device::triangle::surface` in
    /// closest-hit for the world-space hit (position with a rigorous error bound
    /// and the spawn origin it gives, geometric and shading normals, uv, face).
    /// Built for fast trace, and waited for.
    ///
    /// Refused as [`Gas::triangles`] refuses its inputs, and with
    /// [`AccelError::MeshAttribute`](crate::AccelError::MeshAttribute) for normals
    /// or uvs whose count is not the positions' or that are not finite.
    ///
    /// ```
    /// use raykit::glam::{Affine3A, Quat, Vec3};
    /// use raykit::{Backend, Context, ContextOptions, Gas, Ias, Instance, Mesh};
    /// let ctx = Context::new(ContextOptions { backend: Some(Backend::Cpu), ..Default::default() })?;
    /// let cube = Gas::mesh(&ctx, &Mesh::cuboid(Vec3::ZERO, Vec3::splat(165.0)))?;
    /// let record = cube.mesh_data(); // Some(MeshData) for the hit group's record
    /// // A rotated, moved box is one instance.
    /// let turned = Affine3A::from_rotation_translation(Quat::from_rotation_y(-0.3), Vec3::new(130.0, 0.0, 65.0));
    /// let scene = Ias::new(&ctx, &[Instance::new(&cube).transform(turned)])?;
    /// # let _ = (record, scene);
    /// # Ok::<(), raykit::Error>(())
    /// ```
    #[doc(alias("optixAccelBuild", "OPTIX_BUILD_INPUT_TYPE_TRIANGLES"))]
    pub fn mesh(ctx: &Context, mesh: &Mesh) -> Result<Gas> {
        input::mesh(mesh)?;
        let mut gas = Gas::triangles(ctx, &mesh.positions, Some(&mesh.indices))?;
        gas.primitives = Some(Arc::new(PrimitiveData::Mesh(Box::new(MeshBuffers::new(ctx, mesh)?))));
        Ok(gas)
    }

    /// The mesh of a GAS made by [`Gas::mesh`], as `raykit_device::triangle`
    /// reads it; `None` for other GASes. Its buffers live as long as the GAS or an
    /// [`Ias`](super::Ias) over it.
    pub fn mesh_data(&self) -> Option<raykit_device::triangle::MeshData> {
        match self.primitives.as_deref() {
            Some(PrimitiveData::Mesh(mesh)) => Some(mesh.data()),
            _ => None,
        }
    }

    /// The spheres of a GAS made by [`Gas::spheres`] (centre in `xyz`, radius in
    /// `w`, indexed by primitive), for its intersection program; `None` for
    /// other GASes. The buffer lives as long as the GAS or an
    /// [`Ias`](super::Ias) over it.
    pub fn sphere_buffer(&self) -> Option<raykit_device::Buffer<Vec4>> {
        match self.primitives.as_deref() {
            Some(PrimitiveData::Spheres(spheres)) => Some(spheres.handle()),
            _ => None,
        }
    }

    /// The spheres of a GAS made by [`Gas::moving_spheres`]: sphere `i` at
    /// time 0 at index `2i`, at time 1 at `2i + 1` (centre in `xyz`, radius in
    /// `w`), for `raykit_device::sphere::report_moving`; `None` for other
    /// GASes. The buffer lives as long as the GAS or an [`Ias`](super::Ias)
    /// over it.
    pub fn moving_sphere_buffer(&self) -> Option<raykit_device::Buffer<Vec4>> {
        match self.primitives.as_deref() {
            Some(PrimitiveData::MovingSpheres(spheres)) => Some(spheres.handle()),
            _ => None,
        }
    }

    /// Builds several GASes in one submission and waits for all of them.
    pub fn build_many(ctx: &Context, builds: Vec<GasBuilder<'_>>) -> Result<Vec<Gas>> {
        Gas::submit_many(ctx, builds)?.wait()
    }

    /// Builds several GASes in one submission (one command buffer, one shared
    /// scratch buffer) without waiting. Every input is validated before anything
    /// is submitted.
    pub fn submit_many(ctx: &Context, builds: Vec<GasBuilder<'_>>) -> Result<PendingBuild<Vec<Gas>>> {
        if builds.is_empty() {
            return Err(Error::Accel(AccelError::Empty { what: "the batch has no GAS builds".to_owned() }));
        }
        // Validate everything before allocating anything.
        let shapes = builds.iter().map(|b| b.validate(ctx)).collect::<Result<Vec<_>>>()?;
        match ctx.repr() {
            ContextRepr::Vulkan(inner) => {
                let (in_flight, gases) = submit_gases(inner, &builds, shapes)?;
                Ok(PendingBuild::new(in_flight, gases, |gases, sizes| {
                    let mut sizes = sizes.iter();
                    for gas in gases.iter_mut().filter(|g| g.options.allow_compaction) {
                        gas.compacted_size = sizes.next().copied();
                    }
                }))
            }
            ContextRepr::Cpu(cpu) => {
                let gases = builds
                    .iter()
                    .zip(shapes)
                    .map(|(b, shapes)| {
                        let (gas, size) = crate::cpu::accel::build_gas(cpu, &b.inputs);
                        Gas::from_cpu(gas, shapes, b.options, size)
                    })
                    .collect();
                Ok(PendingBuild::ready(gases))
            }
        }
    }

    /// Refits the GAS in place to `inputs` (OptiX's `OPTIX_BUILD_OPERATION_UPDATE`):
    /// vertex positions, AABBs and transforms may change; counts, formats, index
    /// data and flags may not. Refused with [`AccelError::UpdateRefused`](crate::AccelError::UpdateRefused), saying why,
    /// when the build did not allow updates or the topology changed. Update or
    /// rebuild the [`Ias`](super::Ias)es that instance this GAS afterwards, so
    /// their bounds follow.
    #[doc(alias("OPTIX_BUILD_OPERATION_UPDATE"))]
    pub fn update(&mut self, inputs: &[BuildInput<'_>]) -> Result<()> {
        if let Some(primitives) = self.primitives.as_deref() {
            let reason = match primitives {
                PrimitiveData::Spheres(_) => {
                    "it holds built-in spheres, whose buffer a refit of its boxes would leave behind; \
                     make a new one with Gas::spheres"
                }
                PrimitiveData::MovingSpheres(_) => {
                    "it holds moving spheres, whose buffer a refit of its boxes would leave behind; \
                     make a new one with Gas::moving_spheres"
                }
                PrimitiveData::Mesh(_) => {
                    "it holds a mesh, whose vertices and attributes a refit would leave behind; \
                     make a new one with Gas::mesh"
                }
            };
            return Err(Error::Accel(AccelError::UpdateRefused { what: "GAS", reason: reason.to_owned() }));
        }
        if !self.options.allow_update {
            return Err(Error::Accel(AccelError::UpdateRefused {
                what: "GAS",
                reason: "it was built without BuildOptions::allow_update".to_owned(),
            }));
        }
        let shapes = input::validate(inputs, self.repr.context().limits(), true)?;
        if let Some(reason) = input::update_refusal(&self.shapes, &shapes) {
            return Err(Error::Accel(AccelError::UpdateRefused { what: "GAS", reason }));
        }
        match &self.repr {
            GasRepr::Vulkan(accel) => crate::vulkan::accel::gas::refit(accel, inputs, shapes, self.options)?,
            GasRepr::Cpu(cpu) => cpu.refit(inputs),
        }
        self.compacted_size = None;
        Ok(())
    }

    /// Rebuilds the GAS from `inputs` with its options; the topology may change.
    /// The structure may move: rebuild the [`Ias`](super::Ias)es that instance it.
    /// A GAS of [`Gas::spheres`] or [`Gas::mesh`] becomes a GAS of `inputs`
    /// without its spheres or mesh data.
    pub fn rebuild(&mut self, inputs: &[BuildInput<'_>]) -> Result<()> {
        let ctx = self.repr.context();
        let rebuilt = GasBuilder { inputs: inputs.to_vec(), options: self.options }.build(&ctx)?;
        *self = rebuilt;
        Ok(())
    }

    /// Copies the GAS into a structure of its compacted size and frees the
    /// original (unless an [`Ias`](super::Ias) still holds it). Needs
    /// [`BuildOptions::allow_compaction`]; the sizes are in [`Gas::compaction`].
    #[doc(alias("optixAccelCompact", "vkCmdCopyAccelerationStructureKHR"))]
    pub fn compact(self) -> Result<Gas> {
        if !self.options.allow_compaction {
            return Err(Error::Accel(AccelError::CompactionNotAllowed));
        }
        let accel = match &self.repr {
            GasRepr::Vulkan(accel) => accel.clone(),
            GasRepr::Cpu(_) => {
                // The CPU tree is as small as it gets: compaction keeps it.
                let size = self.size();
                return Ok(Gas { compaction: Some(Compaction { before: size, after: size }), ..self });
            }
        };
        let (compacted, compacted_size) = crate::vulkan::accel::gas::compact(&accel, self.compacted_size)?;
        Ok(Gas {
            compaction: Some(Compaction { before: accel.size, after: compacted.size }),
            repr: GasRepr::Vulkan(Arc::new(compacted)),
            primitives: self.primitives,
            shapes: self.shapes,
            options: self.options,
            sizes: self.sizes,
            compacted_size: Some(compacted_size),
        })
    }

    /// Bytes of device memory the structure takes.
    pub fn size(&self) -> u64 {
        match &self.repr {
            GasRepr::Vulkan(accel) => accel.size,
            GasRepr::Cpu(cpu) => cpu.data().size(),
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

    /// Whether its geometries are AABBs (procedural), which only procedural hit
    /// groups (with an intersection program) may be used with.
    pub(crate) fn is_procedural(&self) -> bool {
        matches!(self.shapes.first(), Some(Shape::Aabbs { .. }))
    }

    /// Number of triangles or AABBs over all geometries.
    pub fn primitive_count(&self) -> u64 {
        self.shapes.iter().map(|s| s.primitives() as u64).sum()
    }

    /// The structure's device address (0 on the CPU backend, where
    /// structures have none).
    pub fn device_address(&self) -> u64 {
        match &self.repr {
            GasRepr::Vulkan(accel) => accel.address,
            GasRepr::Cpu(_) => 0,
        }
    }

    /// A GAS of the CPU backend built from validated inputs.
    fn from_cpu(accel: Arc<crate::cpu::accel::CpuGas>, shapes: Vec<Shape>, options: BuildOptions, size: u64) -> Gas {
        let sizes = AccelSizes { structure: size, build_scratch: 0, update_scratch: 0 };
        let compacted_size = options.allow_compaction.then_some(size);
        Gas { repr: GasRepr::Cpu(accel), primitives: None, shapes, options, sizes, compacted_size, compaction: None }
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
