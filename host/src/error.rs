//! raykit's error type: every failure names what went wrong and, where there is
//! one, the fix.

use ash::vk;
use raykit_device::ProgramKind;

use crate::types::group::GroupKind;
use crate::types::sbt::SbtRegion;

/// Result with raykit's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Why a physical device cannot run raykit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceReport {
    /// The device's name as the driver reports it.
    pub name: String,
    /// Device type (discrete GPU, CPU, …).
    pub device_type: String,
    /// The Vulkan version it supports, `major.minor.patch`.
    pub api_version: String,
    /// Extensions and features it lacks; empty when the device is usable.
    pub missing: Vec<String>,
}

impl std::fmt::Display for DeviceReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, Vulkan {})", self.name, self.device_type, self.api_version)?;
        if self.missing.is_empty() {
            write!(f, ": usable")
        } else {
            write!(f, ": lacks {}", self.missing.join(", "))
        }
    }
}

fn list_devices(devices: &[DeviceReport]) -> String {
    if devices.is_empty() {
        return "no Vulkan devices at all".to_owned();
    }
    devices.iter().map(|d| format!("\n  - {d}")).collect()
}

/// Why raykit needs `VK_EXT_robustness2`, and the fix, when a device lacks it.
fn robustness_hint(devices: &[DeviceReport]) -> &'static str {
    let lacks = devices
        .iter()
        .flat_map(|d| &d.missing)
        .any(|m| m.contains("VK_EXT_robustness2") || m.contains("robustBufferAccess2") || m.contains("nullDescriptor"));
    if lacks {
        "\nVK_EXT_robustness2 with robustBufferAccess2 and nullDescriptor is required: device programs index buffers \
         without bounds checks, and rely on it for a read through a null, dropped or never-written handle, or past a \
         buffer's end, to give zero (and such a write to be discarded). Update the GPU driver to one that has it \
         (NVIDIA's, Mesa ≥ 25)."
    } else {
        ""
    }
}

fn list_entry_points(entries: &[(String, Option<ProgramKind>)]) -> String {
    if entries.is_empty() {
        return "none".to_owned();
    }
    entries
        .iter()
        .map(|(name, kind)| match kind {
            Some(kind) => format!("`{name}` ({kind})"),
            None => format!("`{name}` (not a ray-tracing stage)"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// One user exception thrown by a device program (`ctx.throw_exception`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct UserException {
    /// The code the program threw.
    pub code: u32,
    /// The launch index of the invocation that threw it.
    pub launch_index: [u32; 3],
}

fn list_exceptions(exceptions: &[UserException]) -> String {
    let shown: Vec<String> =
        exceptions.iter().take(8).map(|e| format!("code {:#x} at {:?}", e.code, e.launch_index)).collect();
    shown.join(", ")
}

fn list_indices(indices: &[[u32; 3]]) -> String {
    let shown: Vec<String> = indices.iter().take(8).map(|i| format!("{i:?}")).collect();
    let more = if indices.len() > 8 { format!(" and {} more", indices.len() - 8) } else { String::new() };
    format!("{}{more}", shown.join(", "))
}

/// Everything that can go wrong in raykit.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Something that only the Vulkan backend has was asked of a context of the
    /// CPU backend (see [`crate::cpu`]).
    #[error("{what} is not available on the CPU backend: {why}; {fix}")]
    NotOnCpuBackend {
        /// What was asked.
        what: &'static str,
        /// Why the CPU backend has no such thing.
        why: &'static str,
        /// What to do instead.
        fix: &'static str,
    },

    /// A device program panicked (a failed `assert!`, an index out of bounds, an
    /// explicit `panic!`) while the CPU backend ran it: the launch stopped.
    #[error("device program `{program}` panicked at launch index {launch_index:?}: {message}")]
    ProgramPanicked {
        /// The program's entry-point name.
        program: String,
        /// The launch index of the invocation that panicked.
        launch_index: [u32; 3],
        /// The panic's message.
        message: String,
    },

    /// A device program asked the CPU backend for something the device leaves
    /// undefined: a trace into a traversable that is no live IAS, a record past
    /// the end of an SBT region, a payload or callable data of another type than
    /// the receiving program's. The launch stopped.
    #[error("device program `{program}` at launch index {launch_index:?}: {problem}")]
    CpuLaunchFault {
        /// The program running when it happened.
        program: String,
        /// The launch index of the invocation.
        launch_index: [u32; 3],
        /// What went wrong, and how to fix it.
        problem: String,
    },

    /// A program linked on the CPU backend takes a value of another type than
    /// the pipeline gives it, or of a type the backend cannot hold.
    #[error("program `{program}` takes {what} of type {declared}, but the pipeline gives {given}; use one type on both sides")]
    CpuTypeMismatch {
        /// The program's entry-point name.
        program: String,
        /// What the value is (launch params, record data, hit attributes).
        what: &'static str,
        /// The type the program declares.
        declared: &'static str,
        /// What it is given instead.
        given: String,
    },

    /// The CPU backend's thread pool could not be made.
    #[error("cannot start the CPU backend's threads: {reason}")]
    CpuThreads {
        /// What the system said.
        reason: String,
    },

    /// The Vulkan loader (`libvulkan.so.1`) could not be loaded.
    #[error("cannot load the Vulkan loader: {0}. Install it (Debian: `apt-get install libvulkan1`) or run `cargo xtask test`, which installs what is missing")]
    LoaderMissing(String),

    /// No physical device supports Vulkan ray-tracing pipelines.
    #[error("no Vulkan device with ray-tracing pipelines and the features raykit needs; devices seen:{}{}\nOn a machine without a GPU, install Mesa ≥ 25 lavapipe (Debian bookworm: `mesa-vulkan-drivers` from bookworm-backports) — `cargo xtask test` does this when run as root; or run the programs on the CPU backend (`ContextOptions::backend`, `RAYKIT_BACKEND=cpu`)", list_devices(.devices), robustness_hint(.devices))]
    NoRayTracingDevice {
        /// Each device seen, with what it lacks.
        devices: Vec<DeviceReport>,
    },

    /// A Vulkan call failed.
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan {
        /// The function that failed.
        call: &'static str,
        /// Its result code.
        result: vk::Result,
    },

    /// Device memory could not be allocated.
    #[error("allocating {what}: {source}; drop buffers and acceleration structures that are no longer needed, or make smaller ones")]
    Allocation {
        /// What the memory was for.
        what: &'static str,
        /// The allocator's error.
        #[source]
        source: gpu_allocator::AllocationError,
    },

    /// The bytes given as a module are not a SPIR-V module.
    #[error("not a SPIR-V module: {reason}. Give the `.spv` file that `cargo xtask build-shaders` writes under target/spirv/")]
    InvalidSpirv {
        /// What is wrong with them.
        reason: String,
    },

    /// A SPIR-V file could not be read.
    #[error("reading SPIR-V file {path}: {source}. Run `cargo xtask build-shaders` to build the device crates")]
    SpirvFile {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },

    /// The SPIR-V of a device crate was not found where `cargo xtask build-shaders` writes it.
    #[error("no SPIR-V for device crate `{crate_name}`; looked at: {}. {}", .tried.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "), match .spirv_dir {
        Some(dir) => format!("RAYKIT_SPIRV_DIR is set to {}: point it at the folder that holds the `.spv` files, or unset it; build them with `cargo xtask build-shaders`", dir.display()),
        None => "Build them with `cargo xtask build-shaders` (it writes target/spirv/), or set RAYKIT_SPIRV_DIR to the folder that holds them".to_owned(),
    })]
    SpirvNotFound {
        /// The device crate.
        crate_name: String,
        /// Every path looked at.
        tried: Vec<std::path::PathBuf>,
        /// `RAYKIT_SPIRV_DIR`, when set.
        spirv_dir: Option<std::path::PathBuf>,
    },

    /// Validation was asked for but the Khronos validation layer is not installed.
    #[error("validation requested but VK_LAYER_KHRONOS_validation is not installed (Debian: `apt-get install vulkan-validationlayers`)")]
    ValidationLayerMissing,

    /// The module declares a SPIR-V extension whose device extension this device
    /// lacks.
    #[error("the module uses SPIR-V extension {spirv_extension}, which needs {device_extension}; this device lacks it. {fix}")]
    SpirvExtensionUnsupported {
        /// The `OpExtension` name.
        spirv_extension: String,
        /// The Vulkan device extension it needs.
        device_extension: &'static str,
        /// What to do instead.
        fix: &'static str,
    },

    /// The module has no ray-tracing entry point at all.
    #[error("the SPIR-V module has no ray-tracing entry points (raygen, miss, closest-hit, any-hit, intersection, callable); it has: {}. Compile the programs as ray-tracing stages (`#[raygen]`, `#[miss]`, … in Rust; `.rgen`, `.rmiss`, … in GLSL)", list_entry_points(.available))]
    NoRayTracingEntryPoints {
        /// The entry points it has.
        available: Vec<(String, Option<ProgramKind>)>,
    },

    /// The module has no entry point of that name.
    #[error("module has no entry point `{name}`; it has: {}. Name one of these (Rust programs: use the entry-point constants the program macros generate)", list_entry_points(.available))]
    EntryPointNotFound {
        /// The name asked for.
        name: String,
        /// The entry points the module has, with their kinds.
        available: Vec<(String, Option<ProgramKind>)>,
    },

    /// An entry point was used as a program of the wrong kind.
    #[error("entry point `{name}` is a {actual} program, not a {expected} program (asked for by {context}); the module's entry points: {}", list_entry_points(.available))]
    ProgramKindMismatch {
        /// The entry point.
        name: String,
        /// The kind the group needs.
        expected: ProgramKind,
        /// The kind the module (or the name's OptiX prefix) says.
        actual: String,
        /// Which program-group slot asked for it.
        context: &'static str,
        /// The entry points the module has, with their kinds.
        available: Vec<(String, Option<ProgramKind>)>,
    },

    /// Objects of different contexts were combined: a pipeline's program groups,
    /// or the GASes an IAS instances.
    #[error("objects of different Contexts were combined (the program groups of one pipeline, or the GASes of an IAS); make them all with the same Context")]
    ContextMismatch,

    /// `max_trace_depth` is over the device's limit.
    #[error("max_trace_depth {requested} is over this device's maxRayRecursionDepth {limit}; restructure recursive tracing as a loop in raygen, or lower the depth")]
    TraceDepthTooLarge {
        /// What was asked for.
        requested: u32,
        /// `maxRayRecursionDepth`.
        limit: u32,
    },

    /// The pipeline has no raygen program group.
    #[error("a pipeline needs a raygen program group; add one made with ProgramGroup::raygen to Pipeline::new")]
    NoRaygen,

    /// A stack-size call graph cannot be evaluated.
    #[error("stack-size call graph: {reason}")]
    CallGraph {
        /// What is wrong with the graph.
        reason: String,
    },

    /// A stack-size choice does not fit the pipeline.
    #[error("pipeline stack size: {reason}")]
    StackSize {
        /// What does not fit, and the fix.
        reason: String,
    },

    /// The launch params do not fit in a uniform buffer.
    #[error("launch params of {size} bytes exceed this device's maxUniformBufferRange {limit}; move large data into a `Buffer<T>` and put its handle in the params")]
    ParamsTooLarge {
        /// `size_of::<P>()`.
        size: usize,
        /// `maxPushConstantsSize`.
        limit: u32,
    },

    /// A program group given to the SBT is not part of its pipeline.
    #[error("{kind} program group is not part of the pipeline the SBT is built for; add it to Pipeline::new")]
    GroupNotInPipeline {
        /// The group's kind.
        kind: GroupKind,
    },

    /// An SBT record of the wrong kind of group was given.
    #[error("SBT {region} record needs a {expected} program group, got a {actual} group")]
    SbtGroupKind {
        /// Region being filled.
        region: SbtRegion,
        /// Kind the region needs.
        expected: GroupKind,
        /// Kind given.
        actual: GroupKind,
    },

    /// A launch was given an SBT built for another pipeline.
    #[error(
        "the SBT was built for another pipeline; build one for the pipeline you launch with Sbt::builder(&pipeline)"
    )]
    SbtOfAnotherPipeline,

    /// A handle in the launch params, or in the data of an SBT record whose type
    /// derives `SbtRecordData`, does not name a live object of the launching
    /// context: a dropped or foreign buffer, a dropped or foreign IAS, or an IAS
    /// whose GASes changed since it was built.
    #[error("{}: {problem}; {fix}", handle_place(.record, .field))]
    InvalidHandle {
        /// The SBT record holding the handle (its region and index there), or
        /// `None` for a field of the launch params.
        record: Option<(SbtRegion, usize)>,
        /// The field, as a path (`scene`, `inner.buffers[2]`).
        field: String,
        /// What is wrong with it.
        problem: String,
        /// How to fix it.
        fix: &'static str,
    },

    /// An SBT region that must be present is missing.
    #[error("the SBT has no {region} record; add one with Sbt::builder(..).{region}(..)")]
    SbtMissing {
        /// The region.
        region: SbtRegion,
    },

    /// The device cannot link pipelines from libraries.
    #[error("this device lacks VK_KHR_pipeline_library, so pipelines cannot be linked from libraries; link the program groups into one pipeline with Pipeline::new (Context::supports_pipeline_libraries tells beforehand)")]
    PipelineLibrariesUnsupported,

    /// A pipeline library was given no program groups.
    #[error("a pipeline library needs at least one program group")]
    EmptyLibrary,

    /// Libraries linked into one pipeline were made with different settings.
    #[error("library {index} was made with {what} {found}, but {expected} is needed to link it with the others: every library of a pipeline and the pipeline itself must agree on {what}. {fix}")]
    LibraryMismatch {
        /// What differs: `"max_trace_depth"` or `"interface"`.
        what: &'static str,
        /// The position of the library in the list given to `Pipeline::link`.
        index: usize,
        /// What the library has.
        found: String,
        /// What the pipeline (or the first library) has.
        expected: String,
        /// How to make them agree.
        fix: &'static str,
    },

    /// A library's interface does not cover what one of its programs declares.
    #[error("`{program}` declares {needed} bytes of {what}, over the {given} bytes of the library's interface; raise LibraryOptions::interface, or leave it None to size it from the programs")]
    LibraryInterfaceTooSmall {
        /// The program.
        program: String,
        /// `"ray payload"` or `"hit attributes"`.
        what: &'static str,
        /// Bytes the program declares.
        needed: u32,
        /// Bytes of the interface.
        given: u32,
    },

    /// Hit attributes over the device's `maxRayHitAttributeSize`.
    #[error("an interface of {size} bytes of hit attributes is over this device's maxRayHitAttributeSize {limit}; report fewer attributes")]
    HitAttributesTooLarge {
        /// The bytes asked for.
        size: u32,
        /// `maxRayHitAttributeSize`.
        limit: u32,
    },

    /// One program group was put in more than one of the libraries linked together.
    #[error("a {kind} program group is in libraries {first} and {second} of this link; each group may be in one of the libraries linked together (the SBT places groups by identity)")]
    GroupInSeveralLibraries {
        /// The group's kind.
        kind: GroupKind,
        /// The first library holding it.
        first: usize,
        /// Another library holding it.
        second: usize,
    },

    /// A pipeline was given more than one exception program group.
    #[error("a pipeline has at most one exception program group (ProgramGroup::exception); link one")]
    SeveralExceptionPrograms,

    /// An SBT record could not be updated in place.
    #[error("cannot update SBT {region} record: {reason}")]
    SbtUpdate {
        /// The region.
        region: SbtRegion,
        /// Why not.
        reason: String,
    },

    /// Two records were placed in one SBT slot.
    #[error("SBT {region} slot {index} already holds a record; each ray type × geometry slot takes one (check the ray types' SBT_OFFSET/SBT_STRIDE/MISS_INDEX)")]
    SbtSlotTaken {
        /// The region.
        region: SbtRegion,
        /// The slot.
        index: usize,
    },

    /// A slot below the last filled one was left empty.
    #[error("SBT {region} slot {index} is empty, but a later slot is filled; every slot a trace can reach needs a record (add one with `{region}_at({index}, ..)` or the ray type's `{region}_for`)")]
    SbtHole {
        /// The region.
        region: SbtRegion,
        /// The empty slot.
        index: usize,
    },

    /// An SBT index is past what a trace can select, or its arithmetic overflows.
    #[error("SBT {region} index {index} is out of range: a {region} region holds at most {limit} records (Vulkan reads {bits} bits of it); use a smaller index")]
    SbtIndexOutOfRange {
        /// The region.
        region: SbtRegion,
        /// The index, or how it was computed when that overflowed.
        index: String,
        /// The most records the region may hold.
        limit: usize,
        /// How many bits of the index Vulkan reads.
        bits: u32,
    },

    /// The SBT lacks a record that a trace of its pipeline selects.
    #[error("the SBT has {have} {region} record(s), but `{program}` traces rays that select {region} record {}; add it with Sbt::builder(..).{region}_at({}, ..) (or the ray type's `{region}_for`)", .needed - 1, .needed - 1)]
    SbtIncomplete {
        /// The region.
        region: SbtRegion,
        /// How many records it needs.
        needed: usize,
        /// How many it has.
        have: usize,
        /// The program whose trace selects the missing record.
        program: String,
    },

    /// A pipeline's programs trace deeper than its `max_trace_depth`.
    #[error("`{program}` needs a trace depth of at least {needed} ({why}), but the pipeline is linked with max_trace_depth {max_trace_depth}; raise LinkOptions::max_trace_depth to the deepest recursion the programs reach")]
    TraceDepthExceeded {
        /// The program that traces.
        program: String,
        /// The least depth it needs.
        needed: u32,
        /// The depth asked for.
        max_trace_depth: u32,
        /// Why it needs it.
        why: &'static str,
    },

    /// Miss or closest-hit programs of a ray type with `RayType::CHECK_DEPTH`
    /// would have traced past the pipeline's `max_trace_depth` during a launch:
    /// the device did not make those traces (each threw
    /// `raykit_device::exception::TRACE_DEPTH_EXCEEDED` and went on without it).
    /// The launch ran to its end.
    #[error("{refused} trace(s) would have gone to depth {depth}, past the pipeline's max_trace_depth {max_trace_depth}, and were not made, at launch indices {}{} ({total} exception(s) thrown in all); raise LinkOptions::max_trace_depth to the depth the programs recurse to, or end the recursion in the program (ClosestHit::trace_depth / Miss::trace_depth give the depth)", list_indices(.launch_indices), if .user_exceptions.is_empty() { String::new() } else { format!(", and user exceptions {}", list_exceptions(.user_exceptions)) })]
    RecursionTooDeep {
        /// The pipeline's `max_trace_depth`.
        max_trace_depth: u32,
        /// The depth the refused traces would have reached (`max_trace_depth + 1`).
        depth: u32,
        /// How many refused traces were recorded.
        refused: usize,
        /// The launch index of each recorded refusal, in the order recorded.
        launch_indices: Vec<[u32; 3]>,
        /// The user exceptions recorded with them.
        user_exceptions: Vec<UserException>,
        /// How many exceptions were thrown in all (recorded or not: a launch
        /// records the first `EXCEPTION_CAPACITY`).
        total: u32,
    },

    /// A launch's scene can select a hit record past the end of the SBT's hit
    /// region: an instance's SBT offset plus its geometries (at the stride of the
    /// pipeline's traces) plus a ray type's offset reaches further than the
    /// records built (see [`crate::Instance::sbt_offset`]).
    #[error("instance {instance} of the IAS in params field `{field}` (SBT offset {sbt_offset}, {geometries} geometr{}) reaches hit record {slot} = {sbt_offset} + ({geometries} - 1) × stride {stride} + ray offset {ray_offset} (a trace in `{program}`), but the SBT has {hit_records} hit record(s); build the SBT with records up to index {slot} (SbtBuilder::hit_for::<R>(geometry slot, ..) for every ray type), or lower the instance's sbt_offset (raykit::sbt::instance_sbt_offset)", if *.geometries == 1 { "y" } else { "ies" })]
    SbtTooSmallForScene {
        /// The params field holding the IAS.
        field: String,
        /// The instance's index in the IAS.
        instance: usize,
        /// Its SBT offset (`Instance::sbt_offset`).
        sbt_offset: u32,
        /// Geometries of its GAS.
        geometries: u32,
        /// `sbtRecordStride` of the trace.
        stride: u32,
        /// `sbtRecordOffset` of the trace.
        ray_offset: u32,
        /// The hit record index reached.
        slot: u64,
        /// Hit records in the SBT.
        hit_records: usize,
        /// A program making such a trace.
        program: String,
    },

    /// A program declares a descriptor binding raykit's pipeline layout does not have.
    #[error("`{program}` declares {found} at set {set}, binding {binding}, {reason}. raykit's pipeline layout binds its buffer table (storage buffers) at set 0, binding 0, its texture table (combined image samplers, declared with a #[textures] parameter) at set 0, binding 1 and, for params over the push-constant budget, the params uniform buffer at set 1, binding 0: reach buffers through `Buffer<T>` handles, textures through `Texture2D` handles and the scene through a `Traversable` (a u64 turned into an acceleration structure) in the params")]
    DescriptorBinding {
        /// The program.
        program: String,
        /// Its `DescriptorSet`.
        set: u32,
        /// Its `Binding`.
        binding: u32,
        /// What the program declares there.
        found: String,
        /// Why raykit cannot bind it.
        reason: String,
    },

    /// A buffer is larger than one storage-buffer descriptor can cover.
    #[error("a buffer of {bytes} bytes is over this device's maxStorageBufferRange of {limit} bytes, the most a device program can reach through one buffer handle; split the data into several buffers (for example one per image tile or row block) and pass their handles, or an array of handles, in the params")]
    BufferTooLarge {
        /// The buffer's size.
        bytes: u64,
        /// `maxStorageBufferRange`.
        limit: u32,
    },

    /// A group was placed for a ray type other than the one its programs were declared for.
    #[error("`{program}` was declared for ray type `{declared}` (`#[{kind}(ray = {declared})]`), but its group is placed with {region}_for::<{asked}>; place it with {region}_for::<{declared}>, or declare the program for `{asked}`")]
    SbtRayTypeMismatch {
        /// The region.
        region: SbtRegion,
        /// The program.
        program: String,
        /// Its kind's attribute name (`miss`, `closest_hit`, `any_hit`).
        kind: &'static str,
        /// The ray type it was declared for.
        declared: &'static str,
        /// The ray type it was placed for.
        asked: &'static str,
    },

    /// The SBT's host copy could not be allocated.
    #[error("the SBT needs {bytes} bytes, which cannot be allocated; use fewer or smaller records")]
    SbtTooLarge {
        /// Its size.
        bytes: u64,
    },

    /// A record's data is too large for the device.
    #[error("SBT record data of {size} bytes: record stride {stride} exceeds this device's maxShaderGroupStride {limit}; keep large data in a `Buffer<T>` and put its handle in the record")]
    SbtRecordTooLarge {
        /// Data size.
        size: usize,
        /// Resulting stride.
        stride: u64,
        /// `maxShaderGroupStride`.
        limit: u32,
    },

    /// Launch dimensions are zero or too large.
    #[error("launch dimensions {dims:?}: {reason}")]
    LaunchDimensions {
        /// What was asked for.
        dims: [u32; 3],
        /// Why they cannot be launched.
        reason: String,
    },

    /// A geometry input is invalid.
    #[error("geometry input: {0}")]
    Geometry(String),

    /// The bindless buffer table is full.
    #[error("the buffer table is full ({capacity} live buffers); drop buffers that are no longer needed")]
    BufferTableFull {
        /// Its size.
        capacity: u32,
    },

    /// The texture table has no free slot.
    #[error("the texture table is full ({capacity} live textures); drop textures no longer needed, or pack several images into one (an atlas)")]
    TextureTableFull {
        /// Its size.
        capacity: u32,
    },

    /// A texture of that size cannot be made.
    #[error("texture of {width}×{height}: {problem}; {fix}")]
    TextureSize {
        /// Width asked for.
        width: u32,
        /// Height asked for.
        height: u32,
        /// What is wrong.
        problem: String,
        /// How to fix it.
        fix: &'static str,
    },

    /// The texel data given for a texture does not fit it.
    #[error("texture data of mip level {level} ({width}×{height} {format:?}): {got} bytes given, {expected} expected; {fix}")]
    TextureData {
        /// The mip level.
        level: u32,
        /// That level's width.
        width: u32,
        /// That level's height.
        height: u32,
        /// The format.
        format: crate::TextureFormat,
        /// Bytes the level needs.
        expected: usize,
        /// Bytes given.
        got: usize,
        /// How to fix it.
        fix: &'static str,
    },

    /// A texture format or source image raykit or the device cannot use.
    #[error("texture format {format}: {problem}; {fix}")]
    TextureFormat {
        /// The format (raykit's, or the source image's).
        format: String,
        /// What is wrong.
        problem: String,
        /// How to fix it.
        fix: &'static str,
    },

    /// A buffer of that size cannot be made.
    #[error("buffer of {len} elements of {element_size} bytes: {reason}")]
    BufferSize {
        /// Elements asked for.
        len: usize,
        /// Size of one element.
        element_size: usize,
        /// Why not.
        reason: &'static str,
    },

    /// Device programs threw user exceptions during a launch. The launch ran to
    /// its end: buffers hold what the programs wrote.
    #[error("the launch raised {total} user exception(s): {} (the first {} are recorded; each was thrown with ctx.throw_exception)", list_exceptions(.exceptions), .exceptions.len())]
    UserExceptions {
        /// How many were thrown.
        total: u32,
        /// The first `EXCEPTION_CAPACITY` of them, in the order they were recorded.
        exceptions: Vec<UserException>,
    },

    /// A program's params block differs from the host's launch-params struct, or
    /// the program reads its params another way than raykit delivers them.
    #[error(transparent)]
    ParamsLayout(Box<raykit_spirv::LayoutError>),

    /// WGSL source could not be compiled: a syntax or validation error (with
    /// naga's diagnostic: `file:line:col` and a caret), a stage or intrinsic naga
    /// lacks, or a declaration against raykit's WGSL conventions.
    #[error(transparent)]
    Wgsl(Box<raykit_wgsl::WgslError>),

    /// Reading or writing the compile cache file failed.
    #[error("pipeline cache file {path}: {source}; set ContextOptions::pipeline_cache (or RAYKIT_PIPELINE_CACHE) to a writable directory, or turn the cache off")]
    PipelineCacheIo {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },

    /// The GPU stopped responding.
    #[error(
        "the device was lost during {during}; every Context on it refuses new work from now on — drop them and \
         create a new Context (it gets a new device)"
    )]
    DeviceLost {
        /// What was running.
        during: &'static str,
    },

    /// [`crate::ContextOptions::device_index`] is past the usable devices.
    #[error("device index {index} is out of range: {} usable ray-tracing device(s): {}; use an index below {}", .usable.len(), .usable.join(", "), .usable.len())]
    DeviceIndexOutOfRange {
        /// The index asked for.
        index: usize,
        /// The names of the usable devices, in the order indices count.
        usable: Vec<String>,
    },

    /// A buffer range past the buffer's end, or reversed.
    #[error("elements {start}..{end} of a buffer of {len}: {}", if .start > .end { "the range is reversed" } else { "past the buffer's end" })]
    BufferRange {
        /// First element of the range.
        start: usize,
        /// One past its last element.
        end: usize,
        /// Elements in the buffer.
        len: usize,
    },

    // ---- Device groups ----
    /// A [`crate::DeviceGroup`] was made of no contexts.
    #[error("a device group needs at least one context; Context::all lists the ray-tracing devices")]
    EmptyDeviceGroup,

    /// A split launch over a grid with no rows.
    #[error("a split launch needs at least one row to split, got a grid of 0 rows")]
    EmptySplit,

    /// Something one device of a group was asked failed: its error, with the device.
    #[error("device {device} of the group ({name}): {source}")]
    InDevice {
        /// The device's index in the group.
        device: usize,
        /// Its name.
        name: String,
        /// What went wrong there.
        #[source]
        source: Box<Error>,
    },

    /// Band weights given to a split launch cannot divide its rows.
    #[error("band weights {weights:?}: {reason}")]
    BandWeights {
        /// The weights given.
        weights: Vec<f64>,
        /// What is wrong with them.
        reason: &'static str,
    },

    /// The per-device states of a split launch disagree on the length of a row.
    #[error("device {device} of the group has rows of {found} elements, but device 0's rows have {expected}; build every device's state for the same grid")]
    BandRowLength {
        /// The device that differs.
        device: usize,
        /// Its row length.
        found: usize,
        /// Device 0's.
        expected: usize,
    },

    /// The host buffer given to a gather does not hold the grid.
    #[error("gathering {rows} rows of {row_len} elements needs {} elements, but the buffer holds {len}", *.rows as usize * .row_len)]
    GatherSize {
        /// Rows of the grid.
        rows: u32,
        /// Elements per row.
        row_len: usize,
        /// Elements in the buffer given.
        len: usize,
    },

    /// A gather before any split launch: no device holds rows yet.
    #[error("nothing to gather: rows {first}..{end} were not rendered by the launches since the split was made or its rows forgotten; launch first")]
    NotLaunched {
        /// First row no device holds.
        first: u32,
        /// One past the last such row.
        end: u32,
    },

    // ---- Acceleration structures ----
    /// A build has nothing to build: no geometry, no primitives, no instances.
    #[error("acceleration structure build: {what}; give at least one triangle, AABB or instance, or leave the empty part out")]
    AccelEmpty {
        /// What is empty.
        what: String,
    },

    /// A count is over one of the device's acceleration-structure limits.
    #[error("{count} {what} exceed this device's {limit_name} ({limit}); split the input into several GASes and instance them in an IAS")]
    AccelLimit {
        /// What was counted.
        what: &'static str,
        /// How many there are.
        count: u64,
        /// The limit.
        limit: u64,
        /// The limit's Vulkan name.
        limit_name: &'static str,
    },

    /// A triangle index names a vertex that does not exist.
    #[error("geometry {geometry}: index {position} is {index}, but the geometry has {vertex_count} vertices (valid indices are 0..{vertex_count}); fix the index buffer or pass all the vertices")]
    IndexOutOfRange {
        /// Geometry (build input) number.
        geometry: usize,
        /// Position of the index in the index buffer.
        position: usize,
        /// Its value.
        index: u32,
        /// Number of vertices given.
        vertex_count: u64,
    },

    /// An index or vertex count that is not three per triangle.
    #[error("geometry {geometry}: {count} {what} is not a multiple of 3; each triangle takes three")]
    TriangleCount {
        /// Geometry number.
        geometry: usize,
        /// `indices` or `vertices without indices`.
        what: &'static str,
        /// The count.
        count: usize,
    },

    /// A vertex or AABB stride Vulkan does not accept.
    #[error("geometry {geometry}: {what} stride of {stride} bytes must be a multiple of {alignment} and at least {min} (one element); pad the struct or give the element's real stride")]
    MisalignedStride {
        /// Geometry number.
        geometry: usize,
        /// `vertex` or `AABB`.
        what: &'static str,
        /// The stride given.
        stride: u64,
        /// Required alignment (the component size).
        alignment: u64,
        /// Smallest stride (one element).
        min: u64,
    },

    /// The bytes given are fewer than count × stride needs.
    #[error("geometry {geometry}: {what} data of {len} bytes is too short: the count and stride need {needed}; give more data or a smaller count")]
    InputTooShort {
        /// Geometry number.
        geometry: usize,
        /// `vertex` or `AABB`.
        what: &'static str,
        /// Bytes needed.
        needed: u64,
        /// Bytes given.
        len: u64,
    },

    /// A vertex position is NaN or infinite.
    #[error("geometry {geometry}: vertex {vertex} is not finite: {position:?}; acceleration structures need finite positions")]
    NonFiniteVertex {
        /// Geometry number.
        geometry: usize,
        /// Vertex number.
        vertex: usize,
        /// Its position.
        position: [f32; 3],
    },

    /// A box is not finite or has min > max.
    #[error("geometry {geometry}: AABB {primitive} (min {min:?}, max {max:?}) is invalid: {reason}")]
    InvalidAabb {
        /// Geometry number.
        geometry: usize,
        /// Box number.
        primitive: usize,
        /// Minimum corner.
        min: [f32; 3],
        /// Maximum corner.
        max: [f32; 3],
        /// What is wrong.
        reason: &'static str,
    },

    /// A geometry or instance transform is NaN or infinite.
    #[error("{what} is not finite; give a finite affine transform")]
    NonFiniteTransform {
        /// Which transform.
        what: String,
    },

    /// An instance field is over its bit width.
    #[error("instance {instance}: {field} is {value}, over its 24-bit maximum {max}")]
    InstanceField {
        /// Instance number.
        instance: usize,
        /// The field.
        field: &'static str,
        /// Its value.
        value: u32,
        /// Its maximum.
        max: u32,
    },

    /// Triangles and AABBs mixed in one GAS.
    #[error("a GAS holds either triangles or AABBs: geometry {first} and geometry {other} differ; build one GAS of each and instance both in an IAS")]
    MixedGeometryTypes {
        /// The first geometry.
        first: usize,
        /// The first geometry of the other kind.
        other: usize,
    },

    /// A refit (update) that Vulkan does not allow.
    #[error("cannot update (refit) this {what}: {reason}; use rebuild instead, or build with BuildOptions::allow_update and keep the topology")]
    UpdateRefused {
        /// `GAS` or `IAS`.
        what: &'static str,
        /// Why not.
        reason: String,
    },

    /// Compaction of a GAS built without allowing it.
    #[error(
        "this GAS was built without BuildOptions::allow_compaction; build it with allow_compaction(true) to compact it"
    )]
    CompactionNotAllowed,
}

impl From<raykit_spirv::LayoutError> for Error {
    fn from(e: raykit_spirv::LayoutError) -> Self {
        match e {
            raykit_spirv::LayoutError::InvalidSpirv(reason) => Error::InvalidSpirv { reason },
            other => Error::ParamsLayout(Box::new(other)),
        }
    }
}

impl Error {
    /// Wraps a failed Vulkan call.
    pub(crate) fn vk(call: &'static str) -> impl FnOnce(vk::Result) -> Error {
        move |result| match result {
            vk::Result::ERROR_DEVICE_LOST => Error::DeviceLost { during: call },
            result => Error::Vulkan { call, result },
        }
    }
}

/// Where an invalid handle sits, for [`Error::InvalidHandle`]'s message.
fn handle_place(record: &Option<(crate::SbtRegion, usize)>, field: &str) -> String {
    match record {
        None => format!("launch params field `{field}`"),
        Some((region, index)) => format!("field `{field}` of {region} record {index} of the SBT"),
    }
}

/// The error of a launch whose programs threw `total` exceptions, `recorded` of
/// them recorded, in a pipeline linked with `max_trace_depth`: the traces refused
/// past the depth ([`Error::RecursionTooDeep`]) if any were recorded, otherwise
/// the user exceptions ([`Error::UserExceptions`]).
pub(crate) fn exceptions_error(total: u32, recorded: Vec<UserException>, max_trace_depth: u32) -> Error {
    use raykit_device::exception::TRACE_DEPTH_EXCEEDED;
    let (refused, user): (Vec<UserException>, Vec<UserException>) =
        recorded.into_iter().partition(|e| e.code == TRACE_DEPTH_EXCEEDED);
    if refused.is_empty() {
        return Error::UserExceptions { total, exceptions: user };
    }
    Error::RecursionTooDeep {
        max_trace_depth,
        depth: max_trace_depth.saturating_add(1),
        refused: refused.len(),
        launch_indices: refused.iter().map(|e| e.launch_index).collect(),
        user_exceptions: user,
        total,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_device_without_robustness2_is_reported_with_the_reason_and_the_fix() {
        let report = |missing: &[&str]| DeviceReport {
            name: "Some GPU".to_owned(),
            device_type: "DISCRETE_GPU".to_owned(),
            api_version: "1.3.0".to_owned(),
            missing: missing.iter().map(|m| m.to_string()).collect(),
        };
        let text = Error::NoRayTracingDevice { devices: vec![report(&["extension VK_EXT_robustness2"])] }.to_string();
        assert!(text.contains("Some GPU (DISCRETE_GPU, Vulkan 1.3.0): lacks extension VK_EXT_robustness2"), "{text}");
        assert!(text.contains("without bounds checks") && text.contains("Update the GPU driver"), "{text}");
        let text =
            Error::NoRayTracingDevice { devices: vec![report(&["extension VK_KHR_ray_tracing_pipeline"])] }.to_string();
        assert!(!text.contains("robustness2"), "{text}");
    }
}
