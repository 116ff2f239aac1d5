//! # raykit
//!
//! The OptiX 7 programming model on Vulkan ray tracing (and natively on the
//! CPU): the host runtime. Device programs are Rust functions in a device crate
//! ([`raykit_device`], re-exported as [`device`]); this crate loads them, links
//! them and launches them. The book (`docs/book/` in the repository) is the
//! guide; this page is the map.
//!
//! # From a context to a launch
//!
//! Each step is one OptiX call, and one raykit type:
//!
//! 1. **A [`Context`]** ([`context`], OptiX's `optixDeviceContextCreate`):
//!    [`Context::new`] picks a Vulkan device with ray tracing, or the CPU
//!    backend ([`Backend::Cpu`], [`cpu`]). Everything below is made on it.
//! 2. **A [`Module`]** ([`module`], `optixModuleCreate`): the device crate's
//!    SPIR-V, by [`Module::from_device_crate`], [`Module::from_embedded`] (with
//!    [`include_spirv!`]) or [`Module::new`]; on the CPU backend, the crate itself.
//! 3. **[`ProgramGroup`]s** ([`program_group`], `optixProgramGroupCreate`):
//!    [`ProgramGroup::raygen`], [`ProgramGroup::miss`], [`ProgramGroup::hit_group`],
//!    [`ProgramGroup::callable`], named by the constants the device macros make.
//! 4. **A [`Pipeline`]** ([`pipeline`], `optixPipelineCreate`): [`Pipeline::new`]
//!    links the groups for launch params `P`, whose layout it checks against the
//!    SPIR-V; [`PipelineLibrary`] and [`Pipeline::link`] reuse compiled groups,
//!    and [`stack`] sizes its stack (`optixPipelineSetStackSize`).
//! 5. **An [`Sbt`]** ([`sbt`], `OptixShaderBindingTable`): [`Sbt::builder`] packs
//!    each group's handle with its typed record data and checks that every record
//!    the pipeline's traces select exists.
//! 6. **A [`Gas`] and an [`Ias`]** ([`accel`], `optixAccelBuild`): geometry
//!    (triangles, AABBs, spheres) and its [`Instance`]s; [`Ias::handle`] is the
//!    [`Traversable`] a launch-params field carries, beside [`Buffer`] handles of
//!    [`DeviceBuffer`]s ([`memory`]) and [`Texture2D`] handles of [`Texture`]s
//!    ([`texture`]).
//! 7. **A launch** (`optixLaunch`): [`Pipeline::launch`] (or
//!    [`Pipeline::launch_async`], a [`Launch`] to wait on) with the SBT, the params
//!    and the grid; then [`DeviceBuffer::read`] the result.
//!
//! ```no_run
//! # use raykit_device::glam::Vec3;
//! # #[repr(C)]
//! # #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, raykit::LaunchParams)]
//! # pub struct Params { pub image: raykit::Buffer<u32>, pub _pad: u32, pub scene: raykit::Traversable }
//! # const RG: &str = "__raygen__rg";
//! # const MS: &str = "__miss__ms";
//! # const CH: &str = "__closesthit__ch";
//! use raykit::{Context, ContextOptions, Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
//!
//! let ctx = Context::new(ContextOptions::default())?; // 1
//! let module = Module::from_device_crate(&ctx, "my-device")?; // 2: target/spirv/my_device.spv
//! let raygen = ProgramGroup::raygen(&module, RG)?; // 3
//! let miss = ProgramGroup::miss(&module, MS)?;
//! let hit = ProgramGroup::hit_group(&module).closest_hit(CH).build()?;
//! let pipeline = Pipeline::<Params>::new(&ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?; // 4
//! let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(&hit, ()).build()?; // 5
//! let gas = Gas::triangles(&ctx, &[Vec3::X, Vec3::Y, Vec3::Z], None)?; // 6
//! let scene = Ias::single(&ctx, &gas)?;
//! let image = ctx.buffer::<u32>(64 * 64)?;
//! pipeline.launch(&sbt, &Params { image: image.handle(), _pad: 0, scene: scene.handle() }, [64, 64, 1])?; // 7
//! let pixels = image.read()?;
//! # let _ = pixels;
//! # Ok::<(), raykit::Error>(())
//! ```
//!
//! # Around the launch
//!
//! * [`Error`] ([`error`]): every refusal, nested by domain, naming the fix;
//!   [`validate`] holds the checks made before the driver sees anything.
//! * [`log`]: validation and driver messages (OptiX's log callback); [`cache`]:
//!   the compile cache (OptiX's disk cache); [`timeline`] and [`handles`]: when
//!   dropped objects are freed, and the handle checks of every launch.
//! * [`device_group`]: one launch split across several devices.
//! * [`scene`]: a camera, image writers and environment maps for renderers.
//!
//! Search these docs by OptiX's names: `optixTrace`, `optixLaunch`,
//! `optixSbtRecordPackHeader`, … are aliases of the raykit items that do their work.
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
    InstanceFlags, Mesh, PendingBuild, Triangles,
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
