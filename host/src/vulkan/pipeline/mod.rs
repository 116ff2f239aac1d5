//! Pipelines on Vulkan: the pipeline layout and params uniform (`layout`), shader
//! stages and groups (`shader_groups`), owned `VkPipeline`s (`handle`), and
//! user-exception buffers (`exceptions`).

pub(crate) mod exceptions;
pub(crate) mod handle;
pub(crate) mod layout;
pub(crate) mod link;
pub(crate) mod record;
pub(crate) mod shader_groups;
pub(crate) mod timing;
