//! Pipelines on Vulkan.

pub(crate) mod exceptions;
pub(crate) mod handle;
pub(crate) mod layout;
pub(crate) mod shader_groups;
