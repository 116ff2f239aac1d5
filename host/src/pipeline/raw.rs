//! The Vulkan handles under raykit's objects, for interoperation and for
//! comparisons with hand-written Vulkan (raykit's benchmarks launch raykit's own
//! pipeline and SBT through plain ash calls). Getting a handle is safe; using it
//! is `unsafe` ash code whose caller keeps raykit's rules: the owning raykit
//! object outlives every use, and the queue is externally synchronised (raykit
//! submits to queue 0 of [`Context::queue_family`], under its own lock).

use ash::vk;

use crate::context::Context;
use crate::pipeline::Pipeline;
use crate::sbt::Sbt;

impl Context {
    /// The `ash` instance.
    pub fn raw_instance(&self) -> &ash::Instance {
        &self.inner.instance
    }
    /// The `ash` device.
    pub fn raw_device(&self) -> &ash::Device {
        &self.inner.device
    }
    /// The `VK_KHR_ray_tracing_pipeline` functions of the device.
    pub fn raw_ray_tracing(&self) -> &ash::khr::ray_tracing_pipeline::Device {
        &self.inner.rt
    }
    /// The bindless buffer table's descriptor set (set 0 of every raykit pipeline layout).
    pub fn raw_buffer_table_set(&self) -> vk::DescriptorSet {
        self.inner.buffer_table.set
    }
    /// The bindless buffer table's descriptor set layout.
    pub fn raw_buffer_table_layout(&self) -> vk::DescriptorSetLayout {
        self.inner.buffer_table.layout
    }
}

impl<P: raykit_device::LaunchParams> Pipeline<P> {
    /// The `VkPipeline`.
    pub fn raw_pipeline(&self) -> vk::Pipeline {
        self.inner.pipeline
    }
    /// The `VkPipelineLayout`.
    pub fn raw_layout(&self) -> vk::PipelineLayout {
        self.inner.layout
    }
    /// Bytes of push constants the launch pushes (0 when the params go through a
    /// uniform buffer).
    pub fn raw_push_constant_size(&self) -> u32 {
        self.inner.push_constant_size
    }
}

impl Sbt {
    /// The raygen, miss, hit and callable regions passed to `vkCmdTraceRaysKHR`.
    pub fn raw_regions(&self) -> [vk::StridedDeviceAddressRegionKHR; 4] {
        [self.raygen, self.miss, self.hit, self.callable]
    }
}
