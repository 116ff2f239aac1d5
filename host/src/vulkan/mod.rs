//! The Vulkan backend: what the public types run on when a
//! [`Context`](crate::Context) is made with [`Backend::Vulkan`](crate::Backend::Vulkan).

pub(crate) mod accel;
pub(crate) mod buffer_table;
pub(crate) mod cache;
pub(crate) mod context;
pub(crate) mod device_registry;
pub(crate) mod driver_lock;
pub(crate) mod memory;
pub(crate) mod pipeline;
pub(crate) mod texture_table;
pub mod timeline;
