//! The shader binding table: typed records, OptiX's `SbtRecord<T>`.
//!
//! Each record is a program group's handle (`shaderGroupHandleSize` bytes, read
//! from the pipeline) followed by the group's data `T` (any `bytemuck::Pod` type,
//! or a type that derives [`SbtRecordData`](macro@raykit_device::SbtRecordData)),
//! which the device program reads with `#[record] data: &T`. Strides and region offsets follow the
//! device's `shaderGroupHandleAlignment` and `shaderGroupBaseAlignment`; a region's
//! stride fits its largest record. See
//! [the SBT chapter of the Vulkan spec](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#shader-binding-table).
//!
//! # Records fit their programs
//! [`SbtBuilder::build`] refuses a record whose data is smaller than what a
//! program of its group reads (`SbtError::RecordTooSmall`), for Rust, GLSL and
//! WGSL programs alike, and an SBT with fewer callables than the constant
//! callable indices its programs call (`SbtError::CallableMissing`); launches
//! refuse a hit group of the wrong kind for the geometry that selects it
//! (`LaunchError::HitGroupKind`).
//!
//! # Handles in records
//! The `Buffer<T>` and `Traversable` fields of records whose data type derives
//! `SbtRecordData` are recorded by the builder and by [`Sbt::update`], and every
//! launch checks them against the context's live objects as it checks the launch
//! params' (see [`crate::validate::handles`]): a dropped, foreign or stale handle is
//! [`LaunchError::InvalidHandle`](crate::LaunchError::InvalidHandle) naming the region, the record's index and the field.
//! Handles in records of plain `Pod` types, and handles stored inside buffers,
//! reach the device unchecked.

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::error::{LinkError, SbtError};
use crate::pipeline::{Pipeline, PipelineRepr};
use crate::program_group::{GroupKind, ProgramGroup};
use crate::types::sbt::PlainRecord;
pub use crate::types::sbt::{region_layout, RegionLayout, SbtRegion};
use crate::validate::handles::HandleField;
use crate::validate::launch::{CheckedRecord, SbtChecks};
use crate::validate::link::PipelineInfo;
use crate::validate::records::{check_record_sizes, HitKinds, RecordData};
use crate::vulkan::sbt::VulkanSbt;
use raykit_device::{RayType, SbtRecordData};

/// One SBT record before packing: a group and its data.
#[derive(Debug)]
#[doc(alias("optixSbtRecordPackHeader"))]
pub struct SbtRecord<'g, T: SbtRecordData> {
    /// The program group whose handle heads the record.
    pub group: &'g ProgramGroup,
    /// The record's data.
    pub data: T,
}

impl<'g, T: SbtRecordData> SbtRecord<'g, T> {
    /// A record of `group` carrying `data`.
    pub fn new(group: &'g ProgramGroup, data: T) -> Self {
        SbtRecord { group, data }
    }
}

/// A record in type-erased form.
#[derive(Debug)]
struct PackedRecord {
    group_index: usize,
    data: Vec<u8>,
    /// The data's type, which [`Sbt::update`] must be given again.
    data_type: DataType,
    /// The handle fields of the data, which launches check.
    handles: Vec<HandleField>,
}

/// The type of a record's data: its id and its name for errors.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
struct DataType {
    id: std::any::TypeId,
    name: &'static str,
}

impl DataType {
    fn of<T: 'static>() -> DataType {
        DataType { id: std::any::TypeId::of::<T>(), name: std::any::type_name::<T>() }
    }
}

/// The SBT offset ([`Instance::sbt_offset`](crate::Instance::sbt_offset)) of an
/// instance whose first geometry takes geometry slot `first_slot` (see
/// [`SbtBuilder::hit_for`]), for a scene whose ray types have `R::SBT_STRIDE`:
/// `first_slot × R::SBT_STRIDE`, the number of hit records before it. `None` when
/// it does not fit the instance's 24 bits.
pub fn instance_sbt_offset<R: RayType>(first_slot: u32) -> Option<u32> {
    first_slot.checked_mul(R::SBT_STRIDE).filter(|offset| *offset < 1 << 24)
}

/// The hit record a trace of ray type `R` selects for geometry `geometry` (its
/// index in its GAS) of an instance with SBT offset `instance_offset`: Vulkan's
/// `instance_offset + geometry × R::SBT_STRIDE + R::SBT_OFFSET`.
/// Vulkan reads the low 24 bits of the instance offset and the low 4 of the
/// stride and offset, and so does this.
pub fn hit_record_index<R: RayType>(instance_offset: u32, geometry: u32) -> u64 {
    crate::types::sbt::selected_hit_record(instance_offset, geometry, R::SBT_STRIDE, R::SBT_OFFSET)
}

/// Builds an [`Sbt`] for one pipeline.
#[must_use]
#[doc(alias("optixSbtRecordPackHeader"))]
pub struct SbtBuilder<'p, P: raykit_device::LaunchParams> {
    pipeline: &'p Pipeline<P>,
    raygen: Option<PackedRecord>,
    miss: BTreeMap<usize, PackedRecord>,
    hit: BTreeMap<usize, PackedRecord>,
    callable: Vec<PackedRecord>,
    error: Option<Error>,
}

/// The error for an index past what `region` may hold (see [`crate::validate::max_records`]).
fn out_of_range(region: SbtRegion, index: String) -> Error {
    let bits = match region {
        SbtRegion::Hit => 24,
        SbtRegion::Raygen => 0,
        SbtRegion::Miss | SbtRegion::Callable => 16,
    };
    Error::Sbt(SbtError::IndexOutOfRange { region, index, limit: crate::validate::max_records(region), bits })
}

/// Puts `record` at `index` of `region`; a taken slot or an index past the
/// region's limit is an error.
fn place(
    slots: &mut BTreeMap<usize, PackedRecord>,
    index: usize,
    record: PackedRecord,
    region: SbtRegion,
) -> Result<()> {
    if index >= crate::validate::max_records(region) {
        return Err(out_of_range(region, index.to_string()));
    }
    if slots.contains_key(&index) {
        return Err(Error::Sbt(SbtError::SlotTaken { region, index }));
    }
    slots.insert(index, record);
    Ok(())
}

/// The number of slots of `slots` up to its last filled one.
fn slot_count(slots: &BTreeMap<usize, PackedRecord>) -> usize {
    slots.keys().next_back().map_or(0, |last| last + 1)
}

impl<'p, P: raykit_device::LaunchParams> SbtBuilder<'p, P> {
    fn pack<T: SbtRecordData>(&mut self, group: &ProgramGroup, data: &T, region: SbtRegion) -> Option<PackedRecord> {
        if self.error.is_some() {
            return None;
        }
        let expected = region.group_kind();
        if group.kind() != expected {
            self.error = Some(Error::Sbt(SbtError::GroupKind { region, expected, actual: group.kind() }));
            return None;
        }
        let Some(group_index) = self.pipeline.group_index(group) else {
            self.error = Some(Error::Link(LinkError::GroupNotInPipeline { kind: group.kind() }));
            return None;
        };
        Some(PackedRecord {
            group_index,
            data: data.record_bytes().to_vec(),
            data_type: DataType::of::<T>(),
            handles: crate::validate::handles::record_handle_fields::<T>(),
        })
    }

    /// The raygen record (exactly one; a second replaces the first).
    pub fn raygen<T: SbtRecordData>(mut self, group: &ProgramGroup, data: T) -> Self {
        if let Some(r) = self.pack(group, &data, SbtRegion::Raygen) {
            self.raygen = Some(r);
        }
        self
    }

    /// Appends a miss record at the end of the miss region.
    pub fn miss<T: SbtRecordData>(self, group: &ProgramGroup, data: T) -> Self {
        let index = slot_count(&self.miss);
        self.miss_at(index, group, data)
    }

    /// Places a miss record at miss index `index`.
    pub fn miss_at<T: SbtRecordData>(mut self, index: usize, group: &ProgramGroup, data: T) -> Self {
        if let Some(r) = self.pack(group, &data, SbtRegion::Miss) {
            if let Err(e) = place(&mut self.miss, index, r, SbtRegion::Miss) {
                self.error = Some(e);
            }
        }
        self
    }

    /// Places ray type `R`'s miss record where `trace::<R>` looks for it
    /// (`R::MISS_INDEX`).
    /// A group whose program was declared for another ray type
    /// (`#[miss(ray = Other)]`) is refused.
    pub fn miss_for<R: RayType, T: SbtRecordData>(mut self, group: &ProgramGroup, data: T) -> Self {
        self.check_ray::<R>(group, SbtRegion::Miss);
        // A trace reads the low 16 bits of the miss index (as Vulkan does).
        self.miss_at((R::MISS_INDEX & 0xffff) as usize, group, data)
    }

    /// Records an error when a program of `group` was declared for a ray type that
    /// places its records elsewhere than `R`.
    fn check_ray<R: RayType>(&mut self, group: &ProgramGroup, region: SbtRegion) {
        if self.error.is_some() {
            return;
        }
        for program in group.programs() {
            let Some(ray) = program.ray else { continue };
            if !ray.places_like::<R>() {
                let kind = match program.kind {
                    raykit_device::ProgramKind::Miss => "miss",
                    raykit_device::ProgramKind::AnyHit => "any_hit",
                    _ => "closest_hit",
                };
                self.error = Some(Error::Sbt(SbtError::RayTypeMismatch {
                    region,
                    program: program.name.to_string_lossy().into_owned(),
                    kind,
                    declared: ray.name,
                    asked: std::any::type_name::<R>().rsplit("::").next().unwrap_or("R"),
                }));
                return;
            }
        }
    }

    /// Appends a hit record at the end of the hit region.
    pub fn hit<T: SbtRecordData>(self, group: &ProgramGroup, data: T) -> Self {
        let index = slot_count(&self.hit);
        self.hit_at(index, group, data)
    }

    /// Places a hit record at index `index` of the hit region.
    pub fn hit_at<T: SbtRecordData>(mut self, index: usize, group: &ProgramGroup, data: T) -> Self {
        if let Some(r) = self.pack(group, &data, SbtRegion::Hit) {
            if let Err(e) = place(&mut self.hit, index, r, SbtRegion::Hit) {
                self.error = Some(e);
            }
        }
        self
    }

    /// Places ray type `R`'s hit record for geometry slot `geometry` where
    /// `trace::<R>` looks for it: `geometry × R::SBT_STRIDE + R::SBT_OFFSET`,
    /// each of the two taken to its low 4 bits as traces read them.
    /// A geometry slot is a geometry's place among all geometries of the scene
    /// that have records: an instance whose geometries take slots `k, k + 1, …`
    /// has the SBT offset [`instance_sbt_offset::<R>(k)`](instance_sbt_offset)
    /// (`k × R::SBT_STRIDE`, counted in records, as Vulkan adds it), and its
    /// geometry `g` takes slot `k + g`.
    /// A group whose programs were declared for another ray type
    /// (`#[closest_hit(ray = Other)]`) is refused.
    pub fn hit_for<R: RayType, T: SbtRecordData>(mut self, geometry: usize, group: &ProgramGroup, data: T) -> Self {
        self.check_ray::<R>(group, SbtRegion::Hit);
        // A trace reads the low 4 bits of the stride and offset (as Vulkan does).
        let (stride, offset) = ((R::SBT_STRIDE & 0xf) as usize, (R::SBT_OFFSET & 0xf) as usize);
        match geometry.checked_mul(stride).and_then(|i| i.checked_add(offset)) {
            Some(index) => self.hit_at(index, group, data),
            None => {
                if self.error.is_none() {
                    let index = format!(
                        "{geometry} × {} + {} (geometry × SBT_STRIDE + SBT_OFFSET)",
                        R::SBT_STRIDE,
                        R::SBT_OFFSET
                    );
                    self.error = Some(out_of_range(SbtRegion::Hit, index));
                }
                self
            }
        }
    }

    /// Appends a callable record; the n-th call is callable index n (the
    /// `sbt_index` of `ctx.call(sbt_index, data)` on the device).
    pub fn callable<T: SbtRecordData>(mut self, group: &ProgramGroup, data: T) -> Self {
        if let Some(r) = self.pack(group, &data, SbtRegion::Callable) {
            if self.callable.len() >= crate::validate::max_records(SbtRegion::Callable) {
                self.error = Some(out_of_range(SbtRegion::Callable, self.callable.len().to_string()));
            } else {
                self.callable.push(r);
            }
        }
        self
    }

    /// Appends an [`SbtRecord`] to the region its group's kind belongs to.
    pub fn record<T: SbtRecordData>(self, record: SbtRecord<'_, T>) -> Self {
        match record.group.kind() {
            GroupKind::Raygen => self.raygen(record.group, record.data),
            GroupKind::Miss => self.miss(record.group, record.data),
            GroupKind::Hit => self.hit(record.group, record.data),
            // Refused by `callable`: raykit places the exception record itself.
            GroupKind::Callable | GroupKind::Exception => self.callable(record.group, record.data),
        }
    }

    /// Packs the records into a buffer on the device.
    #[doc(alias("optixSbtRecordPackHeader", "vkGetRayTracingShaderGroupHandlesKHR"))]
    pub fn build(self) -> Result<Sbt> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let raygen = self.raygen.ok_or(Error::Sbt(SbtError::Missing { region: SbtRegion::Raygen }))?;
        // A hole would hand the device an empty record: refuse it.
        let filled = |slots: BTreeMap<usize, PackedRecord>, region: SbtRegion| -> Result<Vec<PackedRecord>> {
            let mut records = Vec::with_capacity(slots.len());
            for (expected, (index, record)) in slots.into_iter().enumerate() {
                if index != expected {
                    return Err(Error::Sbt(SbtError::Hole { region, index: expected }));
                }
                records.push(record);
            }
            Ok(records)
        };
        let miss = filled(self.miss, SbtRegion::Miss)?;
        let hit = filled(self.hit, SbtRegion::Hit)?;
        // The checks of the records against what the programs trace and call, the
        // same on every backend.
        let pipeline = self.pipeline;
        let info = &pipeline.info;
        let has = |kind: GroupKind| info.has_group(kind);
        info.reach.check_sbt(has(GroupKind::Miss), miss.len(), has(GroupKind::Hit), hit.len())?;
        info.reach.check_callables(has(GroupKind::Callable), self.callable.len())?;
        let (limits, exception_group, needs) = (info.limits, info.exception_group(), &info.needs[..]);
        for (region, records) in
            SbtRegion::ALL.into_iter().zip([std::slice::from_ref(&raygen), &miss[..], &hit[..], &self.callable[..]])
        {
            let data = records.iter().map(|r| RecordData { group: r.group_index, bytes: r.data.len() });
            check_record_sizes(needs, region, data)?;
        }
        let hit_kinds =
            HitKinds::new(hit.iter().map(|r| needs.get(r.group_index).is_some_and(|n| n.procedural)).collect());
        let max_data = |records: &[PackedRecord]| records.iter().map(|r| r.data.len()).max().unwrap_or(0);
        let check = |layout: RegionLayout, data: usize| -> Result<RegionLayout> {
            if layout.stride > limits.max_shader_group_stride as u64 {
                return Err(Error::Sbt(SbtError::RecordTooLarge {
                    size: data,
                    stride: layout.stride,
                    limit: limits.max_shader_group_stride,
                }));
            }
            Ok(layout)
        };
        let raygen_records = std::slice::from_ref(&raygen);
        let rg = check(region_layout(&limits, 0, 1, raygen.data.len()), raygen.data.len())?;
        let ms = check(region_layout(&limits, rg.offset + rg.size, miss.len(), max_data(&miss)), max_data(&miss))?;
        let ht = check(region_layout(&limits, ms.offset + ms.size, hit.len(), max_data(&hit)), max_data(&hit))?;
        // The exception program, if the pipeline has one, goes after the user's
        // callables; its index reaches the device through the exception buffer.
        let mut callable = self.callable;
        let exception_index = match exception_group {
            Some(group_index) => {
                callable.push(PackedRecord {
                    group_index,
                    data: Vec::new(),
                    data_type: DataType::of::<()>(),
                    handles: Vec::new(),
                });
                Some(callable.len() as u32 - 1)
            }
            None => None,
        };
        let cl = check(
            region_layout(&limits, ht.offset + ht.size, callable.len(), max_data(&callable)),
            max_data(&callable),
        )?;
        let total = cl.offset + cl.size;
        let mut checked = Vec::new();
        for (region, records) in SbtRegion::ALL.into_iter().zip([raygen_records, &miss[..], &hit[..], &callable[..]]) {
            for (index, record) in records.iter().enumerate().filter(|(_, r)| !r.handles.is_empty()) {
                checked.push(CheckedRecord {
                    region,
                    index,
                    fields: record.handles.clone(),
                    data: record.data.clone(),
                });
            }
        }
        let layouts = [rg, ms, ht, cl];
        let counts = [1, miss.len(), hit.len(), callable.len()];
        let data_types = [raygen_records, &miss[..], &hit[..], &callable[..]]
            .map(|records| records.iter().map(|r| r.data_type).collect());
        fn plain(records: &[PackedRecord]) -> Vec<PlainRecord<'_>> {
            records.iter().map(|r| PlainRecord { group: r.group_index, data: &r.data }).collect()
        }
        let regions = [plain(raygen_records), plain(&miss), plain(&hit), plain(&callable)];
        // Checked: each backend packs the records as they are.
        let repr = match &pipeline.repr {
            PipelineRepr::Vulkan(inner) => {
                SbtRepr::Vulkan(VulkanSbt::new(inner, &regions, layouts, total, exception_index)?)
            }
            PipelineRepr::Cpu(data) => SbtRepr::Cpu(Arc::new(crate::cpu::program::SbtData::new(data, &regions))),
        };
        let handle_size = limits.shader_group_handle_size as u64;
        let pipeline = pipeline.info.clone();
        Ok(Sbt { repr, pipeline, handle_size, layouts, counts, data_types, exception_index, checked, hit_kinds })
    }
}

impl<P: raykit_device::LaunchParams> fmt::Debug for SbtBuilder<'_, P> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SbtBuilder")
            .field("raygen", &self.raygen.is_some())
            .field("miss", &self.miss.len())
            .field("hit", &self.hit.len())
            .field("callable", &self.callable.len())
            .field("error", &self.error)
            .finish()
    }
}

/// Where an [`Sbt`]'s records are.
pub(crate) enum SbtRepr {
    /// In a Vulkan buffer.
    Vulkan(VulkanSbt),
    /// In host memory, for the CPU backend (launches running hold their own `Arc`).
    Cpu(Arc<crate::cpu::program::SbtData>),
}

/// A shader binding table on the device, made for one pipeline.
#[doc(alias("OptixShaderBindingTable", "VkStridedDeviceAddressRegionKHR"))]
pub struct Sbt {
    pub(crate) repr: SbtRepr,
    /// The pipeline it was made for.
    pub(crate) pipeline: Arc<PipelineInfo>,
    /// Bytes of the group handle at the head of each record.
    handle_size: u64,
    layouts: [RegionLayout; 4],
    /// Record counts per region (raygen, miss, hit, callable).
    counts: [usize; 4],
    /// The data type of each record, per region.
    data_types: [Vec<DataType>; 4],
    /// The exception program's index in the callable region, if the pipeline has one.
    pub(crate) exception_index: Option<u32>,
    /// The records whose data holds handles, which launches check.
    pub(crate) checked: Vec<CheckedRecord>,
    /// The kinds of its hit groups, which launches check against the scene.
    hit_kinds: HitKinds,
}

impl Sbt {
    /// Starts an SBT for `pipeline`.
    #[doc(alias("optixSbtRecordPackHeader", "OptixShaderBindingTable"))]
    pub fn builder<P: raykit_device::LaunchParams>(pipeline: &Pipeline<P>) -> SbtBuilder<'_, P> {
        SbtBuilder {
            pipeline,
            raygen: None,
            miss: BTreeMap::new(),
            hit: BTreeMap::new(),
            callable: Vec::new(),
            error: None,
        }
    }

    /// Overwrites the data of record `index` of `region` (the group stays),
    /// without rebuilding the SBT or the pipeline — OptiX's way of changing a
    /// material between launches. `data` must be of the type the record was built
    /// with. Launches already submitted keep the records they were given: while
    /// one is in flight, the update goes into a copy of the SBT that later launches
    /// use (the old one is freed once those launches finish, see [`crate::timeline`]).
    /// The handles in data of a type that derives `SbtRecordData` are checked by
    /// every launch from now on (see the [module docs](self)).
    pub fn update<T: SbtRecordData>(&mut self, region: SbtRegion, index: usize, data: T) -> Result<()> {
        let r = region.index();
        if index >= self.counts[r] {
            return Err(Error::Sbt(SbtError::Update {
                region,
                reason: format!("index {index} is past the region's {} record(s)", self.counts[r]),
            }));
        }
        let built = self.data_types[r][index];
        if built != DataType::of::<T>() {
            return Err(Error::Sbt(SbtError::Update {
                region,
                reason: format!(
                    "record {index} holds `{}`, not `{}`; pass data of the type the record was built with",
                    built.name,
                    std::any::type_name::<T>()
                ),
            }));
        }
        let layout = self.layouts[r];
        let handle = self.handle_size;
        let room = layout.stride - handle;
        let bytes = data.record_bytes();
        if bytes.len() as u64 > room {
            return Err(Error::Sbt(SbtError::Update {
                region,
                reason: format!(
                    "{} bytes of data do not fit the region's {room}-byte records; build a new SBT for larger data",
                    bytes.len()
                ),
            }));
        }
        let at = (layout.offset + layout.stride * index as u64 + handle) as usize;
        // The same type as at the build: the same handle fields, with new values.
        if let Some(checked) = self.checked.iter_mut().find(|c| c.region == region && c.index == index) {
            checked.data.clear();
            checked.data.extend_from_slice(bytes);
        }
        match &mut self.repr {
            SbtRepr::Vulkan(sbt) => sbt.write(region, at, bytes),
            SbtRepr::Cpu(data) => {
                // Launches running hold the old records; later ones get these.
                Arc::make_mut(data).regions[r][index].data.write(bytes);
                Ok(())
            }
        }
    }

    /// The raygen, miss, hit and callable regions passed to `vkCmdTraceRaysKHR`, for
    /// hand-written Vulkan (see [`crate::pipeline::raw`]); `None` on the CPU backend.
    pub fn raw_regions(&self) -> Option<[vk::StridedDeviceAddressRegionKHR; 4]> {
        match &self.repr {
            SbtRepr::Vulkan(sbt) => Some(sbt.regions()),
            SbtRepr::Cpu(_) => None,
        }
    }

    /// Layouts of the raygen, miss, hit and callable regions.
    pub fn region_layouts(&self) -> [RegionLayout; 4] {
        self.layouts
    }

    /// How many records `region` holds (for the callable region, the exception
    /// program's record that raykit adds included).
    pub fn record_count(&self, region: SbtRegion) -> usize {
        self.counts[region.index()]
    }

    /// What a launch with this SBT checks: its records with handles and its hit record count.
    pub(crate) fn checks(&self) -> SbtChecks<'_> {
        SbtChecks { records: &self.checked, hit_records: self.record_count(SbtRegion::Hit), hit_kinds: &self.hit_kinds }
    }
}

impl fmt::Debug for Sbt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut s = f.debug_struct("Sbt");
        for region in SbtRegion::ALL {
            let r = region.index();
            s.field(region.name(), &format_args!("{} record(s), {:?}", self.counts[r], self.layouts[r]));
        }
        s.field("exception_index", &self.exception_index).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::context::DeviceLimits;

    fn limits(handle: u32, handle_align: u32, base_align: u32) -> DeviceLimits {
        DeviceLimits {
            shader_group_handle_size: handle,
            shader_group_handle_alignment: handle_align,
            shader_group_base_alignment: base_align,
            max_shader_group_stride: 4096,
            max_ray_recursion_depth: 31,
            max_ray_dispatch_invocation_count: 1 << 30,
            max_ray_hit_attribute_size: 32,
            max_push_constants_size: 128,
            max_uniform_buffer_range: 65536,
            max_storage_buffer_range: 1 << 27,
            min_uniform_buffer_offset_alignment: 256,
            min_scratch_alignment: 128,
            max_geometry_count: 1 << 24,
            max_primitive_count: 1 << 29,
            max_instance_count: 1 << 24,
        }
    }

    #[test]
    fn strides_fit_the_largest_record_and_the_handle_alignment() {
        let l = limits(32, 32, 64);
        assert_eq!(region_layout(&l, 0, 1, 0), RegionLayout { offset: 0, stride: 32, size: 32 });
        // 32-byte handle + 12-byte Vec3 → 44 → 64 with 32-byte handle alignment.
        assert_eq!(region_layout(&l, 32, 2, 12), RegionLayout { offset: 64, stride: 64, size: 128 });
        assert_eq!(region_layout(&l, 192, 0, 100).size, 0);
    }

    struct Radiance;
    impl RayType for Radiance {
        type Payload = u32;
        const SBT_STRIDE: u32 = 2;
    }
    struct Shadow;
    impl RayType for Shadow {
        type Payload = u32;
        const SBT_OFFSET: u32 = 1;
        const SBT_STRIDE: u32 = 2;
        const MISS_INDEX: u32 = 1;
    }

    /// `instance_sbt_offset` and `hit_for` agree with Vulkan's formula: the record a
    /// trace selects is the one `hit_for` placed.
    #[test]
    fn instance_offsets_and_hit_for_agree_with_the_trace_formula() {
        // An instance whose two geometries take slots 3 and 4.
        let offset = instance_sbt_offset::<Radiance>(3).unwrap_or(u32::MAX);
        assert_eq!(offset, 6);
        for g in 0..2u32 {
            let slot = 3 + g as usize;
            assert_eq!(hit_record_index::<Radiance>(offset, g), (slot * 2) as u64);
            assert_eq!(hit_record_index::<Shadow>(offset, g), (slot * 2 + 1) as u64);
        }
        assert_eq!(instance_sbt_offset::<Radiance>(1 << 23), None);
    }

    #[test]
    fn regions_start_on_the_base_alignment() {
        let l = limits(32, 16, 256);
        let r = region_layout(&l, 1, 3, 4);
        assert_eq!(r.offset, 256);
        assert_eq!(r.stride, 48);
        assert_eq!(r.size, 144);
    }
}
