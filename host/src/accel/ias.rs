//! Instance acceleration structures (top level), OptiX's IAS: what device
//! programs trace. Each [`Instance`] places a [`Gas`] with a transform, a custom
//! index, a visibility mask, an SBT offset and flags
//! ([`VkAccelerationStructureInstanceKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkAccelerationStructureInstanceKHR.html)).

use std::sync::atomic::Ordering;
use std::sync::Arc;

use glam::Affine3A;
use raykit_device::Traversable;

use super::gas::{Gas, GasRepr};
use super::primitive_data::PrimitiveData;
use super::PendingBuild;
use super::{AccelSizes, BuildOptions};
use crate::context::{Context, ContextRepr};
use crate::error::{AccelError, DeviceError};
use crate::error::{Error, Result};
use crate::types::accel::{transform_rows, InstanceFlags, InstancePlacement};
use crate::validate::hit_reach::HitReach;
use crate::vulkan::accel::structure::AccelStructure;

/// One instance of a [`Gas`] in an [`Ias`] (OptiX's `OptixInstance`).
#[derive(Clone)]
#[must_use]
pub struct Instance {
    pub(crate) accel: GasRepr,
    /// The spheres or mesh its GAS keeps for its programs, kept alive with the IAS.
    primitives: Option<Arc<PrimitiveData>>,
    pub(crate) placement: InstancePlacement,
    /// Geometries of its GAS: the hit records it spans per ray type.
    geometries: u32,
    /// Whether its GAS holds AABBs rather than triangles.
    procedural: bool,
}

impl Instance {
    /// `gas` at the identity transform, custom index 0, mask 0xff, SBT offset 0.
    #[doc(alias("OptixInstance", "VkAccelerationStructureInstanceKHR"))]
    pub fn new(gas: &Gas) -> Instance {
        Instance {
            accel: gas.repr.clone(),
            primitives: gas.primitives.clone(),
            placement: InstancePlacement {
                transform: transform_rows(&Affine3A::IDENTITY),
                custom_index: 0,
                mask: 0xff,
                sbt_offset: 0,
                flags: InstanceFlags::NONE,
            },
            geometries: u32::try_from(gas.geometry_count()).unwrap_or(u32::MAX),
            procedural: gas.is_procedural(),
        }
    }

    /// Object-to-world transform.
    pub fn transform(mut self, transform: Affine3A) -> Self {
        self.placement.transform = transform_rows(&transform);
        self
    }

    /// Object-to-world transform as a row-major 3×4 matrix (OptiX's `transform[12]`).
    pub fn transform_rows(mut self, rows: [[f32; 4]; 3]) -> Self {
        self.placement.transform = bytemuck::cast(rows);
        self
    }

    /// The value device programs read as the instance's custom index (24 bits).
    pub fn custom_index(mut self, index: u32) -> Self {
        self.placement.custom_index = index;
        self
    }

    /// Visibility mask, tested against each ray's cull mask.
    pub fn mask(mut self, mask: u8) -> Self {
        self.placement.mask = mask;
        self
    }

    /// Offset of this instance's first hit record in the SBT (24 bits), counted in
    /// records: a trace of ray type `R` selects record
    /// `offset + geometry × R::SBT_STRIDE + R::SBT_OFFSET`. With several ray types,
    /// compute it with [`instance_sbt_offset`](crate::sbt::instance_sbt_offset) from the
    /// geometry slot [`SbtBuilder::hit_for`](crate::SbtBuilder::hit_for) places its records at.
    ///
    /// Every launch checks that the records its scene can select exist: the
    /// highest, `offset + (geometries − 1) × stride + ray offset` over the
    /// instances and the pipeline's traces, must be below the SBT's hit record
    /// count ([`LaunchError::SbtTooSmallForScene`](crate::LaunchError::SbtTooSmallForScene) otherwise; see [`Ias::hit_records_for`]).
    pub fn sbt_offset(mut self, offset: u32) -> Self {
        self.placement.sbt_offset = offset;
        self
    }

    /// Instance flags.
    pub fn flags(mut self, flags: InstanceFlags) -> Self {
        self.placement.flags = flags;
        self
    }
}

impl std::fmt::Debug for Instance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Instance")
            .field("transform", &self.placement.transform)
            .field("custom_index", &self.placement.custom_index)
            .field("mask", &self.placement.mask)
            .field("sbt_offset", &self.placement.sbt_offset)
            .field("flags", &self.placement.flags)
            .field("geometries", &self.geometries)
            .finish_non_exhaustive()
    }
}

/// What the Vulkan backend records of `instances`: each placement and its GAS's device address.
fn placements(instances: &[Instance]) -> Vec<(InstancePlacement, u64)> {
    let address = |accel: &GasRepr| match accel {
        GasRepr::Vulkan(accel) => accel.address,
        GasRepr::Cpu(_) => 0,
    };
    instances.iter().map(|i| (i.placement, address(&i.accel))).collect()
}

/// Checks instances for an IAS of `ctx`, on either backend: their fields, and
/// that each GAS is of `ctx`.
fn validate(ctx: &Context, instances: &[Instance]) -> Result<()> {
    check_fields(instances, ctx.limits().max_instance_count)?;
    if instances.iter().any(|i| !i.accel.context().is_same(ctx)) {
        return Err(Error::Device(DeviceError::ContextMismatch));
    }
    Ok(())
}

/// Checks what every backend requires of instances: some, at most `limit`, with
/// 24-bit custom indices and SBT offsets and finite transforms.
fn check_fields(instances: &[Instance], limit: u64) -> Result<()> {
    if instances.is_empty() {
        return Err(Error::Accel(AccelError::Empty { what: "the IAS build has no instances".to_owned() }));
    }
    if instances.len() as u64 > limit {
        return Err(Error::Accel(AccelError::Limit {
            what: "instances",
            count: instances.len() as u64,
            limit,
            limit_name: "maxInstanceCount",
        }));
    }
    for (i, instance) in instances.iter().enumerate() {
        for (field, value) in
            [("custom_index", instance.placement.custom_index), ("sbt_offset", instance.placement.sbt_offset)]
        {
            if value >= 1 << 24 {
                return Err(Error::Accel(AccelError::InstanceField { instance: i, field, value, max: (1 << 24) - 1 }));
            }
        }
        if !instance.placement.transform.iter().all(|c| c.is_finite()) {
            return Err(Error::Accel(AccelError::NonFiniteTransform {
                what: format!("the transform of instance {i}"),
            }));
        }
    }
    Ok(())
}

/// Describes an IAS build: instances and options.
#[must_use]
#[derive(Clone, Debug)]
pub struct IasBuilder<'a> {
    instances: &'a [Instance],
    options: BuildOptions,
}

impl IasBuilder<'_> {
    /// Sets the build options.
    pub fn options(mut self, options: BuildOptions) -> Self {
        self.options = options;
        self
    }

    /// Builds and waits.
    #[doc(alias("optixAccelBuild", "OPTIX_BUILD_INPUT_TYPE_INSTANCES"))]
    pub fn build(self, ctx: &Context) -> Result<Ias> {
        self.submit(ctx)?.wait()
    }

    /// Submits the build and returns without waiting.
    pub fn submit(self, ctx: &Context) -> Result<PendingBuild<Ias>> {
        validate(ctx, self.instances)?;
        match ctx.repr() {
            ContextRepr::Vulkan(inner) => {
                let (accel, sizes, in_flight) =
                    crate::vulkan::accel::ias::submit(inner, &placements(self.instances), self.options)?;
                let ias = Ias {
                    repr: IasRepr::Vulkan(accel),
                    gases: self.instances.iter().map(|i| i.accel.clone()).collect(),
                    primitives: primitive_data(self.instances),
                    options: self.options,
                    sizes,
                    reach: Arc::new(hit_reach(self.instances)),
                };
                ias.register();
                Ok(PendingBuild::new(in_flight, ias, |_, _| {}))
            }
            ContextRepr::Cpu(cpu) => {
                let mut ias = Ias {
                    repr: IasRepr::Cpu { ctx: cpu.clone(), address: crate::cpu::next_scene_address() },
                    gases: Vec::new(),
                    primitives: Vec::new(),
                    options: self.options,
                    sizes: AccelSizes::default(),
                    reach: Arc::new(HitReach::default()),
                };
                ias.build_cpu(self.instances)?;
                Ok(PendingBuild::ready(ias))
            }
        }
    }
}

/// The spheres and meshes the instances' GASes keep.
fn primitive_data(instances: &[Instance]) -> Vec<Arc<PrimitiveData>> {
    instances.iter().filter_map(|i| i.primitives.clone()).collect()
}

/// What an [`Ias`] is underneath.
enum IasRepr {
    /// A Vulkan acceleration structure.
    Vulkan(AccelStructure),
    /// A tree of the CPU backend, registered in its context by `address`.
    Cpu { ctx: Arc<crate::cpu::CpuContext>, address: u64 },
}

impl IasRepr {
    /// The context it was built on.
    fn context(&self) -> Context {
        match self {
            IasRepr::Vulkan(accel) => Context::from_vulkan(accel.ctx.clone()),
            IasRepr::Cpu { ctx, .. } => Context::from_cpu(ctx.clone()),
        }
    }

    fn address(&self) -> u64 {
        match self {
            IasRepr::Vulkan(accel) => accel.address,
            IasRepr::Cpu { address, .. } => *address,
        }
    }
}

/// An instance acceleration structure (top level): what device programs trace.
pub struct Ias {
    // Field order: the structure goes before the GASes it references.
    repr: IasRepr,
    gases: Vec<GasRepr>,
    /// The spheres and meshes of its GASes, for their programs.
    primitives: Vec<Arc<PrimitiveData>>,
    options: BuildOptions,
    sizes: AccelSizes,
    /// The hit records its instances can select, checked by every launch.
    reach: Arc<HitReach>,
}

impl Ias {
    /// Starts describing a build over `instances`.
    pub fn builder(instances: &[Instance]) -> IasBuilder<'_> {
        IasBuilder { instances, options: BuildOptions::default() }
    }

    /// An IAS over one instance of `gas` at the identity transform.
    pub fn single(ctx: &Context, gas: &Gas) -> Result<Ias> {
        Ias::new(ctx, &[Instance::new(gas)])
    }

    /// An IAS over `instances`, built for fast trace, and waited for.
    #[doc(alias("TLAS", "optixAccelBuild"))]
    pub fn new(ctx: &Context, instances: &[Instance]) -> Result<Ias> {
        Ias::builder(instances).build(ctx)
    }

    /// Refits the IAS to `instances` in place: transforms, masks, offsets, flags
    /// and the GASes referenced may change, the instance count may not. Refused
    /// with [`AccelError::UpdateRefused`](crate::AccelError::UpdateRefused), saying why, when the build did not allow
    /// updates or the count changed. Also the way to follow a refitted GAS.
    #[doc(alias("OPTIX_BUILD_OPERATION_UPDATE"))]
    pub fn update(&mut self, instances: &[Instance]) -> Result<()> {
        if !self.options.allow_update {
            return Err(Error::Accel(AccelError::UpdateRefused {
                what: "IAS",
                reason: "it was built without BuildOptions::allow_update".to_owned(),
            }));
        }
        if instances.len() != self.gases.len() {
            return Err(Error::Accel(AccelError::UpdateRefused {
                what: "IAS",
                reason: format!("the instance count changed from {} to {}", self.gases.len(), instances.len()),
            }));
        }
        validate(&self.repr.context(), instances)?;
        let accel = match &self.repr {
            IasRepr::Vulkan(accel) => accel,
            IasRepr::Cpu { .. } => return self.build_cpu(instances),
        };
        crate::vulkan::accel::ias::refit(accel, &placements(instances), self.options)?;
        self.gases = instances.iter().map(|i| i.accel.clone()).collect();
        self.primitives = primitive_data(instances);
        self.reach = Arc::new(hit_reach(instances));
        self.register();
        Ok(())
    }

    /// Records this IAS, with the versions of the GASes it was built over, as
    /// what launches may trace.
    fn register(&self) {
        let over = self.gases.iter().map(|g| (g.version().clone(), g.version().load(Ordering::Acquire))).collect();
        let ias = crate::validate::handles::LiveIas { over, reach: self.reach.clone() };
        if let IasRepr::Vulkan(accel) = &self.repr {
            accel.ctx.traversables.insert(accel.address, ias);
        }
    }

    /// Builds (or rebuilds in place, for an update) the CPU backend's tree over
    /// the checked `instances` and registers it under the IAS's address.
    fn build_cpu(&mut self, instances: &[Instance]) -> Result<()> {
        let IasRepr::Cpu { ctx, address } = &self.repr else { return Ok(()) };
        let mut scene = Vec::with_capacity(instances.len());
        for instance in instances {
            let GasRepr::Cpu(gas) = &instance.accel else { return Err(Error::Device(DeviceError::ContextMismatch)) };
            if !Arc::ptr_eq(&gas.ctx, ctx) {
                return Err(Error::Device(DeviceError::ContextMismatch));
            }
            let object_to_world = crate::cpu::accel::affine_from_rows(&instance.placement.transform);
            scene.push(crate::cpu::accel::SceneInstance::new(
                gas.data(),
                object_to_world,
                instance.placement.custom_index,
                instance.placement.mask,
                instance.placement.sbt_offset,
                instance.placement.flags,
            ));
        }
        let data = Arc::new(crate::cpu::accel::SceneData::build(scene));
        let size = data.size();
        self.sizes = AccelSizes { structure: size, build_scratch: 0, update_scratch: 0 };
        self.gases = instances.iter().map(|i| i.accel.clone()).collect();
        self.primitives = primitive_data(instances);
        self.reach = Arc::new(hit_reach(instances));
        let over = self.gases.iter().map(|g| (g.version().clone(), g.version().load(Ordering::Acquire))).collect();
        let check = crate::validate::handles::LiveIas { over, reach: self.reach.clone() };
        ctx.scenes().insert(*address, crate::cpu::LiveScene { data, check });
        Ok(())
    }

    /// Rebuilds the IAS over `instances` with its options; the count may change.
    /// The handle changes: put the new [`Ias::handle`] in the launch params.
    pub fn rebuild(&mut self, instances: &[Instance]) -> Result<()> {
        *self = Ias::builder(instances).options(self.options).build(&self.repr.context())?;
        Ok(())
    }

    /// The handle device programs trace against (put it in the launch params).
    #[doc(alias("OptixTraversableHandle"))]
    pub fn handle(&self) -> Traversable {
        // SAFETY: the address of this live, built IAS; launches check it is still
        // alive and up to date when they are submitted (see `crate::validate::handles`).
        unsafe { Traversable::from_device_address(self.repr.address()) }
    }

    /// How many hit records an SBT needs for traces of ray type `R` into this
    /// IAS: one more than the highest record index
    /// `sbt_offset + (geometries − 1) × R::SBT_STRIDE + R::SBT_OFFSET` over its
    /// instances (those with a mask of 0, which no ray hits, left out).
    pub fn hit_records_for<R: raykit_device::RayType>(&self) -> u64 {
        self.reach.furthest(R::SBT_STRIDE, R::SBT_OFFSET).map_or(0, |(_, slot)| slot + 1)
    }

    /// Number of instances.
    pub fn instance_count(&self) -> usize {
        self.gases.len()
    }

    /// Bytes of device memory the structure takes.
    pub fn size(&self) -> u64 {
        match &self.repr {
            IasRepr::Vulkan(accel) => accel.size,
            IasRepr::Cpu { .. } => self.sizes.structure,
        }
    }

    /// The sizes the driver reported for the build.
    pub fn build_sizes(&self) -> AccelSizes {
        self.sizes
    }
}

impl Drop for Ias {
    fn drop(&mut self) {
        // Launches refuse its handle from now on; the structure itself waits for
        // the pending work that may trace it (see `crate::timeline`).
        match &self.repr {
            IasRepr::Vulkan(accel) => accel.ctx.traversables.remove(accel.address),
            IasRepr::Cpu { ctx, address } => {
                ctx.scenes().remove(address);
            }
        }
    }
}

impl std::fmt::Debug for Ias {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Ias").field("instances", &self.gases.len()).field("size", &self.size()).finish()
    }
}

/// What `instances` can select in the SBT's hit region. Instances with a mask of 0
/// are never hit and select no record.
fn hit_reach(instances: &[Instance]) -> HitReach {
    HitReach::from_parts(
        instances.iter().map(|i| (i.placement.sbt_offset, i.geometries, i.placement.mask, i.procedural)),
    )
}
