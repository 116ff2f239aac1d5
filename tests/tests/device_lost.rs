//! A lost device (`VK_ERROR_DEVICE_LOST`), injected at submission through the
//! `fault-injection` test hook: the call that meets it and every later call on
//! every context of the device return `DeviceError::DeviceLost`, everything drops
//! cleanly, and a new context gets a new device. Alone in its test binary: the loss
//! reaches every context on the device of this process.

use raykit::{Context, Error, Gas, Ias, LinkOptions, Module, Pipeline, Sbt};
use raykit_tests::{check_triangle_picture, context_or_skip, test_options};
use triangle::{Programs, BG_COLOR, VERTICES};
use triangle_device::{MissData, Params};

const WIDTH: u32 = 32;
const HEIGHT: u32 = 24;

/// optixTriangle, ready to launch.
struct Scene {
    programs: Programs,
    pipeline: Pipeline<Params>,
    sbt: Sbt,
    _gas: Gas,
    ias: Ias,
    image: raykit::DeviceBuffer<u32>,
}

impl Scene {
    fn new(ctx: &Context) -> anyhow::Result<Scene> {
        let programs = Programs::rust(ctx)?;
        let Programs { raygen, miss, hit } = &programs;
        let pipeline = Pipeline::<Params>::new(ctx, &[raygen, miss, hit], LinkOptions { max_trace_depth: 1 })?;
        let sbt = Sbt::builder(&pipeline)
            .raygen(raygen, ())
            .miss(miss, MissData { bg_color: BG_COLOR })
            .hit(hit, ())
            .build()?;
        let gas = Gas::triangles(ctx, &VERTICES, None)?;
        let ias = Ias::single(ctx, &gas)?;
        let image = ctx.buffer::<u32>((WIDTH * HEIGHT) as usize)?;
        Ok(Scene { programs, pipeline, sbt, _gas: gas, ias, image })
    }

    fn launch(&self) -> raykit::Result<()> {
        let params = triangle::params(WIDTH, HEIGHT, self.image.handle(), self.ias.handle());
        self.pipeline.launch(&self.sbt, &params, [WIDTH, HEIGHT, 1])
    }
}

fn lost<T>(what: &str, result: raykit::Result<T>) -> anyhow::Result<()> {
    match result {
        Err(Error::Device(raykit::DeviceError::DeviceLost { .. })) => Ok(()),
        Err(e) => anyhow::bail!("{what}: expected Error::Device(raykit::DeviceError::DeviceLost), got {e:?}"),
        Ok(_) => anyhow::bail!("{what}: succeeded on a lost device"),
    }
}

#[test]
fn an_injected_device_loss_stops_every_context_on_the_device_and_everything_drops_cleanly() -> anyhow::Result<()> {
    let name = "an_injected_device_loss_stops_every_context_on_the_device_and_everything_drops_cleanly";
    let Some(a) = context_or_skip(name, test_options())? else { return Ok(()) };
    let b = Context::new(test_options())?;
    anyhow::ensure!(a.shares_device_with(&b), "two contexts on one GPU did not share its device");
    let logs = [a.messages(), b.messages()];
    let scenes = [Scene::new(&a)?, Scene::new(&b)?];
    for scene in &scenes {
        scene.launch()?;
        check_triangle_picture(&scene.image.read()?, WIDTH, HEIGHT)?;
    }
    // A launch of one context left running, waited for after the loss.
    let params = triangle::params(WIDTH, HEIGHT, scenes[0].image.handle(), scenes[0].ias.handle());
    let running = scenes[0].pipeline.launch_async(&scenes[0].sbt, &params, [WIDTH, HEIGHT, 1])?;

    a.inject_device_loss_at_next_submit();
    // The next submission on the device, by the other context, meets the loss.
    lost("the launch that met the loss", scenes[1].launch())?;
    anyhow::ensure!(a.is_device_lost() && b.is_device_lost(), "the loss did not reach every context");
    lost("waiting for a launch submitted before the loss", running.wait())?;
    for (ctx, scene) in [(&a, &scenes[0]), (&b, &scenes[1])] {
        lost("a launch", scene.launch())?;
        lost("a launch (again)", scene.launch())?;
        lost("a buffer", ctx.buffer::<u32>(4))?;
        lost("a module", Module::from_device_crate(ctx, "triangle-device"))?;
        let Programs { raygen, miss, hit } = &scene.programs;
        lost("a pipeline", Pipeline::<Params>::new(ctx, &[raygen, miss, hit], LinkOptions { max_trace_depth: 1 }))?;
        lost("a GAS build", Gas::triangles(ctx, &VERTICES, None))?;
    }
    drop(scenes);
    drop((a, b));
    for (i, log) in logs.iter().enumerate() {
        anyhow::ensure!(log.context_destroyed(), "context {i} was not destroyed");
        let messages = log.take();
        anyhow::ensure!(messages.is_empty(), "context {i}: {messages:#?}");
    }

    // The lost device went with its last context: a new context gets a new one.
    let c = Context::new(test_options())?;
    anyhow::ensure!(!c.is_device_lost(), "a new context got the lost device");
    let log = c.messages();
    let pixels = triangle::render(&c, WIDTH, HEIGHT)?;
    check_triangle_picture(&pixels, WIDTH, HEIGHT)?;
    drop(c);
    anyhow::ensure!(log.context_destroyed() && log.take().is_empty(), "the new context did not end cleanly");
    Ok(())
}
