//! Hot reload: a watcher on a temporary copy of a device crate (the new-project
//! template's) rebuilds it when a colour constant changes; the renderer swaps in
//! the new module, program groups, pipeline and SBT, keeping its acceleration
//! structures and image, and its next frame has the new colour. A syntax error
//! reports rustc's message and leaves the old pipeline running.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use raykit::bytemuck::{Pod, Zeroable};
use raykit::glam::{UVec2, Vec3, Vec4};
use raykit::{
    Buffer, Camera, Context, DeviceBuffer, Gas, Ias, LaunchParams, LinkOptions, Module, Pipeline, ProgramGroup, Sbt,
    Traversable,
};
use raykit_builder::{DeviceBuild, DeviceWatcher, Report};
use raykit_tests::with_context;

const WIDTH: u32 = 16;
const HEIGHT: u32 = 12;
/// The template's `HIT_COLOR` line.
const HIT_LINE: &str = "pub const HIT_COLOR: u32 = 0xff30_c0ff;";
/// Generous: a warm rebuild takes about a second.
const REBUILD_BOUND: Duration = Duration::from_secs(180);

/// The template device crate's params, as the host lays them out.
#[repr(C)]
#[derive(Copy, Clone, Pod, Zeroable, LaunchParams)]
#[bytemuck(crate = "raykit::bytemuck")]
struct Params {
    image: Buffer<u32>,
    accum: Buffer<Vec4>,
    size: UVec2,
    sample_start: u32,
    samples: u32,
    eye: Vec3,
    cam_u: Vec3,
    cam_v: Vec3,
    cam_w: Vec3,
    scene: Traversable,
}

/// The template's camera: 2 units in front of the triangle.
const CAMERA: Camera =
    Camera { eye: Vec3::new(0.0, 0.0, 2.0), look_at: Vec3::ZERO, up: Vec3::Y, fov_y_degrees: 53.130_104 };

/// What a reload replaces.
struct Programs {
    pipeline: Pipeline<Params>,
    sbt: Sbt,
}

fn load(ctx: &Context, spv: &Path) -> raykit::Result<Programs> {
    let module = Module::from_file(ctx, spv)?;
    let raygen = ProgramGroup::raygen(&module, "__raygen__rg")?;
    let miss = ProgramGroup::miss(&module, "__miss__ms")?;
    let hit = ProgramGroup::hit_group(&module).closest_hit("__closesthit__ch").build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(&hit, ()).build()?;
    Ok(Programs { pipeline, sbt })
}

/// The colour at the image's centre, which sees the triangle (one sample per
/// pixel, through its centre).
fn centre_colour(
    programs: &Programs,
    image: &DeviceBuffer<u32>,
    accum: &DeviceBuffer<Vec4>,
    scene: &Ias,
) -> raykit::Result<u32> {
    let (cam_u, cam_v, cam_w) = CAMERA.uvw(WIDTH as f32 / HEIGHT as f32);
    let params = Params {
        image: image.handle(),
        accum: accum.handle(),
        size: UVec2::new(WIDTH, HEIGHT),
        sample_start: 0,
        samples: 1,
        eye: CAMERA.eye,
        cam_u,
        cam_v,
        cam_w,
        scene: scene.handle(),
    };
    programs.pipeline.launch(&programs.sbt, &params, [WIDTH, HEIGHT, 1])?;
    let pixels = image.read()?;
    Ok(pixels[((HEIGHT / 2) * WIDTH + WIDTH / 2) as usize])
}

fn raykit_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("inside the workspace").to_path_buf()
}

#[test]
fn an_edited_colour_reaches_the_next_frame_and_a_syntax_error_keeps_the_old_pipeline() -> anyhow::Result<()> {
    with_context("hot_reload", |ctx| {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH)?.as_nanos();
        let project = std::env::temp_dir().join(format!("raykit-hot-reload-{}-{nanos}", std::process::id()));
        raykit_builder::write_new_project(&project, &raykit_root())?;
        let lib = project.join("device").join("src").join("lib.rs");
        let source = std::fs::read_to_string(&lib)?;
        assert!(source.contains(HIT_LINE), "the template's HIT_COLOR line changed");

        let build = DeviceBuild::new(project.join("device"))
            .out_dir(project.join("spirv"))
            .target_dir(raykit_root().join("target").join("template-project").join("raykit"))
            .check_params(false)
            .report(Report::Quiet);
        let spv = build.clone().build()?.spv;
        let watcher = DeviceWatcher::new(build, Duration::from_millis(100))?;

        // Kept across reloads.
        let vertices = [Vec3::new(-0.5, -0.5, 0.0), Vec3::new(0.5, -0.5, 0.0), Vec3::new(0.0, 0.5, 0.0)];
        let gas = Gas::triangles(ctx, &vertices, None)?;
        let scene = Ias::single(ctx, &gas)?;
        let image = ctx.buffer::<u32>((WIDTH * HEIGHT) as usize)?;
        let accum = ctx.buffer::<Vec4>((WIDTH * HEIGHT) as usize)?;
        let mut programs = load(ctx, &spv)?;
        assert_eq!(centre_colour(&programs, &image, &accum, &scene)?, 0xff30_c0ff);

        let mut latencies = Vec::new();
        for i in 0..5u32 {
            let colour = 0xff00_0000 | (0x10_2030 * (i + 1));
            let edited = source.replace(HIT_LINE, &format!("pub const HIT_COLOR: u32 = {colour:#010x};"));
            let edited_at = Instant::now();
            std::fs::write(&lib, edited)?;
            let rebuild = watcher.next_timeout(REBUILD_BOUND).expect("the watcher rebuilds after an edit");
            let built = rebuild.result?;
            programs = load(ctx, &built.spv)?;
            assert_eq!(
                centre_colour(&programs, &image, &accum, &scene)?,
                colour,
                "edit {i}: the next frame has the new colour"
            );
            latencies.push(edited_at.elapsed().as_secs_f64());
        }

        // A syntax error: rustc's message comes back, the old pipeline keeps running.
        let last = 0xff00_0000 | (0x10_2030 * 5);
        std::fs::write(&lib, source.replace(HIT_LINE, "pub const HIT_COLOR: u32 = 0xff00_00ff"))?;
        let rebuild = watcher.next_timeout(REBUILD_BOUND).expect("the watcher reports a failed build");
        match rebuild.result {
            Err(raykit_builder::Error::Compile { message, .. }) => {
                assert!(
                    message.contains("error: expected one of") && message.contains("device/src/lib.rs:12"),
                    "rustc's message is reported:\n{message}"
                )
            }
            other => panic!("a syntax error must be a compile error, got {other:?}"),
        }
        assert_eq!(centre_colour(&programs, &image, &accum, &scene)?, last, "the old pipeline keeps rendering");

        latencies.sort_by(f64::total_cmp);
        eprintln!("edit → picture latencies (s): {latencies:.2?}; median {:.2}", latencies[2]);
        let _ = std::fs::remove_dir_all(&project);
        Ok(())
    })
}
