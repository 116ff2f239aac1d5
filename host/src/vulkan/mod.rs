//! The Vulkan backend: what the public types run on when a
//! [`Context`](crate::Context) is made with [`Backend::Vulkan`](crate::Backend::Vulkan).
//!
//! The public types ([`Context`](crate::Context), [`Module`](crate::Module),
//! [`Pipeline`](crate::Pipeline), [`Sbt`](crate::Sbt), [`Gas`](crate::Gas),
//! [`Ias`](crate::Ias), [`DeviceBuffer`](crate::DeviceBuffer),
//! [`Texture`](crate::Texture), launches) sit on top and hold either a Vulkan
//! object of this backend or a CPU object of [`crate::cpu`]; this module and
//! `cpu` do not use each other. Here:
//!
//! * `device_registry`: the process-wide `VkInstance`s and the one `VkDevice`
//!   per GPU that its contexts share; `driver_lock` keeps pipeline destruction
//!   apart from pipeline creation.
//! * `context`: a context's state (`ContextInner`), its creation and the choice
//!   of devices for [`Context::all`](crate::Context::all), its submissions
//!   (command buffers, each signalling an epoch of the context's [`timeline`])
//!   and its destruction.
//! * `messenger`: the debug messenger's callback, which hands validation
//!   messages to the contexts they concern (see [`crate::log`]).
//! * [`timeline`]: objects dropped while the device may use them, destroyed once
//!   their epoch has finished (public as [`crate::timeline`]).
//! * `barrier`: the global memory barriers that order commands within a
//!   submission.
//! * `memory`: a `VkBuffer` with its gpu-allocator allocation, under
//!   [`DeviceBuffer`](crate::DeviceBuffer) (its slot in the buffer table and its
//!   readback copy too), SBTs and acceleration structures.
//! * `buffer_table`, `texture_table`: the bindless descriptor set that device
//!   programs reach buffers and textures through.
//! * `cache`: the `VkPipelineCache` and its file (see [`crate::cache`]).
//! * `module`: a module's `VkShaderModule`.
//! * `texture`: a texture's image, its upload, view and sampler, and the
//!   device's format support.
//! * `pipeline`: pipeline layouts and params uniforms, shader stages and groups,
//!   owned `VkPipeline`s, user-exception buffers, linking from groups and from
//!   libraries (`link`), launch recording and submission (`record`), and the
//!   timestamp queries of timed launches (`timing`).
//! * `sbt`: the SBT's device buffer and the regions a trace is given.
//! * `accel`: acceleration structures, their build commands, GAS builds, refits
//!   and compaction (`gas`) and IAS instance records, builds and refits (`ias`).
//!
//! The public types keep their API, the checks of what they are given, and a
//! dispatch to this module or to `cpu`. Some `ash` types stay in their files
//! because the public API names them: the raw handles of
//! [`Context`](crate::Context), [`Pipeline`](crate::Pipeline) and
//! [`Sbt::raw_regions`](crate::Sbt::raw_regions) (for hand-written Vulkan),
//! [`Context::set_debug_name`](crate::Context::set_debug_name),
//! [`TextureFormat::vk_format`](crate::TextureFormat::vk_format) and the
//! `vk::Result` that [`Error`](crate::Error) reports. The test-only submission
//! gate (`crate::gate`, behind the `fault-injection` feature) is Vulkan through
//! and through and keeps its public place.

pub(crate) mod accel;
pub(crate) mod barrier;
pub(crate) mod buffer_table;
pub(crate) mod cache;
pub(crate) mod context;
pub(crate) mod conv;
pub(crate) mod device_registry;
pub(crate) mod driver_lock;
#[cfg(feature = "fault-injection")]
pub(crate) mod gate;
pub(crate) mod memory;
pub(crate) mod messenger;
pub(crate) mod module;
pub(crate) mod pipeline;
pub(crate) mod sbt;
pub(crate) mod texture;
pub(crate) mod texture_table;
pub mod timeline;
