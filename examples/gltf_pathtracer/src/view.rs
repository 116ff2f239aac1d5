//! The glTF path tracer in `raykit-viewer`'s window (`gltf_pathtracer --view`).

use raykit::glam::Vec4;
use raykit::{Context, DeviceBuffer, Launch};
use raykit_scene::gltf::GltfScene;
use raykit_scene::{Camera, EnvironmentMap};
use raykit_viewer::{DenoiseGuides, Render, RenderError};

use crate::{GpuScene, PathTracer};

/// A glTF scene's path tracer as the viewer drives it.
pub struct ViewRenderer {
    ctx: Context,
    // Dropped before the scene its params point into.
    tracer: PathTracer,
    _scene: GpuScene,
}

impl ViewRenderer {
    /// The scene on `ctx`, lit by `env`, first seen by `camera`.
    pub fn new(ctx: &Context, scene: &GltfScene, env: &EnvironmentMap, camera: &Camera) -> anyhow::Result<Self> {
        let gpu = GpuScene::new(ctx, scene)?;
        let tracer = PathTracer::new(ctx, &gpu, env, camera, 1, 1)?;
        Ok(ViewRenderer { ctx: ctx.clone(), tracer, _scene: gpu })
    }

    /// The path tracer (its bounce cap and light sampling).
    pub fn tracer_mut(&mut self) -> &mut PathTracer {
        &mut self.tracer
    }
}

impl Render for ViewRenderer {
    fn context(&self) -> &Context {
        &self.ctx
    }

    fn resize(&mut self, width: u32, height: u32, camera: &Camera) -> Result<(), RenderError> {
        Ok(self.tracer.resize(&self.ctx, width, height, camera)?)
    }

    fn set_camera(&mut self, camera: &Camera) {
        self.tracer.set_camera(camera);
    }

    fn reset(&mut self) {
        self.tracer.reset();
    }

    fn launch(&mut self, samples: u32) -> Result<Launch, RenderError> {
        Ok(self.tracer.launch_async(samples)?)
    }

    fn accumulation(&self) -> &DeviceBuffer<Vec4> {
        self.tracer.accumulation()
    }

    fn samples_done(&self) -> u32 {
        self.tracer.samples_done()
    }

    fn enable_guides(&mut self) -> Result<bool, RenderError> {
        self.tracer.enable_guides(&self.ctx)?;
        Ok(true)
    }

    fn guides(&self) -> Result<Option<DenoiseGuides>, RenderError> {
        let rgb = |v: Vec<raykit::glam::Vec3>| v.into_iter().map(|c| c.to_array()).collect();
        Ok(self.tracer.guides()?.map(|g| DenoiseGuides { albedo: rgb(g.albedo), normal: rgb(g.normal) }))
    }
}
