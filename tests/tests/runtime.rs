//! OptiX's host-side runtime model on raykit: parameter specialization, async
//! launches, the compile cache, thread safety, logs and pipeline libraries.

use program_model_device::{pack, Params, Radiance, SHADE_MODE_SPEC_ID, SPEC_COLORS};
use raykit::glam::{Affine3A, UVec2, Vec3, Vec4};
use raykit::{
    CacheLoad, Context, ContextOptions, Gas, Ias, Instance, LibraryOptions, LinkOptions, Module, Pipeline,
    PipelineCacheLocation, PipelineLibrary, ProgramGroup, Sbt, Specialization,
};
use raykit_tests::{temp_dir, with_context_options, with_each_backend};

/// The specialization scene: a quad in the middle of the image, the radiance
/// raygen and miss, and a closest-hit whose colour is specialization constant
/// `SHADE_MODE_SPEC_ID` (`SPEC_COLORS[mode]`).
struct SpecScene {
    _gas: Gas,
    scene: Ias,
    raygen: ProgramGroup,
    miss: ProgramGroup,
    hit: ProgramGroup,
}

impl SpecScene {
    /// The centre pixel of a [`SpecScene::render`], on the quad.
    const CENTRE: usize = 8 * 16 + 8;

    fn new(ctx: &Context) -> anyhow::Result<SpecScene> {
        let gas = Gas::triangles(ctx, &program_model::QUAD, None)?;
        let scene =
            Ias::new(ctx, &[Instance::new(&gas).transform(Affine3A::from_translation(Vec3::new(-0.25, -0.25, 0.0)))])?;
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
        let miss = ProgramGroup::miss(&module, program_model_device::MS)?;
        let hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SPEC_SHADE).build()?;
        Ok(SpecScene { _gas: gas, scene, raygen, miss, hit })
    }

    /// Its groups: raygen, miss, hit.
    fn groups(&self) -> [&ProgramGroup; 3] {
        [&self.raygen, &self.miss, &self.hit]
    }

    /// An SBT of its groups for `pipeline`.
    fn sbt(&self, pipeline: &Pipeline<Params>) -> raykit::Result<Sbt> {
        Sbt::builder(pipeline)
            .raygen(&self.raygen, ())
            .miss_for::<Radiance, _>(&self.miss, ())
            .hit_for::<Radiance, _>(0, &self.hit, ())
            .build()
    }

    /// Launches `pipeline` over 16×16 pixels and returns them.
    fn render(&self, ctx: &Context, pipeline: &Pipeline<Params>) -> anyhow::Result<Vec<u32>> {
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let params = Params {
            image: image.handle(),
            spheres: spheres.handle(),
            size: UVec2::splat(16),
            scene: self.scene.handle(),
        };
        pipeline.launch(&self.sbt(pipeline)?, &params, [16, 16, 1])?;
        Ok(image.read()?)
    }
}

#[test]
fn two_pipelines_from_one_module_specialized_differently_render_differently() -> anyhow::Result<()> {
    with_each_backend("two_pipelines_from_one_module_specialized_differently_render_differently", |ctx, _backend| {
        let spec = SpecScene::new(ctx)?;
        let mut seen = Vec::new();
        for constants in [Specialization::new(), Specialization::new().set(SHADE_MODE_SPEC_ID, 1)] {
            let pipeline =
                Pipeline::<Params>::with_specialization(ctx, &spec.groups(), LinkOptions::default(), &constants)?;
            seen.push(spec.render(ctx, &pipeline)?[SpecScene::CENTRE]);
        }
        assert_eq!(seen, [pack(SPEC_COLORS[0]), pack(SPEC_COLORS[1])]);
        Ok(())
    })
}

#[test]
fn two_async_launches_in_flight_give_correct_results() -> anyhow::Result<()> {
    with_each_backend("two_async_launches_in_flight_give_correct_results", |ctx, _backend| {
        let spec = SpecScene::new(ctx)?;
        let pipelines = [Specialization::new(), Specialization::new().set(SHADE_MODE_SPEC_ID, 1)]
            .iter()
            .map(|c| Pipeline::<Params>::with_specialization(ctx, &spec.groups(), LinkOptions::default(), c))
            .collect::<raykit::Result<Vec<_>>>()?;
        let sbts = pipelines.iter().map(|p| spec.sbt(p)).collect::<raykit::Result<Vec<_>>>()?;
        let size = 64u32;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        // Three launches: two of one pipeline (different images), one of the other.
        let images = (0..3).map(|_| ctx.buffer::<u32>((size * size) as usize)).collect::<raykit::Result<Vec<_>>>()?;
        let params = |i: usize| Params {
            image: images[i].handle(),
            spheres: spheres.handle(),
            size: UVec2::splat(size),
            scene: spec.scene.handle(),
        };
        let launches = [
            pipelines[0].launch_async(&sbts[0], &params(0), [size, size, 1])?,
            pipelines[1].launch_async(&sbts[1], &params(1), [size, size, 1])?,
            pipelines[0].launch_async(&sbts[0], &params(2), [size, size, 1])?,
        ];
        // While launches use the SBT, an update goes into a copy.
        let mut spare = spec.sbt(&pipelines[0])?;
        let held = pipelines[0].launch_async(&spare, &params(0), [1, 1, 1])?;
        spare.update(raykit::SbtRegion::Raygen, 0, ())?;
        held.wait()?;
        spare.update(raykit::SbtRegion::Raygen, 0, ())?;
        // Poll the last one, then wait for all.
        while !launches[2].is_done()? {
            std::thread::yield_now();
        }
        for launch in launches {
            launch.wait()?;
        }
        let centre = ((size / 2) * size + size / 2) as usize;
        let corner = 0usize;
        let bg = pack(program_model_device::BACKGROUND);
        let got: Vec<Vec<u32>> = images.iter().map(|i| i.read()).collect::<raykit::Result<_>>()?;
        assert_eq!(
            [got[0][centre], got[1][centre], got[2][centre]],
            [pack(SPEC_COLORS[0]), pack(SPEC_COLORS[1]), pack(SPEC_COLORS[0])]
        );
        assert_eq!([got[0][corner], got[1][corner], got[2][corner]], [bg, bg, bg]);
        assert_eq!(got[0], got[2]);
        Ok(())
    })
}

#[test]
fn async_launches_report_their_own_user_exceptions() -> anyhow::Result<()> {
    with_each_backend("async_launches_report_their_own_user_exceptions", |ctx, _backend| {
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let throwing = ProgramGroup::raygen(&module, program_model_device::RG_THROW)?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&throwing], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&throwing, ()).build()?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
        let p = |size: u32| Params {
            image: image.handle(),
            spheres: spheres.handle(),
            size: UVec2::splat(size),
            scene: raykit::Traversable::NULL,
        };
        // The first launch covers both throwing pixels, the second neither.
        let a = pipeline.launch_async(&sbt, &p(16), [16, 16, 1])?;
        let b = pipeline.launch_async(&sbt, &p(1), [1, 1, 1])?;
        b.wait()?;
        match a.wait() {
            Err(raykit::Error::Launch(raykit::LaunchError::UserExceptions { total, .. })) => assert_eq!(total, 2),
            other => anyhow::bail!("expected two user exceptions, got {other:?}"),
        }
        Ok(())
    })
}

/// Links the specialization scene's pipeline (constant `mode`), renders 16×16 and
/// returns the centre pixel.
fn render_spec_centre(ctx: &Context, mode: u32) -> anyhow::Result<u32> {
    let spec = SpecScene::new(ctx)?;
    let constants = Specialization::new().set(SHADE_MODE_SPEC_ID, mode);
    let pipeline = Pipeline::<Params>::with_specialization(ctx, &spec.groups(), LinkOptions::default(), &constants)?;
    Ok(spec.render(ctx, &pipeline)?[SpecScene::CENTRE])
}

fn cache_in(dir: &std::path::Path) -> ContextOptions {
    ContextOptions { pipeline_cache: PipelineCacheLocation::Dir(dir.to_owned()), ..Default::default() }
}

#[test]
fn a_warm_compile_cache_is_written_and_loaded_by_the_next_context() -> anyhow::Result<()> {
    let dir = temp_dir("warm-cache")?;
    let mut file = None;
    with_context_options("compile cache, cold", cache_in(&dir.0), |ctx| {
        let info = ctx.pipeline_cache_info();
        assert_eq!(info.load, CacheLoad::Missing);
        assert!(
            info.path.as_ref().is_some_and(|p| p.starts_with(&dir.0)),
            "cache file {:?} outside {:?}",
            info.path,
            dir.0
        );
        assert_eq!(render_spec_centre(ctx, 1)?, pack(SPEC_COLORS[1]));
        let after = ctx.pipeline_cache_info();
        eprintln!("compile cache after one pipeline: {} bytes", after.current_bytes);
        file = after.path;
        Ok(())
    })?;
    let file = file.ok_or_else(|| anyhow::anyhow!("no cache file path"))?;
    assert!(file.exists(), "{} was not written when the context was destroyed", file.display());
    with_context_options("compile cache, warm", cache_in(&dir.0), |ctx| {
        let info = ctx.pipeline_cache_info();
        let CacheLoad::Loaded { bytes } = info.load else {
            anyhow::bail!("the warm cache was not loaded: {:?}", info.load)
        };
        assert!(bytes >= 32, "{bytes} bytes loaded");
        assert_eq!(render_spec_centre(ctx, 1)?, pack(SPEC_COLORS[1]));
        Ok(())
    })
}

#[test]
fn a_corrupt_compile_cache_is_refused_and_rebuilt_without_failing_pipelines() -> anyhow::Result<()> {
    let dir = temp_dir("corrupt-cache")?;
    // Make a valid file, then damage it in two ways.
    let mut file = None;
    with_context_options("compile cache, first", cache_in(&dir.0), |ctx| {
        render_spec_centre(ctx, 0)?;
        file = ctx.save_pipeline_cache()?;
        Ok(())
    })?;
    let file = file.ok_or_else(|| anyhow::anyhow!("save_pipeline_cache wrote nothing"))?;
    let good = std::fs::read(&file)?;
    let mut flipped = good.clone();
    let last = flipped.len() - 1;
    flipped[last] ^= 0x5a;
    for (damage, bytes) in [
        ("a flipped byte", flipped),
        ("a truncated file", good[..good.len() / 2].to_vec()),
        ("garbage", b"not a cache".to_vec()),
    ] {
        std::fs::write(&file, &bytes)?;
        with_context_options("compile cache, corrupt", cache_in(&dir.0), |ctx| {
            let info = ctx.pipeline_cache_info();
            let CacheLoad::Rejected { reason } = &info.load else {
                anyhow::bail!("{damage} was not refused: {:?}", info.load)
            };
            eprintln!("{damage}: refused: {reason}");
            assert_eq!(render_spec_centre(ctx, 0)?, pack(SPEC_COLORS[0]), "{damage}");
            Ok(())
        })?;
        // Rebuilt: the next context loads it.
        with_context_options("compile cache, rebuilt", cache_in(&dir.0), |ctx| {
            let load = ctx.pipeline_cache_info().load;
            anyhow::ensure!(
                matches!(load, CacheLoad::Loaded { .. }),
                "after {damage}, the rewritten cache was not loaded: {load:?}"
            );
            Ok(())
        })?;
    }
    Ok(())
}

#[test]
fn the_compile_cache_can_be_turned_off() -> anyhow::Result<()> {
    with_context_options(
        "compile cache off",
        ContextOptions { pipeline_cache: PipelineCacheLocation::Off, ..Default::default() },
        |ctx| {
            let info = ctx.pipeline_cache_info();
            assert_eq!((info.path, info.load), (None, CacheLoad::Off));
            assert_eq!(ctx.save_pipeline_cache()?, None);
            assert_eq!(render_spec_centre(ctx, 1)?, pack(SPEC_COLORS[1]));
            Ok(())
        },
    )
}

#[test]
fn eight_threads_create_modules_and_pipelines_and_launch_concurrently() -> anyhow::Result<()> {
    with_each_backend("eight_threads_create_modules_and_pipelines_and_launch_concurrently", |ctx, _backend| {
        let results: Vec<anyhow::Result<(u32, u32)>> = std::thread::scope(|scope| {
            let threads: Vec<_> = (0..8u32)
                .map(|i| {
                    scope.spawn(move || -> anyhow::Result<(u32, u32)> {
                        // Each thread: its own GAS, IAS, module, groups, pipeline, SBT and launch.
                        let mode = i % 2;
                        Ok((mode, render_spec_centre(ctx, mode)?))
                    })
                })
                .collect();
            threads
                .into_iter()
                .map(|t| t.join().unwrap_or_else(|_| Err(anyhow::anyhow!("a thread panicked"))))
                .collect()
        });
        for result in results {
            let (mode, centre) = result?;
            assert_eq!(centre, pack(SPEC_COLORS[mode as usize]));
        }
        Ok(())
    })
}

/// A message reaches the log callback of the context whose object it names, with
/// the name the object was given, and not another context on the same device.
#[test]
fn a_validation_message_reaches_the_log_callback_naming_its_object() -> anyhow::Result<()> {
    if !raykit_tests::validation_on() {
        eprintln!("SKIPPED: needs the validation layer (RAYKIT_VALIDATION=1, as cargo xtask test sets)");
        return Ok(());
    }
    let received = std::sync::Arc::new(std::sync::Mutex::new(Vec::<raykit::ValidationMessage>::new()));
    let sink = received.clone();
    let options = ContextOptions {
        validation: Some(true),
        pipeline_cache: PipelineCacheLocation::Off,
        log_callback: Some(raykit::LogCallback::new(move |m| {
            sink.lock().unwrap_or_else(|p| p.into_inner()).push(m.clone())
        })),
        ..Default::default()
    };
    let ctx = Context::new(options)?;
    let other = Context::new(raykit_tests::test_options())?;
    anyhow::ensure!(ctx.shares_device_with(&other), "two contexts on one GPU did not share its device");
    let (log, other_log) = (ctx.messages(), other.messages());
    // Creation calls that are valid report nothing.
    let module = Module::from_device_crate(&ctx, "program-model-device")?;
    let raygen = ProgramGroup::raygen(&module, program_model_device::RG)?;
    let pipeline = Pipeline::<Params>::new(&ctx, &[&raygen], LinkOptions::default())?;
    assert!(module.creation_log().is_empty() && pipeline.creation_log().is_empty());
    drop((pipeline, raygen, module));
    assert!(received.lock().unwrap_or_else(|p| p.into_inner()).is_empty(), "messages before the misuse");
    // An invalid but harmless use, through the escape hatch, of a named buffer.
    raykit_tests::provoke_validation_error(&ctx, "deliberately misused buffer")?;
    drop((ctx, other));
    let messages = received.lock().unwrap_or_else(|p| p.into_inner()).clone();
    let Some(misuse) = messages.iter().find(|m| raykit_tests::names_object(m, "deliberately misused buffer")) else {
        anyhow::bail!("no message named the misused buffer; got: {messages:#?}")
    };
    eprintln!("callback got: {misuse}");
    assert_eq!(misuse.severity, raykit::Severity::Error);
    assert_eq!(log.take().len(), messages.len(), "the log and the callback saw different messages");
    let leaked = other_log.take();
    assert!(leaked.is_empty(), "another context on the device got the message: {leaked:?}");
    Ok(())
}

/// OptiX's "program groups can be used across pipelines": one library (raygen
/// and miss) linked into two pipelines, each with its own hit library compiled
/// with another specialization constant. Both pipelines live at once, and keep
/// working after the library handles are dropped.
#[test]
fn one_library_is_linked_into_two_pipelines_with_their_own_hit_libraries() -> anyhow::Result<()> {
    with_each_backend("one_library_is_linked_into_two_pipelines_with_their_own_hit_libraries", |ctx, backend| {
        anyhow::ensure!(ctx.supports_pipeline_libraries(), "{} lacks VK_KHR_pipeline_library", ctx.device_name());
        let spec = SpecScene::new(ctx)?;
        let [raygen, miss, hit] = spec.groups();
        let interface = PipelineLibrary::<Params>::interface_for(&spec.groups());
        let options = LibraryOptions { max_trace_depth: 1, interface: Some(interface) };
        let common = PipelineLibrary::<Params>::new(ctx, &[raygen, miss], options)?;
        let mut pipelines = Vec::new();
        for mode in [0, 1] {
            let constants = Specialization::new().set(SHADE_MODE_SPEC_ID, mode);
            let hits = PipelineLibrary::<Params>::with_specialization(ctx, &[hit], options, &constants)?;
            assert_eq!(hits.interface(), interface);
            pipelines.push(Pipeline::link(ctx, &[&common, &hits], LinkOptions::default())?);
        }
        drop(common);
        for (mode, pipeline) in pipelines.iter().enumerate() {
            let pixels = spec.render(ctx, pipeline)?;
            assert_eq!(pixels[SpecScene::CENTRE], pack(SPEC_COLORS[mode]), "centre of pipeline {mode}");
            assert_eq!(pixels[0], pack(program_model_device::BACKGROUND), "corner of pipeline {mode}");
            if backend == raykit::Backend::Cpu {
                continue; // The CPU backend reports no driver stack sizes.
            }
            // Linking compiled nothing: the groups are the libraries', in library order.
            let roles: Vec<raykit::stack::GroupRole> =
                pipeline.all_group_stack_sizes().iter().map(|(role, _)| *role).collect();
            use raykit::stack::GroupRole::{Hit, Miss, Raygen};
            assert_eq!(roles, [Raygen, Miss, Hit]);
        }
        Ok(())
    })
}

/// A user exception thrown by a program compiled in one library is recorded in
/// that library's buffer and reaches the host from the linked pipeline's launch,
/// and the exception program compiled in another library runs where it was thrown.
#[test]
fn user_exceptions_thrown_in_a_library_reach_the_host_and_the_exception_program_of_another() -> anyhow::Result<()> {
    use program_model_device::{EXCEPTION_MARKER, THROWN};
    with_each_backend(
        "user_exceptions_thrown_in_a_library_reach_the_host_and_the_exception_program_of_another",
        |ctx, _backend| {
            let module = Module::from_device_crate(ctx, "program-model-device")?;
            let throwing = ProgramGroup::raygen(&module, program_model_device::RG_THROW)?;
            let handler = ProgramGroup::exception(&module, program_model_device::ON_EXCEPTION)?;
            let options = LibraryOptions {
                max_trace_depth: 1,
                interface: Some(PipelineLibrary::<Params>::interface_for(&[&throwing, &handler])),
            };
            let raygen_library = PipelineLibrary::<Params>::new(ctx, &[&throwing], options)?;
            let handler_library = PipelineLibrary::<Params>::new(ctx, &[&handler], options)?;
            let pipeline = Pipeline::link(ctx, &[&raygen_library, &handler_library], LinkOptions::default())?;
            let sbt = Sbt::builder(&pipeline).raygen(&throwing, ()).build()?;
            let image = ctx.buffer::<u32>(16 * 16)?;
            let spheres = ctx.buffer_from::<Vec4>(&[Vec4::ZERO])?;
            let params = Params {
                image: image.handle(),
                spheres: spheres.handle(),
                size: UVec2::splat(16),
                scene: raykit::Traversable::NULL,
            };
            match pipeline.launch(&sbt, &params, [16, 16, 1]) {
                Err(raykit::Error::Launch(raykit::LaunchError::UserExceptions { total, exceptions })) => {
                    assert_eq!(total, 2);
                    let mut codes: Vec<u32> = exceptions.iter().map(|e| e.code).collect();
                    codes.sort();
                    let mut expected: Vec<u32> = THROWN.iter().map(|(_, code)| *code).collect();
                    expected.sort();
                    assert_eq!(codes, expected);
                }
                other => anyhow::bail!("expected two user exceptions, got {other:?}"),
            }
            let pixels = image.read()?;
            for (at, code) in THROWN {
                assert_eq!(pixels[(at.y * 16 + at.x) as usize], EXCEPTION_MARKER | code, "at {at}");
            }
            assert_eq!(pixels.iter().filter(|&&p| p == 1).count(), 16 * 16 - 2);
            Ok(())
        },
    )
}
