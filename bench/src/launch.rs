//! The `launch` suite: raykit's launch path against a hand-written ash launch of
//! the same pipeline, SBT and acceleration structure; and pipeline + SBT
//! creation against hand-written ash.
//!
//! * Launch: raykit's `Pipeline::launch` (a command buffer and a fence per
//!   launch, push constants, trace, barrier, submit, wait) against the way a
//!   careful Vulkan programmer writes it: one command buffer and one fence kept
//!   from launch to launch, re-recorded each time (the params change), submitted
//!   and waited for. Both trace raykit's own `VkPipeline` and SBT regions (from
//!   `raykit::pipeline::raw`), so the difference is the launch path alone. Measured on a
//!   1×1 launch (overhead) and at the primary-ray size, wall clock.
//! * Creation: raykit's `Module::new` (with reflection) + program groups +
//!   `Pipeline::new` + `Sbt::build`, against `vkCreateShaderModule` +
//!   `vkCreatePipelineLayout` + `vkCreateRayTracingPipelinesKHR` + group handles and
//!   a host-visible SBT buffer written by hand, for the primary-ray programs.
//!   Twice, so that a compile cache never sits on one side only: without a cache
//!   (raykit in a fresh context with the disk cache off, so its in-memory
//!   `VkPipelineCache` starts empty; ash with no `VkPipelineCache`), and with a warm
//!   one (raykit's context cache; ash's own `VkPipelineCache`; each warmed by one
//!   creation before the samples).

use std::ffi::CStr;
use std::time::Instant;

use anyhow::Context as _;
use raykit::ash::vk;
use raykit::glam::Vec3;
use raykit::{Context, ContextOptions, PipelineCacheLocation};
use triangle_device::MissData;

use crate::ash_launcher::Submitter;
use crate::stats::Summary;
use crate::trace::{PrimaryPipeline, PrimaryScene};

/// One comparison's results.
pub struct Row {
    /// What was measured.
    pub what: String,
    /// Repetitions.
    pub reps: usize,
    /// raykit's seconds.
    pub raykit: Summary,
    /// The hand-written ash seconds.
    pub ash: Summary,
    /// Per-repetition ratio raykit / ash (< 1: raykit faster).
    pub ratio: Summary,
}

fn summarise(what: String, pairs: &[(f64, f64)]) -> Row {
    let raykit: Vec<f64> = pairs.iter().map(|p| p.0).collect();
    let ash: Vec<f64> = pairs.iter().map(|p| p.1).collect();
    let ratio: Vec<f64> = pairs.iter().map(|p| p.0 / p.1).collect();
    Row { what, reps: pairs.len(), raykit: Summary::of(&raykit), ash: Summary::of(&ash), ratio: Summary::of(&ratio) }
}

/// A hand-written launcher: one command pool, and one command buffer and
/// fence kept from launch to launch ([`Submitter`], without timestamps).
struct AshLauncher<'c> {
    device: &'c raykit::ash::Device,
    rt: &'c raykit::ash::khr::ray_tracing_pipeline::Device,
    pool: vk::CommandPool,
    submitter: Submitter<'c>,
}

impl<'c> AshLauncher<'c> {
    fn new(ctx: &'c Context) -> anyhow::Result<Self> {
        let device = ctx.raw_device().expect("a Vulkan context");
        let family = ctx.queue_family().expect("a Vulkan context");
        // SAFETY: queue 0 of raykit's family exists; this benchmark is single-threaded,
        // so raykit never submits to it at the same time.
        let queue = unsafe { device.get_device_queue(family, 0) };
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(family)
            .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
        // SAFETY: valid create info.
        let pool = unsafe { device.create_command_pool(&info, None) }?;
        let submitter = match Submitter::new(device, queue, pool, 0, 0.0) {
            Ok(submitter) => submitter,
            Err(e) => {
                // SAFETY: the pool was just created and nothing was allocated from it.
                unsafe { device.destroy_command_pool(pool, None) };
                return Err(e);
            }
        };
        Ok(AshLauncher { device, rt: ctx.raw_ray_tracing().expect("a Vulkan context"), pool, submitter })
    }

    fn launch(&self, ctx: &Context, p: &PrimaryPipeline, params: &[u8], dims: [u32; 3]) -> anyhow::Result<()> {
        let d = self.device;
        let [raygen, miss, hit, callable] = p.sbt.raw_regions().expect("a Vulkan context");
        let pipeline = p.pipeline.raw_pipeline().expect("a Vulkan context");
        let layout = p.pipeline.raw_layout().expect("a Vulkan context");
        let set = ctx.raw_buffer_table_set().expect("a Vulkan context");
        self.submitter.submit(|cmd| {
            // SAFETY: the command buffer is recording; the pipeline, layout, set
            // and SBT belong to live raykit objects.
            unsafe {
                d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::RAY_TRACING_KHR, pipeline);
                d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::RAY_TRACING_KHR, layout, 0, &[set], &[]);
                d.cmd_push_constants(cmd, layout, rt_stages(), 0, params);
                self.rt.cmd_trace_rays(cmd, &raygen, &miss, &hit, &callable, dims[0], dims[1], dims[2]);
                let barrier = vk::MemoryBarrier::default()
                    .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                    .dst_access_mask(vk::AccessFlags::HOST_READ);
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::RAY_TRACING_SHADER_KHR,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[barrier],
                    &[],
                    &[],
                );
            }
        })
    }
}

impl Drop for AshLauncher<'_> {
    fn drop(&mut self) {
        self.submitter.destroy();
        // SAFETY: nothing is in flight (every launch waited for its fence), and
        // the submitter freed its command buffer.
        unsafe { self.device.destroy_command_pool(self.pool, None) };
    }
}

/// Every ray-tracing stage: what the hand-written launches push constants to.
pub(crate) fn rt_stages() -> vk::ShaderStageFlags {
    vk::ShaderStageFlags::RAYGEN_KHR
        | vk::ShaderStageFlags::MISS_KHR
        | vk::ShaderStageFlags::CLOSEST_HIT_KHR
        | vk::ShaderStageFlags::ANY_HIT_KHR
        | vk::ShaderStageFlags::INTERSECTION_KHR
        | vk::ShaderStageFlags::CALLABLE_KHR
}

/// Launch-path comparison at `1×1` and at `size`.
pub fn launches(ctx: &Context, scene: &PrimaryScene, size: (u32, u32), reps: usize) -> anyhow::Result<Vec<Row>> {
    let p = crate::trace::primary_pipeline(ctx, crate::trace::Language::Rust)?;
    let ash = AshLauncher::new(ctx)?;
    let params = bytemuck::bytes_of(&scene.params);
    anyhow::ensure!(p.pipeline.raw_push_constant_size() as usize == params.len(), "the params are not push constants");
    let mut rows = Vec::new();
    for (dims, reps) in [([1, 1, 1], reps * 20), ([size.0, size.1, 1], reps)] {
        // Warm-up.
        p.pipeline.launch(&p.sbt, &scene.params, dims)?;
        ash.launch(ctx, &p, params, dims)?;
        let mut pairs = Vec::with_capacity(reps);
        for rep in 0..reps {
            let time_raykit = || -> anyhow::Result<f64> {
                let t = Instant::now();
                p.pipeline.launch(&p.sbt, &scene.params, dims)?;
                Ok(t.elapsed().as_secs_f64())
            };
            let time_ash = || -> anyhow::Result<f64> {
                let t = Instant::now();
                ash.launch(ctx, &p, params, dims)?;
                Ok(t.elapsed().as_secs_f64())
            };
            pairs.push(pair(rep, time_raykit, time_ash)?);
        }
        rows.push(summarise(format!("launch {}x{} (primary rays, wall clock)", dims[0], dims[1]), &pairs));
    }
    Ok(rows)
}

/// `launch-loop`: `n` 1×1 launches through raykit in a row, then `n` through the
/// hand-written ash launcher, each loop in a function of its own, for counting
/// instructions per launch with callgrind
/// (`valgrind --tool=callgrind --toggle-collect='*raykit_loop*'` and `'*ash_loop*'`);
/// also timed (wall clock per launch, the loops alternating over `reps` rounds).
pub fn launch_loop(ctx: &Context, scene: &PrimaryScene, n: usize, reps: usize) -> anyhow::Result<Vec<Row>> {
    let p = crate::trace::primary_pipeline(ctx, crate::trace::Language::Rust)?;
    let ash = AshLauncher::new(ctx)?;
    let params = bytemuck::bytes_of(&scene.params);
    anyhow::ensure!(p.pipeline.raw_push_constant_size() as usize == params.len(), "the params are not push constants");
    // Warm-up.
    raykit_loop(&p, scene, 1)?;
    ash_loop(ctx, &ash, &p, params, 1)?;
    let mut pairs = Vec::with_capacity(reps);
    for rep in 0..reps.max(1) {
        let time_raykit = || -> anyhow::Result<f64> {
            let t = Instant::now();
            raykit_loop(&p, scene, n)?;
            Ok(t.elapsed().as_secs_f64() / n as f64)
        };
        let time_ash = || -> anyhow::Result<f64> {
            let t = Instant::now();
            ash_loop(ctx, &ash, &p, params, n)?;
            Ok(t.elapsed().as_secs_f64() / n as f64)
        };
        pairs.push(pair(rep, time_raykit, time_ash)?);
    }
    Ok(vec![summarise(format!("{n} launches 1x1 in a row, per launch (primary rays, wall clock)"), &pairs)])
}

/// `n` blocking 1×1 launches through raykit.
#[inline(never)]
fn raykit_loop(p: &PrimaryPipeline, scene: &PrimaryScene, n: usize) -> anyhow::Result<()> {
    for _ in 0..n {
        p.pipeline.launch(&p.sbt, &scene.params, [1, 1, 1])?;
    }
    Ok(())
}

/// `n` blocking 1×1 launches through the hand-written ash launcher.
#[inline(never)]
fn ash_loop(ctx: &Context, ash: &AshLauncher<'_>, p: &PrimaryPipeline, params: &[u8], n: usize) -> anyhow::Result<()> {
    for _ in 0..n {
        ash.launch(ctx, p, params, [1, 1, 1])?;
    }
    Ok(())
}

/// The physical device raykit runs on (matched by name), for memory types.
fn memory_properties(ctx: &Context) -> anyhow::Result<vk::PhysicalDeviceMemoryProperties> {
    let instance = ctx.raw_instance().expect("a Vulkan context");
    // SAFETY: live instance.
    for physical in unsafe { instance.enumerate_physical_devices() }? {
        // SAFETY: `physical` came from this instance.
        let props = unsafe { instance.get_physical_device_properties(physical) };
        if props.device_name_as_c_str().is_ok_and(|n| n.to_string_lossy() == ctx.device_name()) {
            // SAFETY: as above.
            return Ok(unsafe { instance.get_physical_device_memory_properties(physical) });
        }
    }
    anyhow::bail!("raykit's device is not among the instance's devices")
}

/// Creates and destroys the primary-ray pipeline and SBT by hand, through `cache`
/// (null: no cache); returns the seconds from SPIR-V bytes to a written SBT.
fn ash_create(
    ctx: &Context,
    spirv: &[u32],
    memory: &vk::PhysicalDeviceMemoryProperties,
    cache: vk::PipelineCache,
) -> anyhow::Result<f64> {
    let d = ctx.raw_device().expect("a Vulkan context");
    let limits = ctx.limits();
    let start = Instant::now();
    // SAFETY: everything created here is destroyed below, after its last use;
    // the create infos point at live locals.
    unsafe {
        let module = d.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(spirv), None)?;
        let names: [&CStr; 3] = [c"__raygen__rg", c"__miss__ms", c"__closesthit__ch"];
        let kinds =
            [vk::ShaderStageFlags::RAYGEN_KHR, vk::ShaderStageFlags::MISS_KHR, vk::ShaderStageFlags::CLOSEST_HIT_KHR];
        let stages: Vec<_> = names
            .iter()
            .zip(kinds)
            .map(|(n, k)| vk::PipelineShaderStageCreateInfo::default().stage(k).module(module).name(n))
            .collect();
        let groups = crate::ash_launcher::primary_groups();
        let set_layouts = [ctx.raw_buffer_table_layout().expect("a Vulkan context")];
        let ranges = [vk::PushConstantRange::default().stage_flags(rt_stages()).offset(0).size(72)];
        let layout = d.create_pipeline_layout(
            &vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts).push_constant_ranges(&ranges),
            None,
        )?;
        let info = vk::RayTracingPipelineCreateInfoKHR::default()
            .stages(&stages)
            .groups(&groups)
            .max_pipeline_ray_recursion_depth(1)
            .layout(layout);
        let pipeline = ctx
            .raw_ray_tracing()
            .expect("a Vulkan context")
            .create_ray_tracing_pipelines(vk::DeferredOperationKHR::null(), cache, &[info], None)
            .map_err(|(_, e)| e)?[0];
        let handle_size = limits.shader_group_handle_size as usize;
        let handles = ctx.raw_ray_tracing().expect("a Vulkan context").get_ray_tracing_shader_group_handles(
            pipeline,
            0,
            3,
            3 * handle_size,
        )?;
        // Three regions, each one record, at the base alignment.
        let base = limits.shader_group_base_alignment.max(1) as u64;
        let record = (handle_size as u64 + 16).next_multiple_of(limits.shader_group_handle_alignment.max(1) as u64);
        let stride = record.next_multiple_of(base);
        let size = stride * 3;
        let buffer = d.create_buffer(
            &vk::BufferCreateInfo::default()
                .size(size)
                .usage(vk::BufferUsageFlags::SHADER_BINDING_TABLE_KHR | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS),
            None,
        )?;
        let req = d.get_buffer_memory_requirements(buffer);
        let wanted = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
        let type_index = (0..memory.memory_type_count)
            .find(|&i| {
                req.memory_type_bits & (1 << i) != 0 && memory.memory_types[i as usize].property_flags.contains(wanted)
            })
            .context("no host-visible memory for the SBT")?;
        let mut flags = vk::MemoryAllocateFlagsInfo::default().flags(vk::MemoryAllocateFlags::DEVICE_ADDRESS);
        let mem = d.allocate_memory(
            &vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(type_index)
                .push_next(&mut flags),
            None,
        )?;
        d.bind_buffer_memory(buffer, mem, 0)?;
        let ptr = d.map_memory(mem, 0, size, vk::MemoryMapFlags::empty())? as *mut u8;
        let bytes = std::slice::from_raw_parts_mut(ptr, size as usize);
        for g in 0..3 {
            let at = g * stride as usize;
            bytes[at..at + handle_size].copy_from_slice(&handles[g * handle_size..(g + 1) * handle_size]);
        }
        let miss = MissData { bg_color: Vec3::new(0.3, 0.1, 0.2) };
        let at = stride as usize + handle_size;
        bytes[at..at + 12].copy_from_slice(bytemuck::bytes_of(&miss));
        let _address = d.get_buffer_device_address(&vk::BufferDeviceAddressInfo::default().buffer(buffer));
        d.unmap_memory(mem);
        let elapsed = start.elapsed().as_secs_f64();
        d.destroy_buffer(buffer, None);
        d.free_memory(mem, None);
        d.destroy_pipeline(pipeline, None);
        d.destroy_pipeline_layout(layout, None);
        d.destroy_shader_module(module, None);
        Ok(elapsed)
    }
}

/// raykit's `Module::new` + program groups + `Pipeline::new` + `Sbt::build` in
/// `ctx`; the seconds it took.
fn raykit_create(ctx: &Context, bytes: &[u8]) -> anyhow::Result<f64> {
    let start = Instant::now();
    let module = raykit::Module::new(ctx, bytes)?;
    let raygen = raykit::ProgramGroup::raygen(&module, triangle_device::RG)?;
    let miss = raykit::ProgramGroup::miss(&module, triangle_device::MS)?;
    let hit = raykit::ProgramGroup::hit_group(&module).closest_hit(triangle_device::CH).build()?;
    let pipeline = raykit::Pipeline::<triangle_device::Params>::new(
        ctx,
        &[&raygen, &miss, &hit],
        raykit::LinkOptions { max_trace_depth: 1 },
    )?;
    let _sbt = raykit::Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss(&miss, MissData { bg_color: Vec3::new(0.3, 0.1, 0.2) })
        .hit(&hit, ())
        .build()?;
    Ok(start.elapsed().as_secs_f64())
}

/// One sample of each side, in the order `rep` picks (the first side first on
/// even repetitions).
pub(crate) fn pair<T>(
    rep: usize,
    raykit: impl FnOnce() -> anyhow::Result<T>,
    ash: impl FnOnce() -> anyhow::Result<T>,
) -> anyhow::Result<(T, T)> {
    Ok(if rep.is_multiple_of(2) {
        let r = raykit()?;
        (r, ash()?)
    } else {
        let a = ash()?;
        (raykit()?, a)
    })
}

/// Pipeline + SBT creation, raykit against hand-written ash, interleaved: one row
/// without a compile cache on either side, one with a warm cache on both.
pub fn creation(ctx: &Context, reps: usize) -> anyhow::Result<Vec<Row>> {
    let path = raykit::spirv_path("triangle-device");
    let bytes = std::fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let memory = memory_properties(ctx)?;

    // No cache: raykit has no cache-less mode (every context owns a VkPipelineCache),
    // so each pair gets a fresh context whose cache starts empty (disk cache off);
    // ash passes no cache. Context creation is outside the timed part.
    let fresh = || {
        Context::new(ContextOptions {
            validation: Some(false),
            device_name_contains: Some(ctx.device_name().into_owned()),
            pipeline_cache: PipelineCacheLocation::Off,
            ..Default::default()
        })
    };
    let mut cold = Vec::with_capacity(reps);
    for rep in 0..reps {
        let fresh = fresh()?;
        let null = vk::PipelineCache::null();
        cold.push(pair(rep, || raykit_create(&fresh, &bytes), || ash_create(&fresh, &words, &memory, null))?);
    }

    // Warm cache: raykit's context cache and an ash-owned cache, each warmed by one
    // creation first.
    let d = ctx.raw_device().expect("a Vulkan context");
    // SAFETY: valid create info; destroyed below after its last use.
    let cache = unsafe { d.create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None) }?;
    let warm = (|| -> anyhow::Result<Vec<(f64, f64)>> {
        raykit_create(ctx, &bytes)?;
        ash_create(ctx, &words, &memory, cache)?;
        let mut warm = Vec::with_capacity(reps);
        for rep in 0..reps {
            warm.push(pair(rep, || raykit_create(ctx, &bytes), || ash_create(ctx, &words, &memory, cache))?);
        }
        Ok(warm)
    })();
    // SAFETY: no pipeline creation uses the cache any more.
    unsafe { d.destroy_pipeline_cache(cache, None) };
    Ok(vec![
        summarise(
            "pipeline + SBT creation, no cache (raykit: fresh context, empty VkPipelineCache; ash: none)".to_owned(),
            &cold,
        ),
        summarise("pipeline + SBT creation, warm cache (both: in-memory VkPipelineCache)".to_owned(), &warm?),
    ])
}

/// The rows as a Markdown table.
pub fn markdown(rows: &[Row]) -> String {
    let mut s = String::from("raykit against hand-written ash on the same device; pairs in alternating order; median (± half the interquartile range); ratio = median of per-pair raykit/ash (< 1: raykit faster).\n\n");
    s.push_str("| what | reps | raykit ms | ash ms | raykit/ash (min–max) |\n|---|---:|---:|---:|---:|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {:.3} ± {:.1}% | {:.3} ± {:.1}% | {:.3} ({:.3}–{:.3}) |\n",
            r.what,
            r.reps,
            r.raykit.median * 1e3,
            r.raykit.spread_percent(),
            r.ash.median * 1e3,
            r.ash.spread_percent(),
            r.ratio.median,
            r.ratio.min,
            r.ratio.max
        ));
    }
    s
}

/// The rows as JSON.
pub fn json(rows: &[Row]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| serde_json::json!({"what": r.what, "reps": r.reps, "raykit_s": r.raykit.json(), "ash_s": r.ash.json(), "ratio": r.ratio.json()}))
            .collect(),
    )
}
