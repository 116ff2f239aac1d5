//! The independent ash baseline of the primary-ray suites: the picture raykit's
//! primary-ray programs draw, drawn by a Vulkan program written without raykit,
//! as a careful Vulkan programmer would write it.
//!
//! Nothing of raykit's is used: the [`AshDevice`] is its own instance and device
//! on raykit's GPU (matched by `deviceUUID`), and on it the baseline makes
//!
//! * its own programs, `bench/glsl/independent.*` (glslang, then `spirv-opt -O`),
//!   with a plain descriptor set (binding 0: the TLAS, binding 1: the output
//!   buffer) and the camera and background in push constants;
//! * its own BLAS over the same vertices and indices as raykit's scene (opaque
//!   triangles, `PREFER_FAST_TRACE`, not compacted) and a one-instance TLAS with
//!   the identity transform, built in one submission;
//! * its own ray-tracing pipeline (raygen, miss, one triangle hit group; maximum
//!   recursion depth 1) and SBT: the handles from
//!   `vkGetRayTracingShaderGroupHandlesKHR`, each region at
//!   `shaderGroupBaseAlignment`, strides at `shaderGroupHandleAlignment`, in a
//!   device-local buffer filled through a staging copy;
//! * a device-local output buffer, copied to a host-visible one after the launch,
//!   outside the timed part.
//!
//! GPU timestamps bracket `vkCmdTraceRaysKHR` alone (top of pipe, bottom of pipe),
//! as raykit's `launch_timed` and [`crate::ash_baseline::AshTracer`] time theirs,
//! so the times compare; without timestamps, the wall time of the submission.

use anyhow::Context as _;
use ash::vk;
use raykit::glam::Vec3;

use crate::ash_baseline::{as_bytes, AshDevice, Buffer};
use crate::ash_launcher::{Output, Submitter};

/// The programs' SPIR-V (`bench/glsl/build.sh`).
const RGEN: &[u8] = include_bytes!("../glsl/independent.rgen.spv");
const RMISS: &[u8] = include_bytes!("../glsl/independent.rmiss.spv");
const RCHIT: &[u8] = include_bytes!("../glsl/independent.rchit.spv");

/// The programs' push constants (`Camera` in `bench/glsl/independent.glsl`:
/// std430, one `vec4` per vector, `w` unused).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Camera {
    /// The eye.
    pub eye: [f32; 4],
    /// Right, scaled to half the image plane's width.
    pub u: [f32; 4],
    /// Up, scaled to half the image plane's height.
    pub v: [f32; 4],
    /// Forward, from the eye to the image plane's centre.
    pub w: [f32; 4],
    /// The miss colour (linear RGB).
    pub background: [f32; 4],
}

impl Camera {
    /// The camera of raykit's primary-ray params, with `background` for misses.
    pub fn of(params: &triangle_device::Params, background: Vec3) -> Camera {
        let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
        Camera {
            eye: v4(params.cam_eye),
            u: v4(params.cam_u),
            v: v4(params.cam_v),
            w: v4(params.cam_w),
            background: v4(background),
        }
    }
}

/// The stages that read the push constants.
fn push_stages() -> vk::ShaderStageFlags {
    vk::ShaderStageFlags::RAYGEN_KHR | vk::ShaderStageFlags::MISS_KHR
}

/// An acceleration structure and its storage.
#[derive(Default)]
struct Accel {
    handle: vk::AccelerationStructureKHR,
    storage: Buffer,
}

/// The independent baseline on an [`AshDevice`] (see the module docs). Every
/// handle starts null and is filled as it is made, so that dropping a partly
/// made tracer destroys what was made.
pub struct IndependentTracer<'d> {
    dev: &'d AshDevice,
    blas: Accel,
    tlas: Accel,
    set_layout: vk::DescriptorSetLayout,
    layout: vk::PipelineLayout,
    pipeline: vk::Pipeline,
    descriptor_pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    /// The SBT, device-local, and its raygen, miss, hit and callable regions.
    sbt: Buffer,
    regions: [vk::StridedDeviceAddressRegionKHR; 4],
    /// The programs' output, device-local, and its mapped copy.
    output: Output,
    submitter: Submitter<'d>,
}

impl<'d> IndependentTracer<'d> {
    /// Builds the BLAS over `vertices` and `indices` and its TLAS, the pipeline,
    /// its SBT and an output of `words` 32-bit words.
    pub fn new(
        dev: &'d AshDevice,
        vertices: &[[f32; 3]],
        indices: &[u32],
        words: usize,
    ) -> anyhow::Result<IndependentTracer<'d>> {
        let submitter =
            Submitter::new(&dev.device, dev.queue, dev.pool, dev.timestamp_valid_bits, dev.timestamp_period_ns)?;
        let mut t = IndependentTracer {
            dev,
            blas: Accel::default(),
            tlas: Accel::default(),
            set_layout: vk::DescriptorSetLayout::null(),
            layout: vk::PipelineLayout::null(),
            pipeline: vk::Pipeline::null(),
            descriptor_pool: vk::DescriptorPool::null(),
            set: vk::DescriptorSet::null(),
            sbt: Buffer::default(),
            regions: [vk::StridedDeviceAddressRegionKHR::default(); 4],
            output: Output::new(Buffer::default(), Buffer::default(), (words as u64 * 4).max(4)),
            submitter,
        };
        t.build_structures(vertices, indices)?;
        t.make_output()?;
        t.make_pipeline()?;
        t.make_sbt()?;
        t.make_set()?;
        Ok(t)
    }

    /// The BLAS over the mesh and the one-instance TLAS over it, in one
    /// submission (a barrier between the builds), waited for.
    fn build_structures(&mut self, vertices: &[[f32; 3]], indices: &[u32]) -> anyhow::Result<()> {
        let dev = self.dev;
        anyhow::ensure!(!vertices.is_empty() && indices.len().is_multiple_of(3), "not a triangle mesh");
        let count = (indices.len() / 3) as u32;
        // Sizes first: the instance needs the BLAS's address before anything is uploaded.
        let blas_geometry = |vertex_address: u64, index_address: u64| {
            let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
                .vertex_format(vk::Format::R32G32B32_SFLOAT)
                .vertex_data(vk::DeviceOrHostAddressConstKHR { device_address: vertex_address })
                .vertex_stride(12)
                .max_vertex(vertices.len() as u32 - 1)
                .index_type(vk::IndexType::UINT32)
                .index_data(vk::DeviceOrHostAddressConstKHR { device_address: index_address });
            [vk::AccelerationStructureGeometryKHR::default()
                .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
                .flags(vk::GeometryFlagsKHR::OPAQUE)
                .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })]
        };
        let tlas_geometry = |instance_address: u64| {
            let instances = vk::AccelerationStructureGeometryInstancesDataKHR::default()
                .array_of_pointers(false)
                .data(vk::DeviceOrHostAddressConstKHR { device_address: instance_address });
            [vk::AccelerationStructureGeometryKHR::default()
                .geometry_type(vk::GeometryTypeKHR::INSTANCES)
                .geometry(vk::AccelerationStructureGeometryDataKHR { instances })]
        };
        let info = |ty: vk::AccelerationStructureTypeKHR| {
            vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(ty)
                .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
                .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        };
        let sizes = |geometry: &[vk::AccelerationStructureGeometryKHR<'_>],
                     ty: vk::AccelerationStructureTypeKHR,
                     primitives: u32| {
            let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
            // SAFETY: valid build info and one count per geometry.
            unsafe {
                dev.accel.get_acceleration_structure_build_sizes(
                    vk::AccelerationStructureBuildTypeKHR::DEVICE,
                    &info(ty).geometries(geometry),
                    &[primitives],
                    &mut sizes,
                )
            };
            sizes
        };
        let blas_sizes = sizes(&blas_geometry(0, 0), vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL, count);
        let tlas_sizes = sizes(&tlas_geometry(0), vk::AccelerationStructureTypeKHR::TOP_LEVEL, 1);
        self.blas =
            self.structure(blas_sizes.acceleration_structure_size, vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)?;
        self.tlas =
            self.structure(tlas_sizes.acceleration_structure_size, vk::AccelerationStructureTypeKHR::TOP_LEVEL)?;
        let address_info =
            vk::AccelerationStructureDeviceAddressInfoKHR::default().acceleration_structure(self.blas.handle);
        // SAFETY: the BLAS was just created.
        let blas_address = unsafe { dev.accel.get_acceleration_structure_device_address(&address_info) };
        let instance = vk::AccelerationStructureInstanceKHR {
            transform: vk::TransformMatrixKHR { matrix: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0] },
            instance_custom_index_and_mask: vk::Packed24_8::new(0, 0xff),
            instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(0, 0),
            acceleration_structure_reference: vk::AccelerationStructureReferenceKHR { device_handle: blas_address },
        };
        // SAFETY: the instance is plain data of the layout Vulkan reads (64 bytes, no padding).
        let instance_bytes = unsafe {
            std::slice::from_raw_parts(
                &instance as *const vk::AccelerationStructureInstanceKHR as *const u8,
                std::mem::size_of::<vk::AccelerationStructureInstanceKHR>(),
            )
        };
        let addresses = dev.upload(&[as_bytes(vertices), as_bytes(indices), instance_bytes])?;
        // One scratch buffer for both builds, the barrier between them ordering its reuse.
        let scratch = dev.scratch(blas_sizes.build_scratch_size.max(tlas_sizes.build_scratch_size))?;
        let blas_geometry = blas_geometry(addresses[0], addresses[1]);
        let tlas_geometry = tlas_geometry(addresses[2]);
        let blas_info = info(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
            .geometries(&blas_geometry)
            .dst_acceleration_structure(self.blas.handle)
            .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch });
        let tlas_info = info(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
            .geometries(&tlas_geometry)
            .dst_acceleration_structure(self.tlas.handle)
            .scratch_data(vk::DeviceOrHostAddressKHR { device_address: scratch });
        let blas_range = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
        let tlas_range = [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(1)];
        dev.submit_and_wait(|cmd| {
            let between = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR)
                .dst_access_mask(
                    vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR
                        | vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
                );
            let after = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR)
                .dst_access_mask(vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR);
            // SAFETY: the structures, the input and the scratch live until the wait ends.
            unsafe {
                dev.accel.cmd_build_acceleration_structures(cmd, &[blas_info], &[&blas_range]);
                dev.device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                    vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                    vk::DependencyFlags::empty(),
                    &[between],
                    &[],
                    &[],
                );
                dev.accel.cmd_build_acceleration_structures(cmd, &[tlas_info], &[&tlas_range]);
                dev.device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                    vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                    vk::DependencyFlags::empty(),
                    &[after],
                    &[],
                    &[],
                );
            }
        })
    }

    /// An acceleration structure of `size` bytes in its own device-local storage.
    fn structure(&self, size: u64, ty: vk::AccelerationStructureTypeKHR) -> anyhow::Result<Accel> {
        let storage = self.dev.buffer(size, vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR, false)?;
        let create = vk::AccelerationStructureCreateInfoKHR::default().buffer(storage.buffer).size(size).ty(ty);
        // SAFETY: the storage buffer is large enough.
        match unsafe { self.dev.accel.create_acceleration_structure(&create, None) } {
            Ok(handle) => Ok(Accel { handle, storage }),
            Err(e) => {
                self.dev.free(storage);
                Err(e).context("vkCreateAccelerationStructureKHR")
            }
        }
    }

    /// The device-local output and its mapped, host-visible copy.
    fn make_output(&mut self) -> anyhow::Result<()> {
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC;
        self.output.device = self.dev.buffer(self.output.bytes, usage, false)?;
        self.output.readback = self.dev.buffer(self.output.bytes, vk::BufferUsageFlags::TRANSFER_DST, true)?;
        self.output.map(&self.dev.device)?;
        Ok(())
    }

    /// The descriptor-set layout, the pipeline layout and the pipeline.
    fn make_pipeline(&mut self) -> anyhow::Result<()> {
        let d = &self.dev.device;
        let bindings = [
            vk::DescriptorSetLayoutBinding::default()
                .binding(0)
                .descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::RAYGEN_KHR),
            vk::DescriptorSetLayoutBinding::default()
                .binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .descriptor_count(1)
                .stage_flags(vk::ShaderStageFlags::RAYGEN_KHR),
        ];
        // SAFETY: valid create info.
        self.set_layout = unsafe {
            d.create_descriptor_set_layout(&vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings), None)
        }?;
        let set_layouts = [self.set_layout];
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(push_stages())
            .offset(0)
            .size(std::mem::size_of::<Camera>() as u32)];
        let info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts).push_constant_ranges(&ranges);
        // SAFETY: valid create info.
        self.layout = unsafe { d.create_pipeline_layout(&info, None) }?;

        let mut modules = Vec::new();
        let made = (|| -> anyhow::Result<vk::Pipeline> {
            for (name, spv) in [("raygen", RGEN), ("miss", RMISS), ("closest-hit", RCHIT)] {
                let code = ash::util::read_spv(&mut std::io::Cursor::new(spv))
                    .with_context(|| format!("reading the {name} program's SPIR-V"))?;
                // SAFETY: valid SPIR-V (spirv-val checked it when it was built).
                modules
                    .push(unsafe { d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(&code), None) }?);
            }
            let stage = |module: vk::ShaderModule, stage: vk::ShaderStageFlags| {
                vk::PipelineShaderStageCreateInfo::default().stage(stage).module(module).name(c"main")
            };
            let stages = [
                stage(modules[0], vk::ShaderStageFlags::RAYGEN_KHR),
                stage(modules[1], vk::ShaderStageFlags::MISS_KHR),
                stage(modules[2], vk::ShaderStageFlags::CLOSEST_HIT_KHR),
            ];
            let groups = crate::ash_launcher::primary_groups();
            let info = [vk::RayTracingPipelineCreateInfoKHR::default()
                .stages(&stages)
                .groups(&groups)
                .max_pipeline_ray_recursion_depth(1)
                .layout(self.layout)];
            // SAFETY: valid create info; the modules and the layout are live.
            let pipelines = unsafe {
                self.dev.rt.create_ray_tracing_pipelines(
                    vk::DeferredOperationKHR::null(),
                    vk::PipelineCache::null(),
                    &info,
                    None,
                )
            }
            .map_err(|(_, e)| e)
            .context("vkCreateRayTracingPipelinesKHR")?;
            pipelines.first().copied().context("no pipeline made")
        })();
        for m in modules {
            // SAFETY: the pipeline (if made) no longer needs its modules.
            unsafe { d.destroy_shader_module(m, None) };
        }
        self.pipeline = made?;
        Ok(())
    }

    /// The SBT: raygen, miss and hit group handles, one region each, in a
    /// device-local buffer written by a staging copy.
    fn make_sbt(&mut self) -> anyhow::Result<()> {
        let dev = self.dev;
        let p = dev.rt_props;
        let align = |x: u64, a: u32| x.div_ceil(a as u64) * a as u64;
        let handle = p.handle_size as usize;
        // SAFETY: the pipeline has 3 groups; the data holds 3 handles.
        let handles = unsafe { dev.rt.get_ray_tracing_shader_group_handles(self.pipeline, 0, 3, 3 * handle) }?;
        let stride = align(p.handle_size as u64, p.handle_alignment);
        let region_size = align(stride, p.base_alignment);
        let size = 3 * region_size;
        let mut table = vec![0u8; size as usize];
        for g in 0..3 {
            let at = (g as u64 * region_size) as usize;
            table[at..at + handle].copy_from_slice(&handles[g * handle..(g + 1) * handle]);
        }
        // The buffer's address is aligned up to the base alignment inside it.
        let usage = vk::BufferUsageFlags::SHADER_BINDING_TABLE_KHR | vk::BufferUsageFlags::TRANSFER_DST;
        self.sbt = dev.buffer(size + p.base_alignment as u64, usage, false)?;
        let base = align(self.sbt.address, p.base_alignment);
        let staging = dev.buffer(size, vk::BufferUsageFlags::TRANSFER_SRC, true)?;
        let copied = (|| -> anyhow::Result<()> {
            // SAFETY: host-visible, coherent memory of at least `size` bytes; nothing uses it yet.
            unsafe {
                let ptr = dev.device.map_memory(staging.memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty())?;
                std::ptr::copy_nonoverlapping(table.as_ptr(), ptr as *mut u8, table.len());
                dev.device.unmap_memory(staging.memory);
            }
            let region = [vk::BufferCopy::default().dst_offset(base - self.sbt.address).size(size)];
            dev.submit_and_wait(|cmd| {
                let barrier = vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
                    .dst_access_mask(vk::AccessFlags::SHADER_READ);
                // SAFETY: both buffers live until the wait ends.
                unsafe {
                    dev.device.cmd_copy_buffer(cmd, staging.buffer, self.sbt.buffer, &region);
                    dev.device.cmd_pipeline_barrier(
                        cmd,
                        vk::PipelineStageFlags::TRANSFER,
                        vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                        vk::DependencyFlags::empty(),
                        &[barrier],
                        &[],
                        &[],
                    );
                }
            })
        })();
        dev.free(staging);
        copied?;
        let region =
            |g: u64| vk::StridedDeviceAddressRegionKHR { device_address: base + g * region_size, stride, size: stride };
        self.regions = [region(0), region(1), region(2), vk::StridedDeviceAddressRegionKHR::default()];
        Ok(())
    }

    /// The descriptor set: the TLAS and the output buffer.
    fn make_set(&mut self) -> anyhow::Result<()> {
        let d = &self.dev.device;
        let sizes = [
            vk::DescriptorPoolSize { ty: vk::DescriptorType::ACCELERATION_STRUCTURE_KHR, descriptor_count: 1 },
            vk::DescriptorPoolSize { ty: vk::DescriptorType::STORAGE_BUFFER, descriptor_count: 1 },
        ];
        // SAFETY: valid create info.
        self.descriptor_pool = unsafe {
            d.create_descriptor_pool(&vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes), None)
        }?;
        let layouts = [self.set_layout];
        let alloc =
            vk::DescriptorSetAllocateInfo::default().descriptor_pool(self.descriptor_pool).set_layouts(&layouts);
        // SAFETY: the pool has room for this one set.
        self.set = unsafe { d.allocate_descriptor_sets(&alloc) }?[0];
        let structures = [self.tlas.handle];
        let mut tlas_write =
            vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(&structures);
        let buffers =
            [vk::DescriptorBufferInfo::default().buffer(self.output.device.buffer).offset(0).range(vk::WHOLE_SIZE)];
        let writes = [
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(0)
                .descriptor_type(vk::DescriptorType::ACCELERATION_STRUCTURE_KHR)
                .descriptor_count(1)
                .push_next(&mut tlas_write),
            vk::WriteDescriptorSet::default()
                .dst_set(self.set)
                .dst_binding(1)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&buffers),
        ];
        // SAFETY: the set, the TLAS and the buffer are live; no launch uses the set yet.
        unsafe { d.update_descriptor_sets(&writes, &[]) };
        Ok(())
    }

    /// One launch of `dims` rays with `camera`; returns the seconds of the trace
    /// (GPU timestamps, else the wall time of the submission).
    pub fn launch(&self, camera: &Camera, dims: [u32; 3]) -> anyhow::Result<f64> {
        anyhow::ensure!(
            dims.iter().map(|&n| n as u64).product::<u64>() * 4 <= self.output.bytes,
            "a {dims:?} launch writes past the tracer's output"
        );
        let d = &self.dev.device;
        let [raygen, miss, hit, callable] = &self.regions;
        self.submitter.timed(
            |cmd| {
                // SAFETY: the pipeline, layout and set are the tracer's and live.
                unsafe {
                    d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::RAY_TRACING_KHR, self.pipeline);
                    d.cmd_bind_descriptor_sets(
                        cmd,
                        vk::PipelineBindPoint::RAY_TRACING_KHR,
                        self.layout,
                        0,
                        &[self.set],
                        &[],
                    );
                    d.cmd_push_constants(cmd, self.layout, push_stages(), 0, bytemuck::bytes_of(camera));
                }
            },
            // SAFETY: the tracer's SBT regions, of its pipeline bound above.
            |cmd| unsafe { self.dev.rt.cmd_trace_rays(cmd, raygen, miss, hit, callable, dims[0], dims[1], dims[2]) },
        )
    }

    /// The output buffer's words, copied out of device-local memory.
    pub fn picture(&self) -> anyhow::Result<Vec<u32>> {
        self.submitter.picture(&self.output)
    }
}

impl Drop for IndependentTracer<'_> {
    fn drop(&mut self) {
        let dev = self.dev;
        let d = &dev.device;
        // SAFETY: the device is live; waiting has no other requirement.
        let _ = unsafe { d.device_wait_idle() };
        self.submitter.destroy();
        self.output.unmap(d);
        // SAFETY: nothing is in flight (waited for above); objects go child first;
        // null handles (never made) are ignored by Vulkan.
        unsafe {
            d.destroy_descriptor_pool(self.descriptor_pool, None);
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
            for accel in [&self.tlas, &self.blas] {
                dev.accel.destroy_acceleration_structure(accel.handle, None);
            }
        }
        for b in [
            &mut self.sbt,
            &mut self.output.device,
            &mut self.output.readback,
            &mut self.tlas.storage,
            &mut self.blas.storage,
        ] {
            dev.free(std::mem::take(b));
        }
    }
}

/// How another primary-ray picture differs from raykit's (RGBA8 words).
#[derive(Clone, Copy, Debug, Default)]
pub struct Difference {
    /// Pixels of the picture.
    pub total: usize,
    /// Pixels not equal.
    pub differ: usize,
    /// Of those, pixels off by more than 1 in a channel (another triangle, other
    /// barycentrics) rather than a colour rounded the other way.
    pub beyond_one: usize,
    /// Of those, pixels that are the background on one side only.
    pub hit_miss: usize,
}

impl Difference {
    /// Whether the pictures show the same hits: colours rounded the other way
    /// anywhere, and at most one pixel in a thousand where another build's tree
    /// gave a ray the other triangle of a shared edge (or grazed it).
    pub fn acceptable(&self) -> bool {
        self.beyond_one <= self.total / 1000
    }

    /// Compares `theirs` with raykit's `ours`, `background` being the miss colour's word.
    pub fn of(ours: &[u32], theirs: &[u32], background: u32) -> Difference {
        let mut d = Difference { total: ours.len().max(theirs.len()), ..Difference::default() };
        d.differ = ours.len().abs_diff(theirs.len());
        for (&a, &b) in ours.iter().zip(theirs) {
            if a == b {
                continue;
            }
            d.differ += 1;
            let largest = [0, 8, 16, 24].iter().map(|s| ((a >> s) & 255).abs_diff((b >> s) & 255)).max().unwrap_or(0);
            if largest > 1 {
                d.beyond_one += 1;
            }
            if (a == background) != (b == background) {
                d.hit_miss += 1;
            }
        }
        d
    }
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} of {} pixels differ ({} by more than 1 in a channel, {} hit on one side and missed on the other)",
            self.differ, self.total, self.beyond_one, self.hit_miss
        )
    }
}

/// Fails when the validation layer reported anything, on raykit's context or on
/// the baseline's device (both empty unless `RAYKIT_VALIDATION=1`).
pub fn ensure_no_validation_messages(ctx: &raykit::Context, dev: &AshDevice) -> anyhow::Result<()> {
    let mut messages: Vec<String> = ctx.messages().snapshot().iter().map(|m| format!("raykit: {m}")).collect();
    messages.extend(dev.messages().into_iter().map(|m| format!("ash baseline: {m}")));
    anyhow::ensure!(
        messages.is_empty(),
        "the validation layer reported {} messages:\n{}",
        messages.len(),
        messages.join("\n")
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camera_is_the_programs_push_constant_block() {
        // Five std430 vec4s: eye, u, v, w, background.
        assert_eq!(std::mem::size_of::<Camera>(), 80);
        assert_eq!(std::mem::offset_of!(Camera, background), 64);
    }

    #[test]
    fn differences_are_told_apart() {
        let background = 0xff33_1a4d;
        let ours = [background, 0xff00_0000, 0xff10_2030, 0xff10_2030];
        let theirs = [background, 0xff00_0001, 0xff10_2040, background];
        let d = Difference::of(&ours, &theirs, background);
        assert_eq!((d.total, d.differ, d.beyond_one, d.hit_miss), (4, 3, 2, 1));
        assert_eq!(Difference::of(&ours, &ours, background).differ, 0);
        assert_eq!(Difference::of(&ours, &ours[..3], background).differ, 1);
    }
}
