//! Acceleration structures on Vulkan.

pub(crate) mod build;
pub(crate) mod structure;
