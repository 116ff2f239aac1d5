//! glTF scenes on raykit: the host half.
//!
//! [`GpuScene::new`] turns a [`GltfScene`] into acceleration structures and
//! records: one GAS per mesh with a geometry per primitive (opaque unless its
//! material is alpha-masked), one IAS instance per mesh node with its world
//! transform, vertex buffers per primitive, a texture per (image, colour space)
//! the materials use. [`Renderer`] links the programs of `gltf-pathtracer-device`
//! and lays out one hit record per (instance, primitive), reached through each
//! instance's SBT offset; [`Renderer::primary_hits`] renders each pixel's
//! primary hit (material index and texture coordinates).

use std::collections::HashMap;

use gltf_pathtracer_device::{GeometryRecord, Params, Primary, TraceParams};
use raykit::glam::{Affine3A, UVec2, Vec2, Vec3, Vec4};
use raykit::{
    AddressMode, Context, DeviceBuffer, Filter, Gas, GeometryFlags, Ias, Instance, LinkOptions, Mipmaps, Module,
    Pipeline, ProgramGroup, SamplerOptions, Sbt, Texture, TextureFormat, Triangles,
};
use raykit_scene::gltf::{AlphaMode, GltfScene};
use raykit_scene::{Camera, EnvironmentMap};

pub use gltf_pathtracer_device as device;

pub mod demo_scene;
pub mod view;

/// A primitive's device buffers.
struct PrimitiveBuffers {
    indices: DeviceBuffer<u32>,
    uvs: DeviceBuffer<Vec2>,
    normals: DeviceBuffer<Vec3>,
    tangents: DeviceBuffer<Vec4>,
    coverage: DeviceBuffer<u32>,
}

/// The coverage bits of a masked material: per texel of its base-colour image, whether
/// alpha × `factor` reaches `cutoff` (one texel of `factor` alone without an image).
fn coverage_bits(scene: &GltfScene, image: Option<usize>, factor: f32, cutoff: f32) -> (Vec<u32>, u32, u32) {
    let Some(img) = image.map(|i| &scene.images[i]) else {
        return (vec![if factor >= cutoff { u32::MAX } else { 0 }], 1, 1);
    };
    let texels = (img.width * img.height) as usize;
    let mut bits = vec![0u32; texels.div_ceil(32)];
    for t in 0..texels {
        if img.rgba8[t * 4 + 3] as f32 / 255.0 * factor >= cutoff {
            bits[t / 32] |= 1 << (t % 32);
        }
    }
    (bits, img.width, img.height)
}

/// The mean of an sRGB image's texels, in linear light.
fn linear_mean(image: &raykit_scene::gltf::Image) -> Vec3 {
    let decode = |c: u8| raykit::device::color::srgb_to_linear(c as f32 / 255.0) as f64;
    let mut sum = [0.0f64; 3];
    for texel in image.rgba8.chunks_exact(4) {
        for (s, &c) in sum.iter_mut().zip(texel) {
            *s += decode(c);
        }
    }
    let n = (image.rgba8.len() / 4).max(1) as f64;
    Vec3::new((sum[0] / n) as f32, (sum[1] / n) as f32, (sum[2] / n) as f32)
}

/// The emissive triangles of a scene, for light sampling (see
/// `gltf_pathtracer_device::LIGHT_STRIDE` for the layout).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightTable {
    /// [`gltf_pathtracer_device::LIGHT_STRIDE`] `Vec4`s per triangle.
    pub lights: Vec<Vec4>,
    /// Per triangle: the raw emissive texture handle.
    pub textures: Vec<u32>,
    /// The CDF of the triangles' power.
    pub cdf: Vec<f32>,
}

impl LightTable {
    /// The number of light triangles.
    pub fn len(&self) -> usize {
        self.cdf.len()
    }

    /// Whether the scene has no emissive triangles.
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }
}

/// A glTF scene on the device.
pub struct GpuScene {
    /// The TLAS.
    pub ias: Ias,
    /// The hit record of each (instance, primitive), in SBT order.
    pub records: Vec<GeometryRecord>,
    /// Whether each record's material is alpha-masked.
    pub masked: Vec<bool>,
    /// The emissive triangles: every triangle of every (instance, primitive) whose
    /// material's emissive factor × strength is not black and which is not alpha-masked
    /// (masked emitters are found by BSDF sampling alone), in world space, picked in
    /// proportion to its power (area × the mean of the emitted radiance's channels, the
    /// radiance being the factor × strength × the emissive texture's mean; the texture
    /// itself is sampled at the point picked).
    pub light_table: LightTable,
    lights: DeviceBuffer<Vec4>,
    light_textures: DeviceBuffer<u32>,
    light_cdf: DeviceBuffer<f32>,
    _buffers: Vec<PrimitiveBuffers>,
    _textures: HashMap<(usize, bool), Texture>,
}

impl std::fmt::Debug for GpuScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuScene").field("records", &self.records.len()).finish()
    }
}

/// How the renderer samples material textures: nearest texel, no mip levels, repeat (alpha masks cut
/// exactly along texel edges).
pub const MATERIAL_SAMPLER: SamplerOptions = SamplerOptions {
    filter: Filter::Nearest,
    mip_filter: Filter::Nearest,
    address_u: AddressMode::Repeat,
    address_v: AddressMode::Repeat,
};

impl GpuScene {
    /// Uploads `scene`.
    pub fn new(ctx: &Context, scene: &GltfScene) -> anyhow::Result<GpuScene> {
        let mut textures = HashMap::new();
        let mut texture = |image: usize, srgb: bool| -> anyhow::Result<raykit::Texture2D> {
            if let Some(t) = textures.get(&(image, srgb)) {
                return Ok(Texture::handle(t));
            }
            let img = &scene.images[image];
            let format = if srgb { TextureFormat::Rgba8Srgb } else { TextureFormat::Rgba8Unorm };
            let t = Texture::new(ctx, format, img.width, img.height, &img.rgba8, Mipmaps::One, MATERIAL_SAMPLER)?;
            let handle = t.handle();
            textures.insert((image, srgb), t);
            Ok(handle)
        };
        let mut gases = Vec::new();
        let mut buffers = Vec::new();
        // Per mesh: the records of its primitives (without the instance).
        let mut mesh_records: Vec<Vec<(GeometryRecord, bool)>> = Vec::new();
        for mesh in &scene.meshes {
            let mut builder = Gas::builder();
            let mut records = Vec::new();
            for p in &mesh.primitives {
                let material = &scene.materials[p.material];
                let masked = matches!(material.alpha, AlphaMode::Mask(_));
                let flags = if masked { GeometryFlags::NONE } else { GeometryFlags::OPAQUE };
                builder = builder.triangles(Triangles::new(&p.positions).indices_u32(&p.indices).flags(flags));
                let (coverage, coverage_width, coverage_height) = match material.alpha {
                    AlphaMode::Mask(cutoff) => {
                        coverage_bits(scene, material.base_color_texture, material.base_color.w, cutoff)
                    }
                    _ => (vec![u32::MAX], 1, 1),
                };
                let b = PrimitiveBuffers {
                    indices: ctx.buffer_from(&p.indices)?,
                    uvs: ctx.buffer_from(&p.uvs)?,
                    normals: ctx.buffer_from(&p.normals)?,
                    // One zero tangent when the file has none (a normal map is then not applied).
                    tangents: ctx.buffer_from(if p.tangents.is_empty() { &[Vec4::ZERO][..] } else { &p.tangents })?,
                    coverage: ctx.buffer_from(&coverage)?,
                };
                let mut optional = |image: Option<usize>, srgb: bool| match image {
                    Some(i) => texture(i, srgb),
                    None => Ok(raykit::Texture2D::NULL),
                };
                let base_color = optional(material.base_color_texture, true)?;
                let metallic_roughness = optional(material.metallic_roughness_texture, false)?;
                let emissive_texture = optional(material.emissive_texture, true)?;
                // Normal maps need the file's tangents (none are generated).
                let normal_texture = if p.tangents.is_empty() {
                    raykit::Texture2D::NULL
                } else {
                    optional(material.normal_texture, false)?
                };
                records.push((
                    GeometryRecord {
                        indices: b.indices.handle(),
                        uvs: b.uvs.handle(),
                        normals: b.normals.handle(),
                        tangents: b.tangents.handle(),
                        normal_texture,
                        normal_scale: material.normal_scale,
                        material: p.material as u32,
                        light_offset: gltf_pathtracer_device::NO_LIGHT,
                        callable: 0,
                        base_color,
                        base_color_factor: material.base_color.truncate(),
                        metallic_roughness,
                        metallic: material.metallic,
                        roughness: material.roughness,
                        emissive_texture,
                        emissive: material.emissive * material.emissive_strength,
                        coverage: b.coverage.handle(),
                        coverage_width,
                        coverage_height,
                    },
                    masked,
                ));
                buffers.push(b);
            }
            gases.push(builder.build(ctx)?);
            mesh_records.push(records);
        }
        let mut instances = Vec::new();
        let mut records = Vec::new();
        let mut masked = Vec::new();
        let mut table = LightTable::default();
        let mut power = Vec::new();
        for (i, inst) in scene.instances.iter().enumerate() {
            let offset = records.len() as u32;
            let transform = Affine3A::from_mat4(inst.transform);
            instances
                .push(Instance::new(&gases[inst.mesh]).transform(transform).custom_index(i as u32).sbt_offset(offset));
            for (&(mut r, m), p) in mesh_records[inst.mesh].iter().zip(&scene.meshes[inst.mesh].primitives) {
                let material = &scene.materials[p.material];
                let emitted = material.emissive * material.emissive_strength;
                // Alpha-masked emitters are left to BSDF sampling: a point picked on the triangle
                // may lie in a hole.
                if emitted.max_element() > 0.0 && !m {
                    r.light_offset = power.len() as u32;
                    let mean = material.emissive_texture.map_or(Vec3::ONE, |t| linear_mean(&scene.images[t]));
                    for t in p.indices.chunks_exact(3) {
                        let [a, b, c] =
                            [t[0], t[1], t[2]].map(|k| inst.transform.transform_point3(p.positions[k as usize]));
                        let [ua, ub, uc] = [t[0], t[1], t[2]].map(|k| p.uvs[k as usize]);
                        let area = 0.5 * (b - a).cross(c - a).length();
                        power.push(area as f64 * (emitted * mean).element_sum() as f64 / 3.0);
                        table.lights.extend([
                            a.extend(0.0),
                            b.extend(area),
                            c.extend(0.0),
                            emitted.extend(0.0),
                            Vec4::new(ua.x, ua.y, ub.x, ub.y),
                            Vec4::new(uc.x, uc.y, 0.0, 0.0),
                        ]);
                        table.textures.push(r.emissive_texture.raw());
                    }
                }
                records.push(r);
                masked.push(m);
            }
        }
        let total: f64 = power.iter().sum();
        if total > 0.0 && total.is_finite() {
            let mut running = 0.0;
            for (k, w) in power.iter().enumerate() {
                running += w;
                table.cdf.push((running / total) as f32);
                table.lights[k * gltf_pathtracer_device::LIGHT_STRIDE as usize].w = (w / total) as f32;
            }
            if let Some(last) = table.cdf.last_mut() {
                *last = 1.0;
            }
        } else {
            // Nothing emits measurably: no light sampling (emission is still found by the BSDF).
            table = LightTable::default();
            records.iter_mut().for_each(|r| r.light_offset = gltf_pathtracer_device::NO_LIGHT);
        }
        // Buffers of at least one element (an empty table is not sampled: `light_count` is 0).
        let or_one = |v: &[Vec4]| if v.is_empty() { vec![Vec4::ZERO] } else { v.to_vec() };
        let lights = ctx.buffer_from(&or_one(&table.lights))?;
        let light_textures = ctx.buffer_from(if table.textures.is_empty() { &[0u32][..] } else { &table.textures })?;
        let light_cdf = ctx.buffer_from(if table.cdf.is_empty() { &[1.0f32][..] } else { &table.cdf })?;
        let ias = Ias::new(ctx, &instances)?;
        Ok(GpuScene {
            ias,
            records,
            masked,
            light_table: table,
            lights,
            light_textures,
            light_cdf,
            _buffers: buffers,
            _textures: textures,
        })
    }
}

/// The SBT of `pipeline` for `scene`: raygen, the primary miss program, one hit
/// record per (instance, primitive) with the opaque or the masked hit group.
fn scene_sbt<P: raykit::LaunchParams>(
    pipeline: &Pipeline<P>,
    groups: &[ProgramGroup; 4],
    scene: &GpuScene,
) -> raykit::Result<Sbt> {
    let [raygen, miss, opaque, masked] = groups;
    let mut sbt = Sbt::builder(pipeline).raygen(raygen, ()).miss_for::<Primary, _>(miss, ());
    for (i, (record, is_masked)) in scene.records.iter().zip(&scene.masked).enumerate() {
        sbt = sbt.hit_at(i, if *is_masked { masked } else { opaque }, *record);
    }
    sbt.build()
}

/// The program groups: `raygen`, the miss program, the opaque and the masked hit groups.
fn groups(module: &Module, raygen: raykit::EntryPoint) -> raykit::Result<[ProgramGroup; 4]> {
    use gltf_pathtracer_device::{AH_MASK, CH, MS};
    Ok([
        ProgramGroup::raygen(module, raygen)?,
        ProgramGroup::miss(module, MS)?,
        ProgramGroup::hit_group(module).closest_hit(CH).build()?,
        ProgramGroup::hit_group(module).closest_hit(CH).any_hit(AH_MASK).build()?,
    ])
}

/// The path tracer for one scene, environment and image size: progressive
/// launches into an accumulation buffer (see `gltf_pathtracer_device::rg_path`).
pub struct PathTracer {
    pipeline: Pipeline<TraceParams>,
    sbt: Sbt,
    accum: DeviceBuffer<Vec4>,
    _env: Texture,
    _env_cdf: DeviceBuffer<f32>,
    params: TraceParams,
    samples_done: u32,
    light_count: u32,
    /// The guides' buffers (albedo, normal) once [`PathTracer::enable_guides`] ran.
    guides: Option<(DeviceBuffer<Vec4>, DeviceBuffer<Vec4>)>,
}

/// The denoiser's guides of a render: per pixel, the mean over its paths of the
/// first hit's albedo and shading normal (facing the camera), row 0 at the top.
#[derive(Clone, Debug)]
pub struct GuideImages {
    /// First-hit albedo (an emitter's colour normalised to 1; 0 for a miss).
    pub albedo: Vec<Vec3>,
    /// First-hit shading normal (averaged over the pixel; 0 for a miss).
    pub normal: Vec<Vec3>,
}

/// Mean of an accumulated guide (sum in xyz, paths in w).
fn guide_mean(sums: &[Vec4]) -> Vec<Vec3> {
    sums.iter().map(|s| if s.w > 0.0 { s.truncate() / s.w } else { Vec3::ZERO }).collect()
}

impl std::fmt::Debug for PathTracer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PathTracer").field("size", &self.params.size).field("samples", &self.samples_done).finish()
    }
}

impl PathTracer {
    /// Links the path tracer for `scene` lit by `env`, seen by `camera` at `width × height`.
    pub fn new(
        ctx: &Context,
        scene: &GpuScene,
        env: &EnvironmentMap,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> anyhow::Result<PathTracer> {
        let module = Module::from_device_crate(ctx, "gltf-pathtracer-device")?;
        let groups = groups(&module, gltf_pathtracer_device::RG_PATH)?;
        let refs: Vec<&ProgramGroup> = groups.iter().collect();
        let pipeline = Pipeline::<TraceParams>::new(ctx, &refs, LinkOptions { max_trace_depth: 1 })?;
        let sbt = scene_sbt(&pipeline, &groups, scene)?;
        let texels: Vec<f32> = env.radiance.iter().flat_map(|c| [c.x, c.y, c.z, 1.0]).collect();
        let env_texture = Texture::new(
            ctx,
            TextureFormat::Rgba32Float,
            env.width,
            env.height,
            bytemuck::cast_slice(&texels),
            Mipmaps::One,
            SamplerOptions { filter: Filter::Nearest, ..SamplerOptions::default() },
        )?;
        let env_cdf = ctx.buffer_from(&env.cdf)?;
        let accum = ctx.buffer::<Vec4>(width as usize * height as usize)?;
        let (u, v, w) = camera.uvw(width as f32 / height as f32);
        let params = TraceParams {
            accum: accum.handle(),
            env_cdf: env_cdf.handle(),
            size: UVec2::new(width, height),
            env: env_texture.handle(),
            env_width: env.width,
            env_height: env.height,
            subframe: 0,
            samples: 1,
            max_depth: 1024,
            cam_eye: camera.eye,
            cam_u: u,
            cam_v: v,
            cam_w: w,
            scene: scene.ias.handle(),
            lights: scene.lights.handle(),
            light_textures: scene.light_textures.handle(),
            light_cdf: scene.light_cdf.handle(),
            light_count: scene.light_table.len() as u32,
            guides: 0,
            // Never written while `guides` is 0.
            albedo: accum.handle(),
            normal: accum.handle(),
            _pad: 0,
        };
        Ok(PathTracer {
            pipeline,
            sbt,
            accum,
            _env: env_texture,
            _env_cdf: env_cdf,
            params,
            samples_done: 0,
            light_count: scene.light_table.len() as u32,
            guides: None,
        })
    }

    /// From now on every launch also writes the denoiser's guides (first-hit
    /// albedo and normals, [`PathTracer::guides`]) in the same launch; starts over.
    pub fn enable_guides(&mut self, ctx: &Context) -> raykit::Result<()> {
        let pixels = self.params.size.x as usize * self.params.size.y as usize;
        let (albedo, normal) = (ctx.buffer::<Vec4>(pixels)?, ctx.buffer::<Vec4>(pixels)?);
        (self.params.albedo, self.params.normal, self.params.guides) = (albedo.handle(), normal.handle(), 1);
        self.guides = Some((albedo, normal));
        self.reset();
        Ok(())
    }

    /// Reads the guides back (`None` unless [`PathTracer::enable_guides`] ran).
    pub fn guides(&self) -> raykit::Result<Option<GuideImages>> {
        let Some((albedo, normal)) = &self.guides else { return Ok(None) };
        Ok(Some(GuideImages { albedo: guide_mean(&albedo.read()?), normal: guide_mean(&normal.read()?) }))
    }

    /// Sets the safety cap on bounces (Russian roulette ends paths; 1024 by default).
    pub fn set_max_depth(&mut self, max_depth: u32) {
        self.params.max_depth = max_depth.max(1);
    }

    /// Whether paths sample the emissive triangles (next-event estimation, weighted
    /// by multiple importance sampling against the BSDF; on by default). Off, emissive
    /// surfaces are found by BSDF sampling alone: the same image, noisier.
    pub fn set_light_sampling(&mut self, on: bool) {
        self.params.light_count = if on { self.light_count } else { 0 };
    }

    /// One launch adding `samples` paths per pixel.
    pub fn launch(&mut self, samples: u32) -> anyhow::Result<()> {
        let params = TraceParams { subframe: self.params.subframe, samples, ..self.params };
        let size = self.params.size;
        self.pipeline.launch(&self.sbt, &params, [size.x, size.y, 1])?;
        self.params.subframe += 1;
        self.samples_done += samples;
        Ok(())
    }

    /// Paths per pixel so far.
    pub fn samples_done(&self) -> u32 {
        self.samples_done
    }

    /// Starts over: the next launch overwrites the accumulation.
    pub fn reset(&mut self) {
        self.params.subframe = 0;
        self.samples_done = 0;
    }

    /// Aims `camera` at the image's aspect; starts over.
    pub fn set_camera(&mut self, camera: &Camera) {
        let size = self.params.size;
        let (u, v, w) = camera.uvw(size.x as f32 / size.y as f32);
        (self.params.cam_eye, self.params.cam_u, self.params.cam_v, self.params.cam_w) = (camera.eye, u, v, w);
        self.reset();
    }

    /// A new accumulation buffer for `width × height` pixels seen by `camera`; starts over.
    pub fn resize(&mut self, ctx: &Context, width: u32, height: u32, camera: &Camera) -> anyhow::Result<()> {
        self.accum = ctx.buffer::<Vec4>(width as usize * height as usize)?;
        self.params.accum = self.accum.handle();
        self.params.size = UVec2::new(width, height);
        if self.guides.is_some() {
            self.enable_guides(ctx)?;
        } else {
            (self.params.albedo, self.params.normal) = (self.accum.handle(), self.accum.handle());
        }
        self.set_camera(camera);
        Ok(())
    }

    /// Submits a launch adding `samples` paths per pixel without waiting for it.
    pub fn launch_async(&mut self, samples: u32) -> anyhow::Result<raykit::Launch> {
        let params = TraceParams { subframe: self.params.subframe, samples, ..self.params };
        let size = self.params.size;
        let launch = self.pipeline.launch_async(&self.sbt, &params, [size.x, size.y, 1])?;
        self.params.subframe += 1;
        self.samples_done += samples;
        Ok(launch)
    }

    /// The accumulation buffer: per pixel, the radiance sum (xyz) and the rays traced (w).
    pub fn accumulation(&self) -> &DeviceBuffer<Vec4> {
        &self.accum
    }

    /// Mean radiance per pixel so far, and the rays traced.
    pub fn image(&self) -> anyhow::Result<(Vec<Vec3>, u64)> {
        let accum = self.accum.read()?;
        let n = self.samples_done.max(1) as f32;
        let rays = accum.iter().map(|a| a.w as f64).sum::<f64>() as u64;
        Ok((accum.iter().map(|a| a.truncate() / n).collect(), rays))
    }
}

/// A procedural sky as an environment map: a blue gradient above a grey ground
/// and a small bright sun.
pub fn default_sky(width: u32, height: u32) -> anyhow::Result<EnvironmentMap> {
    let mut radiance = Vec::with_capacity((width * height) as usize);
    let sun = Vec3::new(0.4, 0.8, 0.45).normalize();
    for y in 0..height {
        for x in 0..width {
            let uv = Vec2::new((x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32);
            let d = raykit::device::environment::equirect_direction(uv);
            let sky = if d.y > 0.0 {
                Vec3::new(0.5, 0.7, 1.0).lerp(Vec3::new(0.15, 0.3, 0.8), d.y)
            } else {
                Vec3::splat(0.25)
            };
            radiance.push(if d.dot(sun) > 0.995 { Vec3::new(400.0, 380.0, 340.0) } else { sky });
        }
    }
    Ok(EnvironmentMap::new(width, height, radiance)?)
}

/// A camera looking at the scene's bounds from +z (and a little above).
pub fn framing_camera(scene: &GltfScene) -> Camera {
    let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for inst in &scene.instances {
        for p in &scene.meshes[inst.mesh].primitives {
            for &v in &p.positions {
                let w = inst.transform.transform_point3(v);
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
    }
    if lo.x > hi.x {
        (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
    }
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    Camera {
        eye: centre + Vec3::new(0.0, 0.3, 1.0).normalize() * radius * 2.8,
        look_at: centre,
        up: Vec3::Y,
        fov_y_degrees: 40.0,
    }
}

/// The output buffers of one primary-hit launch (`out`, `color`, `normal`, one
/// `Vec4` per pixel) and the params that name them.
struct PrimaryTarget {
    out: raykit::DeviceBuffer<Vec4>,
    color: raykit::DeviceBuffer<Vec4>,
    normal: raykit::DeviceBuffer<Vec4>,
    params: Params,
}

impl PrimaryTarget {
    /// Buffers for a `width × height` image of `scene` seen by `camera`.
    fn new(ctx: &Context, scene: &GpuScene, camera: &Camera, width: u32, height: u32) -> anyhow::Result<Self> {
        let pixels = width as usize * height as usize;
        let (out, color, normal) =
            (ctx.buffer::<Vec4>(pixels)?, ctx.buffer::<Vec4>(pixels)?, ctx.buffer::<Vec4>(pixels)?);
        let (u, v, w) = camera.uvw(width as f32 / height as f32);
        let params = Params {
            out: out.handle(),
            size: UVec2::new(width, height),
            color: color.handle(),
            cam_eye: camera.eye,
            cam_u: u,
            cam_v: v,
            cam_w: w,
            scene: scene.ias.handle(),
            normal: normal.handle(),
            _pad: 0,
        };
        Ok(PrimaryTarget { out, color, normal, params })
    }

    /// What the launch wrote: `out`, `color` and `normal`.
    fn read(&self) -> anyhow::Result<(Vec<Vec4>, Vec<Vec4>, Vec<Vec4>)> {
        Ok((self.out.read()?, self.color.read()?, self.normal.read()?))
    }
}

/// The glTF renderer's pipeline and SBT for one scene.
pub struct Renderer {
    pipeline: Pipeline<Params>,
    sbt: Sbt,
}

impl Renderer {
    /// Links the programs and lays out one hit record per (instance, primitive) of `scene`.
    pub fn new(ctx: &Context, scene: &GpuScene) -> anyhow::Result<Renderer> {
        let module = Module::from_device_crate(ctx, "gltf-pathtracer-device")?;
        let groups = groups(&module, gltf_pathtracer_device::RG)?;
        let refs: Vec<&ProgramGroup> = groups.iter().collect();
        let pipeline = Pipeline::<Params>::new(ctx, &refs, LinkOptions { max_trace_depth: 1 })?;
        let sbt = scene_sbt(&pipeline, &groups, scene)?;
        Ok(Renderer { pipeline, sbt })
    }

    /// Per pixel of a `width × height` image seen by `camera`: the primary hit's
    /// material index (−1 for a miss), texture coordinates and distance; and its
    /// base colour (factor × texture, linear RGB; 0 for a miss).
    pub fn primary_hits(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> anyhow::Result<(Vec<Vec4>, Vec<Vec4>)> {
        let (out, color, _) = self.primary_hits_with_normals(ctx, scene, camera, width, height)?;
        Ok((out, color))
    }

    /// [`Renderer::primary_hits`], and per pixel the primary hit's shading normal (world
    /// space, after the normal map; 0 for a miss).
    pub fn primary_hits_with_normals(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> anyhow::Result<(Vec<Vec4>, Vec<Vec4>, Vec<Vec4>)> {
        let target = PrimaryTarget::new(ctx, scene, camera, width, height)?;
        self.pipeline.launch(&self.sbt, &target.params, [width, height, 1])?;
        target.read()
    }
}

/// How materials become programs (see `gltf_pathtracer_device::materials`).
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum MaterialMode {
    /// One closest-hit calls the material's direct callable, by the index in its record.
    Callables,
    /// One closest-hit per material, the material inlined, in its own hit group.
    Inlined,
}

/// Primary hits shaded by the eight procedural materials, a primitive of glTF
/// material `m` with procedural material `m % 8`, in either [`MaterialMode`]
/// (opaque: no any-hit programs).
pub struct MaterialRenderer {
    pipeline: Pipeline<Params>,
    sbt: Sbt,
    /// How long linking the pipeline took.
    pub link_time: std::time::Duration,
}

impl MaterialRenderer {
    /// Links the programs of `mode` for `scene`.
    pub fn new(ctx: &Context, scene: &GpuScene, mode: MaterialMode) -> anyhow::Result<MaterialRenderer> {
        use gltf_pathtracer_device::materials::MATERIAL_COUNT;
        use gltf_pathtracer_device::{CH_CALLABLES, MATERIAL_CALLABLES, MATERIAL_CLOSEST_HITS, MS, RG};
        let module = Module::from_device_crate(ctx, "gltf-pathtracer-device")?;
        let raygen = ProgramGroup::raygen(&module, RG)?;
        let miss = ProgramGroup::miss(&module, MS)?;
        let (hits, callables) = match mode {
            MaterialMode::Callables => (
                vec![ProgramGroup::hit_group(&module).closest_hit(CH_CALLABLES).build()?],
                MATERIAL_CALLABLES
                    .iter()
                    .map(|&c| ProgramGroup::callable(&module, c))
                    .collect::<Result<Vec<_>, _>>()?,
            ),
            MaterialMode::Inlined => (
                MATERIAL_CLOSEST_HITS
                    .iter()
                    .map(|&c| ProgramGroup::hit_group(&module).closest_hit(c).build())
                    .collect::<Result<Vec<_>, _>>()?,
                Vec::new(),
            ),
        };
        let mut all = vec![&raygen, &miss];
        all.extend(hits.iter());
        all.extend(callables.iter());
        let started = std::time::Instant::now();
        let pipeline = Pipeline::<Params>::new(ctx, &all, LinkOptions { max_trace_depth: 1 })?;
        let link_time = started.elapsed();
        let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss_for::<Primary, _>(&miss, ());
        for (i, record) in scene.records.iter().enumerate() {
            let slot = record.material % MATERIAL_COUNT;
            let record = GeometryRecord { material: slot, callable: slot, ..*record };
            let group = match mode {
                MaterialMode::Callables => &hits[0],
                MaterialMode::Inlined => &hits[slot as usize],
            };
            sbt = sbt.hit_at(i, group, record);
        }
        for c in &callables {
            sbt = sbt.callable(c, ());
        }
        let sbt = sbt.build()?;
        Ok(MaterialRenderer { pipeline, sbt, link_time })
    }

    /// One launch of `width × height` primary rays, timed by GPU timestamps when
    /// `timer` is given, by the wall clock around the launch otherwise.
    pub fn time_launch(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &Camera,
        (width, height): (u32, u32),
        timer: Option<&raykit::LaunchTimer>,
    ) -> anyhow::Result<std::time::Duration> {
        // Kept alive for the launch: the params name its buffers.
        let target = PrimaryTarget::new(ctx, scene, camera, width, height)?;
        Ok(match timer {
            Some(timer) => self.pipeline.launch_timed(&self.sbt, &target.params, [width, height, 1], timer)?,
            None => {
                let started = std::time::Instant::now();
                self.pipeline.launch(&self.sbt, &target.params, [width, height, 1])?;
                started.elapsed()
            }
        })
    }

    /// Per pixel: the material slot (−1 for a miss), texture coordinates, distance; and the colour.
    pub fn render(
        &self,
        ctx: &Context,
        scene: &GpuScene,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> anyhow::Result<(Vec<Vec4>, Vec<Vec4>)> {
        let target = PrimaryTarget::new(ctx, scene, camera, width, height)?;
        self.pipeline.launch(&self.sbt, &target.params, [width, height, 1])?;
        let (out, color, _) = target.read()?;
        Ok((out, color))
    }
}
