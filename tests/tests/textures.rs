//! Textures against a CPU reference sampler, on both backends.
//!
//! A quad covering texture coordinates [-0.75, 1.75]² is sampled once per pixel,
//! at an explicit level of detail, from raygen, closest-hit (its SBT record's
//! texture), any-hit, miss and a direct callable, for every texture format and
//! three samplers (bilinear with linear mip blending and repeat; nearest with
//! nearest mip and clamp/mirror; bilinear at level 0 with mirror/clamp). The CPU
//! reference implements Vulkan's sampling rules (texel coordinates, address
//! modes, bilinear weights, the mip level chosen from the LOD, sRGB decoded
//! before filtering) over the same mip chain the host generated, in `f64`, with
//! its own texel decoding: it shares no code with the CPU backend's sampler. Each
//! test runs on Vulkan and on the CPU backend (`with_each_backend`). The tolerance
//! is what Vulkan lets a device round: texel and mip weights carry only
//! `subTexelPrecisionBits` and `mipmapPrecisionBits` bits (read from the
//! device), so a result may be off by that share of the texture's value range;
//! 8-bit formats may also be filtered in 8-bit fixed point (lavapipe does), one
//! more 1/255 step (2/255 for sRGB, decoded through an 8-bit table). A wrong
//! level, texel, address mode or a missing sRGB decode is off by far more.
//! Where a nearest-filter coordinate lies within 10⁻³ texel of a texel edge, both
//! neighbours are accepted.

use raykit::glam::{UVec2, Vec4};
use raykit::texture::{filter_precision_bits, generate_mips, MipLevel};
use raykit::{
    AddressMode, Context, Error, Filter, Gas, Ias, LinkOptions, Mipmaps, Module, Pipeline, ProgramGroup,
    SamplerOptions, Sbt, Texture, TextureFormat, Triangles,
};
use raykit_tests::with_each_backend;
use texture_test_device::{
    pixel_uv, HitRecord, Params, ViaAnyHit, ViaCallable, ViaClosestHit, ViaMiss, AH, CH, CH_CALL, MISSED, MS,
    MS_SAMPLE, QUAD, RG, SAMPLE_TEXTURE, STAGES,
};

const SIZE: u32 = 24;
const TEX_W: u32 = 16;
const TEX_H: u32 = 8;

/// A deterministic hash of the texel index, for texel values.
fn hash(i: u32) -> u32 {
    let mut x = i.wrapping_mul(0x9e37_79b9) ^ 0x85eb_ca6b;
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x
}

/// Level 0's bytes: random 8-bit values, or floats in [-1, 3) for float formats.
fn texels(format: TextureFormat) -> Vec<u8> {
    let mut out = Vec::new();
    for t in 0..TEX_W * TEX_H {
        let v: [f32; 4] = std::array::from_fn(|c| (hash(t * 4 + c as u32) >> 8) as f32 / 16_777_216.0);
        match format {
            TextureFormat::Rgba8Srgb | TextureFormat::Rgba8Unorm => {
                out.extend((0..4).map(|c| (hash(t * 4 + c) >> 24) as u8));
            }
            _ => format.encode(v.map(|x| 4.0 * x - 1.0), &mut out),
        }
    }
    out
}

/// The Vulkan texel index of `i` in a dimension of `n` texels under `mode`.
fn wrap(i: i64, n: i64, mode: AddressMode) -> i64 {
    match mode {
        AddressMode::Repeat => i.rem_euclid(n),
        AddressMode::ClampToEdge => i.clamp(0, n - 1),
        AddressMode::MirroredRepeat => {
            let t = i.rem_euclid(2 * n);
            if t >= n {
                2 * n - 1 - t
            } else {
                t
            }
        }
    }
}

/// The linear value of an 8-bit sRGB code (the sRGB transfer function, in `f64`).
fn srgb_decode(code: u8) -> f32 {
    let c = code as f64 / 255.0;
    (if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }) as f32
}

/// An IEEE half-precision float's value.
fn half_value(bits: u16) -> f32 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exponent = i32::from((bits >> 10) & 0x1f);
    let mantissa = f64::from(bits & 0x3ff);
    let magnitude = match exponent {
        0 => mantissa * 2f64.powi(-24),
        31 if mantissa == 0.0 => f64::INFINITY,
        31 => f64::NAN,
        e => (1.0 + mantissa / 1024.0) * 2f64.powi(e - 15),
    };
    (sign * magnitude) as f32
}

/// The linear value of the texel in `bytes`: the reference's own decoding.
fn decode(format: TextureFormat, bytes: &[u8]) -> Vec4 {
    Vec4::from_array(std::array::from_fn(|c| match format {
        TextureFormat::Rgba8Srgb if c < 3 => srgb_decode(bytes[c]),
        TextureFormat::Rgba8Srgb | TextureFormat::Rgba8Unorm => bytes[c] as f32 / 255.0,
        TextureFormat::Rgba16Float => half_value(u16::from_le_bytes([bytes[2 * c], bytes[2 * c + 1]])),
        TextureFormat::Rgba32Float => f32::from_le_bytes(std::array::from_fn(|i| bytes[4 * c + i])),
        other => panic!("no reference decoding for {other:?}"),
    }))
}

/// The CPU reference sampler over a texture's mip chain.
struct Reference<'a> {
    format: TextureFormat,
    levels: &'a [MipLevel],
    options: SamplerOptions,
}

impl Reference<'_> {
    fn texel(&self, level: usize, x: i64, y: i64) -> Vec4 {
        let l = &self.levels[level];
        let x = wrap(x, l.width as i64, self.options.address_u);
        let y = wrap(y, l.height as i64, self.options.address_v);
        let bpt = self.format.bytes_per_texel();
        let i = (y as usize * l.width as usize + x as usize) * bpt;
        decode(self.format, &l.data[i..i + bpt])
    }

    /// Candidate results of sampling one level at `(u, v)` (two or four where a
    /// nearest coordinate lies on a texel edge).
    fn sample_level(&self, level: usize, u: f32, v: f32) -> Vec<Vec4> {
        let l = &self.levels[level];
        let (x, y) = (u as f64 * l.width as f64, v as f64 * l.height as f64);
        match self.options.filter {
            Filter::Nearest => {
                let candidates = |c: f64| {
                    let f = c.floor() as i64;
                    if (c - c.round()).abs() < 1e-3 {
                        vec![c.round() as i64 - 1, c.round() as i64]
                    } else {
                        vec![f]
                    }
                };
                let mut out = Vec::new();
                for &i in &candidates(x) {
                    for &j in &candidates(y) {
                        out.push(self.texel(level, i, j));
                    }
                }
                out
            }
            Filter::Linear => {
                let (x, y) = (x - 0.5, y - 0.5);
                let (i, j) = (x.floor() as i64, y.floor() as i64);
                let (a, b) = ((x - x.floor()) as f32, (y - y.floor()) as f32);
                let t = |di, dj| self.texel(level, i + di, j + dj);
                vec![
                    (1.0 - a) * (1.0 - b) * t(0, 0)
                        + a * (1.0 - b) * t(1, 0)
                        + (1.0 - a) * b * t(0, 1)
                        + a * b * t(1, 1),
                ]
            }
        }
    }

    /// Candidate results of sampling at `(u, v)` with level of detail `lod`.
    fn sample(&self, u: f32, v: f32, lod: f32) -> Vec<Vec4> {
        let q = self.levels.len() - 1;
        let lod = lod.clamp(0.0, q as f32);
        match self.options.mip_filter {
            Filter::Nearest => {
                let d = ((lod + 0.5).ceil() as usize).saturating_sub(1).min(q);
                self.sample_level(d, u, v)
            }
            Filter::Linear => {
                let d = (lod.floor() as usize).min(q);
                let delta = lod - d as f32;
                if d == q || delta == 0.0 {
                    return self.sample_level(d, u, v);
                }
                let lo = self.sample_level(d, u, v);
                let hi = self.sample_level(d + 1, u, v);
                lo.iter().flat_map(|a| hi.iter().map(move |b| (1.0 - delta) * *a + delta * *b)).collect()
            }
        }
    }
}

/// The test's programs, pipeline and scene.
struct Rig {
    pipeline: Pipeline<Params>,
    groups: [ProgramGroup; 7],
    ias: Ias,
}

impl Rig {
    fn new(ctx: &Context) -> anyhow::Result<Rig> {
        let module = Module::from_device_crate(ctx, "texture-test-device")?;
        let groups = [
            ProgramGroup::raygen(&module, RG)?,
            ProgramGroup::miss(&module, MS)?,
            ProgramGroup::miss(&module, MS_SAMPLE)?,
            ProgramGroup::hit_group(&module).closest_hit(CH).build()?,
            ProgramGroup::hit_group(&module).any_hit(AH).build()?,
            ProgramGroup::hit_group(&module).closest_hit(CH_CALL).build()?,
            ProgramGroup::callable(&module, SAMPLE_TEXTURE)?,
        ];
        let refs: Vec<&ProgramGroup> = groups.iter().collect();
        let pipeline = Pipeline::<Params>::new(ctx, &refs, LinkOptions { max_trace_depth: 1 })?;
        // Not opaque: any-hit programs run.
        let gas = Gas::builder().triangles(Triangles::new(&QUAD)).build(ctx)?;
        let ias = Ias::single(ctx, &gas)?;
        Ok(Rig { pipeline, groups, ias })
    }

    fn sbt(&self, record_texture: raykit::Texture2D) -> raykit::Result<Sbt> {
        let [rg, ms, ms_sample, ch, ah, ch_call, callable] = &self.groups;
        Sbt::builder(&self.pipeline)
            .raygen(rg, ())
            .miss_for::<ViaClosestHit, _>(ms, ())
            .miss_for::<ViaMiss, _>(ms_sample, ())
            .hit_for::<ViaClosestHit, _>(0, ch, HitRecord { texture: record_texture })
            .hit_for::<ViaAnyHit, _>(0, ah, ())
            .hit_for::<ViaCallable, _>(0, ch_call, ())
            .callable(callable, ())
            .build()
    }

    /// One sample per pixel of `texture` from `stage` at `lod`.
    fn render(&self, ctx: &Context, texture: &Texture, stage: u32, lod: f32) -> anyhow::Result<Vec<Vec4>> {
        let sbt = self.sbt(texture.handle())?;
        let out = ctx.buffer::<Vec4>((SIZE * SIZE) as usize)?;
        let params = Params {
            out: out.handle(),
            size: UVec2::splat(SIZE),
            texture: texture.handle(),
            stage,
            lod,
            scene: self.ias.handle(),
        };
        self.pipeline.launch(&sbt, &params, [SIZE, SIZE, 1])?;
        Ok(out.read()?)
    }
}

/// The four samplers, each with its level of detail.
fn samplers() -> [(SamplerOptions, f32, &'static str); 4] {
    [
        (
            SamplerOptions {
                filter: Filter::Nearest,
                mip_filter: Filter::Nearest,
                address_u: AddressMode::Repeat,
                address_v: AddressMode::Repeat,
            },
            0.0,
            "nearest, level 0, repeat",
        ),
        (
            SamplerOptions {
                filter: Filter::Linear,
                mip_filter: Filter::Linear,
                address_u: AddressMode::Repeat,
                address_v: AddressMode::Repeat,
            },
            1.3,
            "bilinear, mip blend 1.3, repeat",
        ),
        (
            SamplerOptions {
                filter: Filter::Nearest,
                mip_filter: Filter::Nearest,
                address_u: AddressMode::ClampToEdge,
                address_v: AddressMode::MirroredRepeat,
            },
            0.7,
            "nearest, mip 0.7 (level 1), clamp/mirror",
        ),
        (
            SamplerOptions {
                filter: Filter::Linear,
                mip_filter: Filter::Nearest,
                address_u: AddressMode::MirroredRepeat,
                address_v: AddressMode::ClampToEdge,
            },
            0.0,
            "bilinear, level 0, mirror/clamp",
        ),
    ]
}

#[test]
fn every_format_and_stage_samples_as_the_cpu_reference() -> anyhow::Result<()> {
    with_each_backend("every_format_and_stage_samples_as_the_cpu_reference", |ctx, backend| {
        let rig = Rig::new(ctx)?;
        let (sub_bits, mip_bits) = filter_precision_bits(ctx);
        let weight_error = 2.0 / (1u64 << sub_bits) as f32 + 1.0 / (1u64 << mip_bits) as f32;
        let mut failures = Vec::new();
        let mut checked = 0usize;
        for format in TextureFormat::ALL {
            let data = texels(format);
            let levels = generate_mips(format, TEX_W, TEX_H, &data)?;
            anyhow::ensure!(levels.len() == 5, "{format:?}: {} mip levels", levels.len());
            let (lo, hi) = levels[0]
                .data
                .chunks(format.bytes_per_texel())
                .map(|t| decode(format, t).to_array())
                .fold((f32::MAX, f32::MIN), |(lo, hi), t| {
                    (t.iter().fold(lo, |a, &b| a.min(b)), t.iter().fold(hi, |a, &b| a.max(b)))
                });
            let step = match format {
                TextureFormat::Rgba8Srgb => 2.0 / 255.0,
                TextureFormat::Rgba8Unorm => 1.0 / 255.0,
                _ => 0.0,
            };
            let tolerance = weight_error * (hi - lo) + step + 1e-4;
            for (options, lod, what) in samplers() {
                let texture = Texture::from_levels(ctx, format, &levels, options)?;
                anyhow::ensure!(texture.mip_levels() == 5 && texture.size() == (TEX_W, TEX_H));
                let reference = Reference { format, levels: &levels, options };
                for (stage, stage_name) in STAGES {
                    let got = rig.render(ctx, &texture, stage, lod)?;
                    let mut worst = 0.0f32;
                    for y in 0..SIZE {
                        for x in 0..SIZE {
                            let uv = pixel_uv(UVec2::new(x, y), UVec2::splat(SIZE));
                            let g = got[(y * SIZE + x) as usize];
                            anyhow::ensure!(g != MISSED, "{format:?} {what} {stage_name}: pixel ({x}, {y}) missed");
                            let error = reference
                                .sample(uv.x, uv.y, lod)
                                .iter()
                                .map(|w| (g - *w).abs().max_element())
                                .fold(f32::MAX, f32::min);
                            worst = worst.max(error);
                            checked += 1;
                            if error > tolerance && failures.len() < 20 {
                                failures.push(format!(
                                    "{format:?}, {what}, {stage_name}: pixel ({x}, {y}) uv {uv}: {g} vs reference {:?} (off by {error}, tolerance {tolerance})",
                                    reference.sample(uv.x, uv.y, lod)
                                ));
                            }
                        }
                    }
                    eprintln!(
                        "[{backend:?}] {format:?}, {what}, {stage_name}: worst error {worst:.2e} (tolerance {tolerance:.2e})"
                    );
                }
            }
        }
        anyhow::ensure!(failures.is_empty(), "samples off the reference:\n{}", failures.join("\n"));
        anyhow::ensure!(checked == 4 * 4 * 5 * (SIZE * SIZE) as usize);
        Ok(())
    })
}

#[test]
fn sampling_an_image_crate_picture_decodes_srgb() -> anyhow::Result<()> {
    with_each_backend("sampling_an_image_crate_picture_decodes_srgb", |ctx, _backend| {
        let rig = Rig::new(ctx)?;
        // A uniform sRGB grey of 188 is linear 0.5 (within half an 8-bit step).
        let picture = image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(4, 4, image::Rgb([188, 188, 188])));
        let texture = Texture::from_image(ctx, &picture, true, Mipmaps::Generate, SamplerOptions::default())?;
        anyhow::ensure!(texture.format() == TextureFormat::Rgba8Srgb && texture.mip_levels() == 3);
        let want = srgb_decode(188);
        for (stage, name) in STAGES {
            for lod in [0.0, 1.5, 2.0] {
                let got = rig.render(ctx, &texture, stage, lod)?;
                for g in &got {
                    anyhow::ensure!(
                        (g.x - want).abs() < 2.0 / 255.0 && (g.w - 1.0).abs() < 1e-6,
                        "{name} at lod {lod}: {g}, want ({want}, …, 1)"
                    );
                }
            }
        }
        // The same picture as linear data is not decoded: 188 / 255.
        let linear = Texture::from_image(ctx, &picture, false, Mipmaps::One, SamplerOptions::default())?;
        let got = rig.render(ctx, &linear, texture_test_device::STAGE_RAYGEN, 0.0)?;
        anyhow::ensure!(got.iter().all(|g| (g.x - 188.0 / 255.0).abs() < 1.0 / 255.0), "{}", got[0]);
        // A 32-bit float picture keeps values above 1.
        let hdr = image::DynamicImage::ImageRgb32F(image::Rgb32FImage::from_pixel(2, 2, image::Rgb([3.5, 0.25, 0.0])));
        let texture = Texture::from_image(ctx, &hdr, false, Mipmaps::Generate, SamplerOptions::default())?;
        anyhow::ensure!(texture.format() == TextureFormat::Rgba32Float);
        let got = rig.render(ctx, &texture, texture_test_device::STAGE_CLOSEST_HIT, 0.5)?;
        anyhow::ensure!(got.iter().all(|g| (*g - Vec4::new(3.5, 0.25, 0.0, 1.0)).abs().max_element() < 1e-5));
        Ok(())
    })
}

#[test]
fn image_files_load_as_textures_by_their_contents() -> anyhow::Result<()> {
    let dir = raykit_tests::temp_dir("texture_files")?;
    let picture = image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(8, 8, image::Rgb([188, 188, 188])));
    let png = dir.0.join("grey.png");
    picture.save(&png)?;
    // A JPEG under a name that says PNG: the format is read from the bytes.
    let jpeg = dir.0.join("grey-really-a-jpeg.png");
    picture.save_with_format(&jpeg, image::ImageFormat::Jpeg)?;
    anyhow::ensure!(std::fs::read(&jpeg)?.starts_with(&[0xff, 0xd8]), "not a JPEG");
    with_each_backend("image_files_load_as_textures_by_their_contents", |ctx, backend| {
        let rig = Rig::new(ctx)?;
        let want = srgb_decode(188);
        for file in [&png, &jpeg] {
            let texture = Texture::load(ctx, file, true, Mipmaps::Generate, SamplerOptions::default())?;
            anyhow::ensure!(texture.format() == TextureFormat::Rgba8Srgb && texture.size() == (8, 8));
            let got = rig.render(ctx, &texture, texture_test_device::STAGE_RAYGEN, 0.0)?;
            // JPEG may move a flat grey by a level or two.
            let worst = got.iter().map(|g| (g.x - want).abs()).fold(0.0, f32::max);
            anyhow::ensure!(worst < 3.0 / 255.0, "[{backend:?}] {}: off by {worst}", file.display());
        }
        Ok(())
    })
}

#[test]
fn dropped_and_null_texture_handles() -> anyhow::Result<()> {
    with_each_backend("dropped_and_null_texture_handles", |ctx, _backend| {
        let rig = Rig::new(ctx)?;
        let data = texels(TextureFormat::Rgba8Unorm);
        let make = || {
            Texture::new(ctx, TextureFormat::Rgba8Unorm, TEX_W, TEX_H, &data, Mipmaps::One, SamplerOptions::default())
        };
        let kept = make()?;
        // A dropped texture's handle in the params is refused, naming the field.
        let dropped = make()?;
        let stale = dropped.handle();
        drop(dropped);
        let sbt = rig.sbt(kept.handle())?;
        let out = ctx.buffer::<Vec4>((SIZE * SIZE) as usize)?;
        let params = |texture| Params {
            out: out.handle(),
            size: UVec2::splat(SIZE),
            texture,
            stage: texture_test_device::STAGE_RAYGEN,
            lod: 0.0,
            scene: rig.ias.handle(),
        };
        match rig.pipeline.launch(&sbt, &params(stale), [SIZE, SIZE, 1]) {
            Err(Error::Launch(raykit::LaunchError::InvalidHandle { field, record: None, problem, .. })) => {
                anyhow::ensure!(field == "texture" && problem.contains("no live Texture"), "{field}: {problem}")
            }
            other => anyhow::bail!("a dropped texture's handle was not refused: {other:?}"),
        }
        // In an SBT record, the error names the record.
        let record_texture = make()?;
        let sbt_stale = rig.sbt(record_texture.handle())?;
        drop(record_texture);
        match rig.pipeline.launch(&sbt_stale, &params(kept.handle()), [SIZE, SIZE, 1]) {
            Err(Error::Launch(raykit::LaunchError::InvalidHandle { field, record: Some(_), .. })) => {
                anyhow::ensure!(field == "texture")
            }
            other => anyhow::bail!("a dropped texture's handle in a record was not refused: {other:?}"),
        }
        // The null handle samples zero colour (a null descriptor).
        rig.pipeline.launch(&sbt, &params(raykit::Texture2D::NULL), [SIZE, SIZE, 1])?;
        let got = out.read()?;
        anyhow::ensure!(got.iter().all(|g| g.truncate() == raykit::glam::Vec3::ZERO), "{}", got[0]);
        Ok(())
    })
}

#[test]
fn a_texture_dropped_while_a_launch_samples_it_lives_until_the_launch_ends() -> anyhow::Result<()> {
    with_each_backend("a_texture_dropped_while_a_launch_samples_it_lives_until_the_launch_ends", |ctx, _backend| {
        let rig = Rig::new(ctx)?;
        let uniform = |value: [f32; 4]| -> raykit::Result<Texture> {
            let mut data = Vec::new();
            for _ in 0..TEX_W * TEX_H {
                TextureFormat::Rgba32Float.encode(value, &mut data);
            }
            Texture::new(
                ctx,
                TextureFormat::Rgba32Float,
                TEX_W,
                TEX_H,
                &data,
                Mipmaps::Generate,
                SamplerOptions::default(),
            )
        };
        let baseline = ctx.memory_usage();
        let texture = uniform([0.25, 0.5, 0.75, 1.0])?;
        let sbt = rig.sbt(texture.handle())?;
        let out = ctx.buffer::<Vec4>((SIZE * SIZE) as usize)?;
        let params = Params {
            out: out.handle(),
            size: UVec2::splat(SIZE),
            texture: texture.handle(),
            stage: texture_test_device::STAGE_CLOSEST_HIT,
            lod: 0.5,
            scene: rig.ias.handle(),
        };
        // The gate holds the launch until it opens: the texture is dropped while
        // the launch is pending, and another one made (on Vulkan its upload waits
        // for the launch, which opens the gate).
        let gate = ctx.close_submission_gate()?;
        let launch = rig.pipeline.launch_async(&sbt, &params, [SIZE, SIZE, 1])?;
        let readback = out.read_async()?;
        drop(texture);
        anyhow::ensure!(!launch.is_done()?, "the gate let the launch run");
        let other = uniform([9.0; 4])?;
        gate.open()?;
        launch.wait()?;
        let got = readback.wait()?;
        let want = Vec4::new(0.25, 0.5, 0.75, 1.0);
        let worst = got.iter().map(|g| (*g - want).abs().max_element()).fold(0.0, f32::max);
        anyhow::ensure!(worst < 1e-5, "the launch sampled {} where the dropped texture holds {want}", got[0]);
        drop((other, sbt, out));
        ctx.wait_idle()?;
        let end = ctx.memory_usage();
        anyhow::ensure!(
            (end.allocations, end.allocated_bytes) == (baseline.allocations, baseline.allocated_bytes),
            "textures leaked: {baseline:?} before, {end:?} after"
        );
        Ok(())
    })
}

#[test]
fn environment_sampling_on_the_device_matches_the_host() -> anyhow::Result<()> {
    use raykit::glam::Vec3;
    use texture_test_device::{environment_numbers, EnvironmentParams, RG_ENVIRONMENT};
    with_each_backend("environment_sampling_on_the_device_matches_the_host", |ctx, _backend| {
        // A sky with a sun: the samples crowd around the sun.
        let (w, h) = (64u32, 32u32);
        let mut radiance = vec![Vec3::new(0.2, 0.3, 0.5); (w * h) as usize];
        for (x, y, v) in [(40, 9, 800.0), (41, 9, 300.0), (40, 10, 300.0)] {
            radiance[(y * w + x) as usize] = Vec3::splat(v);
        }
        let map = raykit_scene::EnvironmentMap::new(w, h, radiance)?;
        let module = Module::from_device_crate(ctx, "texture-test-device")?;
        let raygen = ProgramGroup::raygen(&module, RG_ENVIRONMENT)?;
        let pipeline = Pipeline::<EnvironmentParams>::new(ctx, &[&raygen], LinkOptions { max_trace_depth: 1 })?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let count = 4096u32;
        let out = ctx.buffer::<Vec4>(count as usize)?;
        let cdf = ctx.buffer_from(&map.cdf)?;
        let params = EnvironmentParams { out: out.handle(), cdf: cdf.handle(), width: w, height: h };
        pipeline.launch(&sbt, &params, [count, 1, 1])?;
        let got = out.read()?;
        let mut near_sun = 0;
        for (i, g) in got.iter().enumerate() {
            let (u1, u2) = environment_numbers(i as u32);
            let want = map.sample(u1, u2);
            let (d, pdf) = (g.truncate(), g.w);
            anyhow::ensure!(
                (d - want.direction).length() < 1e-4 && (pdf - want.pdf).abs() <= 1e-4 * want.pdf.max(1.0),
                "sample {i}: device ({d}, pdf {pdf}), host ({}, pdf {})",
                want.direction,
                want.pdf
            );
            if map.radiance(d).x > 100.0 {
                near_sun += 1;
            }
        }
        // The sun's three texels hold this share of the sampling weight.
        let weight = |x: u32, y: u32| {
            raykit_scene::environment::luminance(map.radiance[(y * w + x) as usize]) as f64
                * (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin()
        };
        let total: f64 = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| weight(x, y)).sum();
        let share = (weight(40, 9) + weight(41, 9) + weight(40, 10)) / total;
        let expected = share * count as f64;
        let sd = (count as f64 * share * (1.0 - share)).sqrt();
        anyhow::ensure!(
            (near_sun as f64 - expected).abs() < 5.0 * sd,
            "{near_sun} of {count} samples at the sun, expected {expected:.0} ± {sd:.0}"
        );
        Ok(())
    })
}
