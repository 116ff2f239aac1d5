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
//! * `context`: a context's submissions (command buffers, each signalling an
//!   epoch of the context's [`timeline`]) and its destruction.
//! * [`timeline`]: objects dropped while the device may use them, destroyed once
//!   their epoch has finished (public as [`crate::timeline`]).
//! * `memory`: a `VkBuffer` with its gpu-allocator allocation, under
//!   [`DeviceBuffer`](crate::DeviceBuffer), SBTs and acceleration structures.
//! * `buffer_table`, `texture_table`: the bindless descriptor set that device
//!   programs reach buffers and textures through.
//! * `cache`: the `VkPipelineCache` and its file (see [`crate::cache`]).
//! * `pipeline`: pipeline layouts and params uniforms, shader stages and groups,
//!   owned `VkPipeline`s, user-exception buffers.
//! * `accel`: acceleration structures and their build commands.
//!
//! Still on the public types' side, with their Vulkan code inline: module
//! creation ([`crate::module`]), textures and samplers ([`crate::texture`]),
//! pipeline linking, launch recording and timing ([`crate::pipeline`]), the
//! SBT's device buffer ([`crate::sbt`]), GAS and IAS builds, compaction and
//! refits ([`crate::accel`]), and the debug messenger ([`crate::log`]).

pub(crate) mod accel;
pub(crate) mod buffer_table;
pub(crate) mod cache;
pub(crate) mod context;
pub(crate) mod device_registry;
pub(crate) mod driver_lock;
pub(crate) mod memory;
pub(crate) mod messenger;
pub(crate) mod module;
pub(crate) mod pipeline;
pub(crate) mod sbt;
pub(crate) mod texture;
pub(crate) mod texture_table;
pub mod timeline;
