//! The path tracer in `raykit-viewer`'s window (`path_tracer --view`): a
//! [`Renderer`] behind the viewer's [`Render`] trait, with hot reload of the
//! device crate (`--watch`) swapping the pipeline in the running window.

use std::path::Path;
use std::time::Duration;

use raykit::glam::Vec4;
use raykit::{Context, DeviceBuffer, Launch};
use raykit_builder::{DeviceBuild, DeviceWatcher, Report};
use raykit_viewer::{DenoiseGuides, Render, RenderError};

use crate::{Camera, Programs, Renderer, Scene};

/// The path tracer as the viewer drives it.
pub struct ViewRenderer {
    ctx: Context,
    renderer: Renderer,
    /// The programs linked now (hot reload swaps them); the guides' raygen is theirs.
    programs: Programs,
    /// The scene the renderer's params point into.
    _scene: Scene,
    watcher: Option<DeviceWatcher>,
}

impl ViewRenderer {
    /// The Rust programs on `ctx`, the Cornell box, a `width × height` image.
    pub fn new(ctx: &Context, width: u32, height: u32, max_depth: u32) -> anyhow::Result<ViewRenderer> {
        let programs = Programs::rust(ctx)?;
        let scene = Scene::new(ctx)?;
        let mut renderer = Renderer::new(ctx, &programs, &scene, width.max(1), height.max(1))?;
        renderer.set_max_depth(max_depth);
        Ok(ViewRenderer { ctx: ctx.clone(), renderer, programs, _scene: scene, watcher: None })
    }

    /// Hot reload: watches the device crate at `device_dir` (its SPIR-V goes to
    /// `out_dir`, its build to `target_dir`); each change rebuilds it and swaps the
    /// pipeline before the next frame.
    pub fn watch(&mut self, device_dir: &Path, out_dir: &Path, target_dir: &Path) -> anyhow::Result<()> {
        let build = DeviceBuild::new(device_dir)
            .name("path-tracer-device")
            .out_dir(out_dir)
            .target_dir(target_dir)
            .check_params(false)
            .report(Report::Quiet);
        self.watcher = Some(DeviceWatcher::new(build, Duration::from_millis(100))?);
        println!("watching {} (each save swaps the pipeline in the window)", device_dir.display());
        Ok(())
    }
}

impl Render for ViewRenderer {
    fn context(&self) -> &Context {
        &self.ctx
    }

    fn resize(&mut self, width: u32, height: u32, camera: &Camera) -> Result<(), RenderError> {
        Ok(self.renderer.resize(&self.ctx, width, height, camera)?)
    }

    fn set_camera(&mut self, camera: &Camera) {
        self.renderer.set_camera(camera);
    }

    fn reset(&mut self) {
        self.renderer.reset();
    }

    fn launch(&mut self, samples: u32) -> Result<Launch, RenderError> {
        Ok(self.renderer.launch_async(samples)?)
    }

    fn launches_rows(&self) -> bool {
        true
    }

    fn launch_rows(&mut self, samples: u32, rows: std::ops::Range<u32>) -> Result<Launch, RenderError> {
        Ok(self.renderer.launch_rows_async(samples, rows)?)
    }

    fn accumulation(&self) -> &DeviceBuffer<Vec4> {
        self.renderer.accumulation_buffer()
    }

    fn samples_done(&self) -> u32 {
        self.renderer.samples_done()
    }

    fn enable_guides(&mut self) -> Result<bool, RenderError> {
        self.renderer.enable_guides(&self.ctx, &self.programs)?;
        Ok(true)
    }

    fn guides(&self) -> Result<Option<DenoiseGuides>, RenderError> {
        let rgb = |v: Vec<raykit::glam::Vec3>| v.into_iter().map(|c| c.to_array()).collect();
        Ok(self.renderer.guides()?.map(|g| DenoiseGuides { albedo: rgb(g.albedo), normal: rgb(g.normal) }))
    }

    fn poll_reload(&mut self) -> Option<Result<String, RenderError>> {
        let rebuild = self.watcher.as_ref()?.try_next()?;
        let reloaded = rebuild.result.map_err(RenderError::from).and_then(|built| {
            let module = raykit::Module::from_file(&self.ctx, &built.spv)?;
            let programs = Programs::rust_from(&module)?;
            self.renderer.swap_programs(&self.ctx, &programs)?;
            self.programs = programs;
            Ok(())
        });
        Some(reloaded.map(|()| format!("reloaded in {:.2} s", rebuild.changed_at.elapsed().as_secs_f64())))
    }
}
