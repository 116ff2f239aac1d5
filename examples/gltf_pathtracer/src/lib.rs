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

use gltf_pathtracer_device::{GeometryRecord, Params, Primary};
use raykit::glam::{Affine3A, UVec2, Vec2, Vec3, Vec4};
use raykit::{
    AddressMode, Context, DeviceBuffer, Filter, Gas, GeometryFlags, Ias, Instance, LinkOptions, Mipmaps, Module,
    Pipeline, ProgramGroup, SamplerOptions, Sbt, Texture, TextureFormat, Triangles,
};
use raykit_scene::gltf::{AlphaMode, GltfScene};
use raykit_scene::Camera;

pub use gltf_pathtracer_device as device;

/// A primitive's device buffers.
struct PrimitiveBuffers {
    indices: DeviceBuffer<u32>,
    uvs: DeviceBuffer<Vec2>,
    normals: DeviceBuffer<Vec3>,
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

/// A glTF scene on the device.
pub struct GpuScene {
    /// The TLAS.
    pub ias: Ias,
    /// The hit record of each (instance, primitive), in SBT order.
    pub records: Vec<GeometryRecord>,
    /// Whether each record's material is alpha-masked.
    pub masked: Vec<bool>,
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
                    coverage: ctx.buffer_from(&coverage)?,
                };
                let base_color = match material.base_color_texture {
                    Some(i) => texture(i, true)?,
                    None => raykit::Texture2D::NULL,
                };
                records.push((
                    GeometryRecord {
                        indices: b.indices.handle(),
                        uvs: b.uvs.handle(),
                        normals: b.normals.handle(),
                        material: p.material as u32,
                        base_color,
                        base_color_factor: material.base_color.truncate(),
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
        for (i, inst) in scene.instances.iter().enumerate() {
            let offset = records.len() as u32;
            let transform = Affine3A::from_mat4(inst.transform);
            instances
                .push(Instance::new(&gases[inst.mesh]).transform(transform).custom_index(i as u32).sbt_offset(offset));
            for &(r, m) in &mesh_records[inst.mesh] {
                records.push(r);
                masked.push(m);
            }
        }
        let ias = Ias::new(ctx, &instances)?;
        Ok(GpuScene { ias, records, masked, _buffers: buffers, _textures: textures })
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
        use gltf_pathtracer_device::{AH_MASK, CH, MS, RG};
        let module = Module::from_device_crate(ctx, "gltf-pathtracer-device")?;
        let raygen = ProgramGroup::raygen(&module, RG)?;
        let miss = ProgramGroup::miss(&module, MS)?;
        let opaque = ProgramGroup::hit_group(&module).closest_hit(CH).build()?;
        let masked = ProgramGroup::hit_group(&module).closest_hit(CH).any_hit(AH_MASK).build()?;
        let pipeline =
            Pipeline::<Params>::new(ctx, &[&raygen, &miss, &opaque, &masked], LinkOptions { max_trace_depth: 1 })?;
        let mut sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss_for::<Primary, _>(&miss, ());
        for (i, (record, is_masked)) in scene.records.iter().zip(&scene.masked).enumerate() {
            sbt = sbt.hit_at(i, if *is_masked { &masked } else { &opaque }, *record);
        }
        let sbt = sbt.build()?;
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
        let out = ctx.buffer::<Vec4>(width as usize * height as usize)?;
        let color = ctx.buffer::<Vec4>(width as usize * height as usize)?;
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
        };
        self.pipeline.launch(&self.sbt, &params, [width, height, 1])?;
        Ok((out.read()?, color.read()?))
    }
}
