//! Errors of linking program groups into pipelines and pipeline libraries: trace depth, params
//! layout and size, descriptor bindings, stack sizes.

use crate::types::group::GroupKind;

/// Errors of linking program groups into pipelines and pipeline libraries.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LinkError {
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

    /// A program's params block differs from the host's launch-params struct, or
    /// the program reads its params another way than raykit delivers them.
    #[error(transparent)]
    ParamsLayout(Box<raykit_spirv::LayoutError>),
}
