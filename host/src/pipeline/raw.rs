//! The Vulkan handles under a pipeline, for interoperation and for comparisons
//! with hand-written Vulkan (raykit's benchmarks launch raykit's own pipeline and
//! SBT through plain ash calls, with [`Context::raw_device`](crate::Context::raw_device)
//! and [`Sbt::raw_regions`](crate::Sbt::raw_regions) beside these). Getting a handle
//! is safe; using it is `unsafe` ash code whose caller keeps raykit's rules: the
//! owning raykit object outlives every use (work submitted through these handles
//! is not on raykit's GPU timeline, [`crate::timeline`], so raykit cannot defer the
//! object's destruction for it), and the queue is externally
//! synchronised (raykit submits to queue 0 of
//! [`Context::queue_family`](crate::Context::queue_family), under a lock shared by
//! every context on the device).

use ash::vk;

use super::Pipeline;

impl<P: raykit_device::LaunchParams> Pipeline<P> {
    /// The `VkPipeline` (`None` on the CPU backend).
    pub fn raw_pipeline(&self) -> Option<vk::Pipeline> {
        self.vulkan_inner().map(|inner| inner.pipeline.handle)
    }
    /// The `VkPipelineLayout` (`None` on the CPU backend).
    pub fn raw_layout(&self) -> Option<vk::PipelineLayout> {
        self.vulkan_inner().map(|inner| inner.layout.handle)
    }
    /// Bytes of push constants the launch pushes (0 when the params go through a
    /// uniform buffer, or on the CPU backend).
    pub fn raw_push_constant_size(&self) -> u32 {
        self.vulkan_inner().map_or(0, |inner| inner.layout.push_constant_size)
    }
}
