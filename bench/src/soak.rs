//! The `soak` suite: many launches, each after an SBT record update, a GAS refit
//! and an IAS update, with host memory (resident set) and device memory (raykit's
//! allocator) sampled along the way. Both must stay flat: anything that grows
//! per launch is a leak. The last picture is checked against the last record.

use program_model_device::{pack, ColorRecord, Params, Radiance};
use raykit::glam::{Affine3A, UVec2, Vec3, Vec4};
use raykit::{
    BuildOptions, Context, Gas, Ias, Instance, LinkOptions, MemoryUsage, Module, Pipeline, ProgramGroup, Sbt,
    SbtRegion, Triangles,
};

/// One sample.
pub struct Sample {
    /// Launches done.
    pub launches: usize,
    /// Host resident set, KiB.
    pub rss_kib: u64,
    /// raykit's device memory.
    pub device: MemoryUsage,
}

fn rss_kib() -> u64 {
    // Linux: /proc/self/statm, resident pages in the second field.
    let text = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: u64 = text.split_whitespace().nth(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    pages * 4
}

/// Runs `launches` launches, sampling every `launches / 10`.
pub fn run(ctx: &Context, launches: usize) -> anyhow::Result<Vec<Sample>> {
    let quad = |dx: f32| -> Vec<Vec3> { program_model::QUAD.iter().map(|v| *v + Vec3::new(dx, 0.0, 0.0)).collect() };
    let updatable = BuildOptions::default().allow_update(true);
    let mut gas = Gas::builder().triangles(Triangles::new(&quad(0.0))).options(updatable).build(ctx)?;
    let place = Affine3A::from_translation(Vec3::new(-0.25, -0.25, 0.0));
    let mut ias = Ias::builder(&[Instance::new(&gas).transform(place)]).options(updatable).build(ctx)?;
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
    let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::RECORD_COLOR).build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
    let mut sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss_for::<Radiance, _>(&miss, ())
        .hit_for::<Radiance, _>(0, &hit, ColorRecord { color: Vec3::ZERO })
        .build()?;
    let size = 32u32;
    let image = ctx.buffer::<u32>((size * size) as usize)?;
    let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
    let every = (launches / 10).max(1);
    let mut samples = Vec::new();
    let mut color = Vec3::ZERO;
    for i in 0..=launches {
        if i % every == 0 {
            samples.push(Sample { launches: i, rss_kib: rss_kib(), device: ctx.memory_usage() });
        }
        if i == launches {
            break;
        }
        color = Vec3::new((i % 7) as f32 / 7.0, (i % 5) as f32 / 5.0, (i % 3) as f32 / 3.0);
        sbt.update(SbtRegion::Hit, 0, ColorRecord { color })?;
        let moved = quad(((i % 10) as f32) * 0.01);
        gas.update(&[Triangles::new(&moved).into()])?;
        ias.update(&[Instance::new(&gas).transform(place)])?;
        let params =
            Params { image: image.handle(), spheres: spheres.handle(), size: UVec2::splat(size), scene: ias.handle() };
        pipeline.launch(&sbt, &params, [size, size, 1])?;
    }
    let centre = image.read()?[(size / 2 * size + size / 2) as usize];
    anyhow::ensure!(
        centre == pack(color),
        "after {launches} launches the centre pixel is {centre:#x}, not the last record's colour"
    );
    Ok(samples)
}

/// The samples as a Markdown table, with the growth from the first sample after
/// warm-up (the second) to the last.
pub fn markdown(samples: &[Sample], device: &str) -> String {
    let mut out = format!(
        "Soak on {device}: each launch after an SBT record update, a GAS refit and an IAS update; 32×32 launches.\n\n\
         | launches | host RSS KiB | device allocations | allocated B | reserved B |\n|---:|---:|---:|---:|---:|\n"
    );
    for s in samples {
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} |\n",
            s.launches, s.rss_kib, s.device.allocations, s.device.allocated_bytes, s.device.reserved_bytes
        ));
    }
    if let (Some(first), Some(last)) = (samples.get(1), samples.last()) {
        out.push_str(&format!(
            "\nFrom {} to {} launches: host RSS {:+} KiB, device allocations {:+}, allocated bytes {:+}.\n",
            first.launches,
            last.launches,
            last.rss_kib as i64 - first.rss_kib as i64,
            last.device.allocations as i64 - first.device.allocations as i64,
            last.device.allocated_bytes as i64 - first.device.allocated_bytes as i64
        ));
    }
    out
}

/// The samples as JSON.
pub fn json(samples: &[Sample]) -> serde_json::Value {
    serde_json::Value::Array(
        samples
            .iter()
            .map(|s| {
                serde_json::json!({
                    "launches": s.launches, "rss_kib": s.rss_kib, "allocations": s.device.allocations,
                    "allocated_bytes": s.device.allocated_bytes, "reserved_bytes": s.device.reserved_bytes,
                })
            })
            .collect(),
    )
}
