// The README's code needs the triangle example's crates: `examples/triangle`
// compiles it as its own doctests, so it is left out of this crate's.
#![cfg_attr(not(doctest), doc = include_str!("../../README.md"))]
#![deny(missing_docs)]
#![deny(missing_debug_implementations)]

pub mod accel;
mod backend;
pub mod cache;
pub mod context;
pub mod cpu;
pub mod device_group;
pub mod error;
#[cfg(feature = "fault-injection")]
pub mod gate;
pub use validate::handles;
pub mod log;
pub mod memory;
pub mod module;
pub mod pipeline;
pub mod program_group;
pub mod sbt;
pub mod stack;
pub mod texture;
mod types;
pub mod validate;
mod vulkan;
#[cfg(feature = "wgsl")]
pub mod wgsl;

pub use vulkan::timeline;

pub use accel::{
    Aabb, Aabbs, BuildInput, BuildOptions, Gas, GasBuilder, GeometryFlags, Ias, IasBuilder, Indices, Instance,
    InstanceFlags, PendingBuild, Triangles,
};
pub use cache::{CacheLoad, PipelineCacheInfo, PipelineCacheLocation};
pub use context::{Backend, Context, ContextOptions, DeviceLimits, MemoryUsage};
pub use device_group::{Balance, Band, BandRows, BandTiming, DeviceGroup, Split};
pub use error::{
    AccelError, DeviceError, DeviceGroupError, DeviceReport, Error, LaunchError, LinkError, ModuleError, ResourceError,
    Result, SbtError, UserException,
};
#[cfg(feature = "fault-injection")]
#[doc(hidden)]
pub use gate::SubmissionGate;
pub use log::{LogCallback, LoggedObject, MessageLog, Severity, ValidationMessage};
pub use memory::{BufferMemory, DeviceBuffer, PendingRead};
pub use module::{spirv_path, EmbeddedSpirv, EntryPointInfo, Module};
pub use pipeline::launch::Launch;
pub use pipeline::library::{LibraryOptions, PipelineLibrary};
pub use pipeline::timing::LaunchTimer;
pub use pipeline::{params_delivery, LinkOptions, Pipeline, Specialization};
pub use program_group::{EntryName, GroupKind, HitGroupBuilder, ProgramGroup};
pub use raykit_spirv::{BlockMember, BlockType, InterfaceSizes, LayoutError, ParamsBlock, ParamsDelivery};
pub use sbt::{Sbt, SbtBuilder, SbtRecord, SbtRegion};
pub use stack::{CallDepths, CallGraph, GroupStackSizes, StackSize, StackSizes};
pub use texture::{AddressMode, Filter, MipLevel, Mipmaps, SamplerOptions, Texture, TextureFormat};
#[cfg(feature = "wgsl")]
pub use wgsl::WgslError;

pub use ash;
pub use bytemuck;
pub use glam;
/// The device crate's shared types, re-exported for host code.
pub use raykit_device::{
    self as device, Buffer, Element, EntryPoint, LaunchParams, ProgramKind, SbtRecordData, Texture2D, Traversable,
};
/// What a renderer needs on the host beside the runtime: a pinhole camera, PNG
/// and PFM output, environment-map tables (`raykit-scene`, without its glTF and
/// OpenEXR features; depend on `raykit-scene` itself for those).
pub use raykit_scene as scene;
pub use raykit_scene::{write_png_rgba8, write_png_srgb, Camera, ImageError};
/// raykit's SPIR-V reflection and params layout check, for build tooling and tests.
pub use raykit_spirv as spirv;

/// Host objects are `Send + Sync`: each may be shared by threads, with the external
/// synchronisation Vulkan requires (queue, command pool, allocator, descriptor
/// updates) done inside raykit behind locks.
#[allow(dead_code)]
fn host_objects_are_send_and_sync<P: LaunchParams, T: raykit_device::Element + Send + Sync>() {
    fn check<X: Send + Sync>() {}
    check::<Context>();
    check::<DeviceGroup>();
    check::<Module>();
    check::<ProgramGroup>();
    check::<Pipeline<P>>();
    check::<PipelineLibrary<P>>();
    check::<Sbt>();
    check::<Launch>();
    check::<Gas>();
    check::<Ias>();
    check::<PendingBuild<Gas>>();
    check::<PendingBuild<Ias>>();
    check::<DeviceBuffer<T>>();
    check::<MessageLog>();
}
