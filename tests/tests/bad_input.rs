//! The catalogue of bad inputs: one test per case. Each feeds raykit a
//! wrong input, checks the typed error — its variant, and a message that names the
//! problem and the fix — and then renders optixTriangle with the same context, to
//! show the error left it usable. Like every test, each runs under the harness:
//! with `cargo xtask test` the validation layer is on and any message, or any
//! object left alive, fails it.
//!
//! Cases that cannot be provoked here:
//! * device lost during a launch: lavapipe cannot lose its device; `device_lost.rs`
//!   injects `VK_ERROR_DEVICE_LOST` at submission instead. The waits have no
//!   timeout: on a GPU the driver's watchdog turns a program that never ends into a
//!   lost device; on lavapipe such a launch hangs.
//!
//! raykit reads the ray types the programs trace from their SPIR-V (the constant
//! SBT offsets and miss indices of `OpTraceRayKHR`) and the ray type each miss and
//! hit program was declared for (`#[miss(ray = R)]`): an SBT missing a record a
//! trace selects, or a group placed for another ray type, is refused. Crash cases
//! (inputs that once crashed the driver or raykit) run in a child process.

use raykit::glam::{Affine3A, Vec3};
use raykit::texture::MipLevel;
use raykit::{
    Balance, BandRows, BuildOptions, Context, ContextOptions, DeviceGroup, DeviceGroupError, Error, Gas, Ias, Instance,
    InterfaceSizes, LaunchError, LayoutError, LibraryOptions, LinkOptions, Mipmaps, Module, Pipeline, PipelineLibrary,
    ProgramGroup, ProgramKind, ResourceError, SamplerOptions, Sbt, SbtRegion, Texture, TextureFormat, Triangles,
};
use raykit_tests::with_context;
use triangle::BG_COLOR;
use triangle_device::{make_color, MissData, Params};

/// Renders the triangle at 16 × 16: a corner must be background and the centre
/// the triangle.
fn still_usable(ctx: &Context) -> anyhow::Result<()> {
    let pixels = triangle::render(ctx, 16, 16)?;
    let bg = make_color(BG_COLOR);
    anyhow::ensure!(pixels.len() == 256, "{} pixels", pixels.len());
    anyhow::ensure!(pixels[0] == bg, "corner pixel {:#010x} is not background after the error", pixels[0]);
    anyhow::ensure!(pixels[8 * 16 + 8] != bg, "centre pixel is background after the error");
    Ok(())
}

/// The error of `result`, or a failure saying what was wrongly accepted.
fn refused<T>(result: raykit::Result<T>, what: &str) -> anyhow::Result<Error> {
    match result {
        Ok(_) => anyhow::bail!("{what} was accepted"),
        Err(e) => Ok(e),
    }
}

/// One catalogue case, on each backend (`raykit_tests::with_each_backend`):
/// `provoke` returns the error raykit gave; `expected` checks its variant; its
/// message must contain each of `mentions`; then the context must still render.
/// Both backends must refuse the input alike: the same variant and message.
fn case(
    name: &str,
    mentions: &[&str],
    provoke: impl Fn(&Context) -> anyhow::Result<Error>,
    expected: impl Fn(&Error) -> bool,
) -> anyhow::Result<()> {
    raykit_tests::with_each_backend(name, |ctx, backend| {
        check_case(ctx, (backend, ""), name, mentions, &provoke, &expected)
    })
}

/// [`case`] on Vulkan only, for an input the CPU backend cannot be given;
/// `why` says why in one line (it is the table's reason).
fn vulkan_case(
    why: &str,
    name: &str,
    mentions: &[&str],
    provoke: impl FnOnce(&Context) -> anyhow::Result<Error>,
    expected: impl FnOnce(&Error) -> bool,
) -> anyhow::Result<()> {
    anyhow::ensure!(!why.is_empty(), "{name}: a Vulkan-only case says why");
    with_context(name, |ctx| check_case(ctx, (raykit::Backend::Vulkan, why), name, mentions, provoke, expected))
}

/// [`case`] on the CPU backend only, for a refusal that only it makes; `why`
/// says why in one line (it is the table's reason).
fn cpu_case(
    why: &str,
    name: &str,
    mentions: &[&str],
    provoke: impl FnOnce(&Context) -> anyhow::Result<Error>,
    expected: impl FnOnce(&Error) -> bool,
) -> anyhow::Result<()> {
    anyhow::ensure!(!why.is_empty(), "{name}: a CPU-only case says why");
    let options = ContextOptions { backend: Some(raykit::Backend::Cpu), ..raykit_tests::test_options() };
    raykit_tests::with_context_options(name, options, |ctx| {
        check_case(ctx, (raykit::Backend::Cpu, why), name, mentions, provoke, expected)
    })
}

/// One case on `ctx` of `backend`: the error, its variant, its message, then a
/// render. The refusal is noted for the refusal table, with why the case runs
/// on that backend only (empty when it runs on both).
fn check_case(
    ctx: &Context,
    (backend, why): (raykit::Backend, &str),
    name: &str,
    mentions: &[&str],
    provoke: impl FnOnce(&Context) -> anyhow::Result<Error>,
    expected: impl FnOnce(&Error) -> bool,
) -> anyhow::Result<()> {
    let err = provoke(ctx)?;
    anyhow::ensure!(expected(&err), "{name} [{backend:?}]: unexpected error {err:?}");
    raykit_tests::note_refusal(name, backend, &err, why);
    let text = err.to_string();
    for m in mentions {
        anyhow::ensure!(text.contains(m), "{name}: the message does not mention {m:?}: {text}");
    }
    still_usable(ctx)
}

fn triangle_module(ctx: &Context) -> anyhow::Result<Module> {
    Ok(Module::from_device_crate(ctx, "triangle-device")?)
}

const RAYGEN_MAIN: &[u8] = include_bytes!("../data/raygen_main.rgen.spv");

/// SPIR-V words of `bytes` (little-endian).
fn words(bytes: &[u8]) -> Vec<u32> {
    bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

fn bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// Index of the first instruction with `opcode` in a module's words.
fn find_instruction(words: &[u32], opcode: u32) -> Option<usize> {
    let mut at = 5;
    while at < words.len() {
        if words[at] & 0xffff == opcode {
            return Some(at);
        }
        at += (words[at] >> 16).max(1) as usize;
    }
    None
}

// ---------------------------------------------------------------- program groups

#[test]
fn entry_point_missing() -> anyhow::Result<()> {
    case(
        "entry_point_missing",
        &["`__raygen__nope`", "`__raygen__rg` (raygen)", "entry-point constants"],
        |ctx| refused(ProgramGroup::raygen(&triangle_module(ctx)?, "__raygen__nope"), "a missing entry point"),
        |e| matches!(e, Error::Module(raykit::ModuleError::EntryPointNotFound { name, .. }) if name == "__raygen__nope"),
    )
}

#[test]
fn entry_point_of_another_stage_named_as_raygen() -> anyhow::Result<()> {
    case(
        "entry_point_of_another_stage_named_as_raygen",
        &["`__miss__ms` is a miss program, not a raygen program", "ProgramGroup::raygen"],
        |ctx| refused(ProgramGroup::raygen(&triangle_module(ctx)?, "__miss__ms"), "a miss entry as raygen"),
        |e| matches!(e, Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::Raygen, .. })),
    )
}

#[test]
fn entry_point_constant_of_another_kind() -> anyhow::Result<()> {
    case(
        "entry_point_constant_of_another_kind",
        &["`__closesthit__ch`", "ProgramGroup::miss"],
        |ctx| {
            refused(ProgramGroup::miss(&triangle_module(ctx)?, triangle_device::CH), "a closest-hit constant as miss")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::Miss, .. })),
    )
}

#[test]
fn closest_hit_slot_given_a_raygen() -> anyhow::Result<()> {
    case(
        "closest_hit_slot_given_a_raygen",
        &["`__raygen__rg`", "HitGroupBuilder::closest_hit"],
        |ctx| {
            let module = triangle_module(ctx)?;
            refused(
                ProgramGroup::hit_group(&module).closest_hit(triangle_device::RG).build(),
                "a raygen as closest-hit",
            )
        },
        |e| {
            matches!(
                e,
                Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::ClosestHit, .. })
            )
        },
    )
}

#[test]
fn optix_prefix_disagrees_with_the_stage() -> anyhow::Result<()> {
    // A GLSL raygen stage whose entry point is called `__miss__named_wrong`.
    vulkan_case(
        "a SPIR-V module (GLSL): the CPU backend runs Rust programs and refuses it (CpuRefusal::SpirvModule)",
        "optix_prefix_disagrees_with_the_stage",
        &["`__miss__named_wrong`", "by its `__miss__` prefix"],
        |ctx| {
            let module = Module::new(ctx, include_bytes!("../data/raygen_named_miss.rgen.spv"))?;
            // As a miss it is refused by its stage …
            let err = refused(ProgramGroup::miss(&module, "__miss__named_wrong"), "a raygen stage as miss")?;
            anyhow::ensure!(
                matches!(
                    err,
                    Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::Miss, .. })
                ),
                "{err:?}"
            );
            // … and as a raygen by its name.
            refused(ProgramGroup::raygen(&module, "__miss__named_wrong"), "a `__miss__` name as raygen")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::Raygen, actual, .. }) if actual.contains("prefix")),
    )
}

#[test]
fn glsl_main_used_as_another_stage() -> anyhow::Result<()> {
    vulkan_case(
        "a SPIR-V module (GLSL): the CPU backend runs Rust programs and refuses it (CpuRefusal::SpirvModule)",
        "glsl_main_used_as_another_stage",
        &["`main` is a raygen program, not a miss program"],
        |ctx| refused(ProgramGroup::miss(&Module::new(ctx, RAYGEN_MAIN)?, "main"), "a GLSL raygen as miss"),
        |e| matches!(e, Error::Module(raykit::ModuleError::ProgramKindMismatch { expected: ProgramKind::Miss, .. })),
    )
}

#[test]
fn hit_group_without_programs_is_allowed() -> anyhow::Result<()> {
    // Vulkan and OptiX allow it: a ray type that needs no hit program gets one.
    with_context("hit_group_without_programs_is_allowed", |ctx| {
        let s = shadows(ctx)?;
        let module = Module::from_device_crate(ctx, "program-model-device")?;
        let empty = ProgramGroup::hit_group(&module).build()?;
        let pipeline = Pipeline::<program_model_device::Params>::new(
            ctx,
            &[&s.raygen, &s.miss, &s.shadow_miss, &s.shade, &empty],
            LinkOptions { max_trace_depth: 2 },
        )?;
        Sbt::builder(&pipeline)
            .raygen(&s.raygen, ())
            .miss_for::<program_model_device::ShadowedRadiance, _>(&s.miss, ())
            .miss_for::<program_model_device::Shadow, _>(&s.shadow_miss, ())
            .hit_for::<program_model_device::ShadowedRadiance, _>(0, &s.shade, ())
            .hit_for::<program_model_device::Shadow, _>(0, &empty, ())
            .build()?;
        still_usable(ctx)
    })
}

// ---------------------------------------------------------------- SPIR-V intake

#[test]
fn module_that_is_not_spirv() -> anyhow::Result<()> {
    case(
        "module_that_is_not_spirv",
        &["not a SPIR-V module", "magic number", "cargo xtask build-shaders"],
        |ctx| {
            let mut source = b"#version 460\nvoid main() {}\n".to_vec();
            source.resize(source.len().next_multiple_of(4), b' ');
            refused(Module::new(ctx, &source), "GLSL source as SPIR-V")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn empty_module() -> anyhow::Result<()> {
    case(
        "empty_module",
        &["0 bytes is shorter than a SPIR-V header", "cargo xtask build-shaders"],
        |ctx| refused(Module::new(ctx, &[]), "an empty module"),
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_cut_inside_a_word() -> anyhow::Result<()> {
    case(
        "spirv_cut_inside_a_word",
        &["not a whole number of 32-bit words"],
        |ctx| refused(Module::new(ctx, &RAYGEN_MAIN[..RAYGEN_MAIN.len() - 2]), "a module cut inside a word"),
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_truncated_between_words() -> anyhow::Result<()> {
    case(
        "spirv_truncated_between_words",
        &["truncated"],
        |ctx| refused(Module::new(ctx, &RAYGEN_MAIN[..(RAYGEN_MAIN.len() / 2) & !3]), "half a module"),
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_with_a_zero_word_count() -> anyhow::Result<()> {
    case(
        "spirv_with_a_zero_word_count",
        &["claims 0 words"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            w[5] &= 0xffff; // the first instruction's word count
            refused(Module::new(ctx, &bytes(&w)), "an instruction of zero words")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_with_an_unknown_version() -> anyhow::Result<()> {
    case(
        "spirv_with_an_unknown_version",
        &["unknown SPIR-V version word 0x00020000"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            w[1] = 0x0002_0000;
            refused(Module::new(ctx, &bytes(&w)), "SPIR-V 2.0")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_with_an_absurd_id_bound() -> anyhow::Result<()> {
    case(
        "spirv_with_an_absurd_id_bound",
        &["ID bound 4294967295 is out of range"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            w[3] = u32::MAX;
            refused(Module::new(ctx, &bytes(&w)), "an ID bound of 2^32 - 1")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_entry_point_naming_an_undefined_function() -> anyhow::Result<()> {
    case(
        "spirv_entry_point_naming_an_undefined_function",
        &["which the module does not define"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            let at = find_instruction(&w, 15).ok_or_else(|| anyhow::anyhow!("no OpEntryPoint"))?;
            w[at + 2] = w[3] - 1; // an id below the bound that names no function
            refused(Module::new(ctx, &bytes(&w)), "an entry point without its function")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_defining_an_id_outside_its_bound() -> anyhow::Result<()> {
    case(
        "spirv_defining_an_id_outside_its_bound",
        &["TypeVoid defines %", "outside the module's ID bound"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            let at = find_instruction(&w, 19).ok_or_else(|| anyhow::anyhow!("no OpTypeVoid"))?;
            w[at + 1] = w[3] + 5;
            refused(Module::new(ctx, &bytes(&w)), "an id over the bound")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_using_an_id_it_never_defines() -> anyhow::Result<()> {
    case(
        "spirv_using_an_id_it_never_defines",
        &["which the module never defines"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            // OpTypePointer %ptr StorageClass %pointee: point it at nothing.
            let at = find_instruction(&w, 32).ok_or_else(|| anyhow::anyhow!("no OpTypePointer"))?;
            w[at + 3] = w[3]; // the old bound: an id nothing defines …
            w[3] += 1; // … made legal by a larger bound
            refused(Module::new(ctx, &bytes(&w)), "a pointer to an undefined type")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_with_a_spec_constant_op_it_cannot_compute() -> anyhow::Result<()> {
    // Found by fuzzing: rspirv's parser panics on this (raykit caught the panic,
    // but printed it and gave a vague reason); now refused before parsing.
    case(
        "spirv_with_a_spec_constant_op_it_cannot_compute",
        &["OpSpecConstantOp at word", "computes opcode 52"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            let at = find_instruction(&w, 21).ok_or_else(|| anyhow::anyhow!("no OpTypeInt"))?; // %uint
            let (uint, bound) = (w[at + 1], w[3]);
            // `%bound = OpSpecConstantOp %uint OpSpecConstantOp`, after the types.
            let after = find_instruction(&w, 54).ok_or_else(|| anyhow::anyhow!("no OpFunction"))?;
            w.splice(after..after, [(4 << 16) | 52, uint, bound, 52]);
            w[3] += 1;
            refused(Module::new(ctx, &bytes(&w)), "an OpSpecConstantOp of an OpSpecConstantOp")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn spirv_without_ray_tracing_entry_points() -> anyhow::Result<()> {
    case(
        "spirv_without_ray_tracing_entry_points",
        &[
            "no ray-tracing entry points",
            "`main` (not a ray-tracing stage)",
            "Compile the programs as ray-tracing stages",
        ],
        |ctx| refused(Module::new(ctx, include_bytes!("../data/compute_only.comp.spv")), "a compute shader"),
        |e| matches!(e, Error::Module(raykit::ModuleError::NoRayTracingEntryPoints { available }) if available.len() == 1),
    )
}

#[test]
fn spirv_without_any_entry_point() -> anyhow::Result<()> {
    case(
        "spirv_without_any_entry_point",
        &["no ray-tracing entry points", "it has: none"],
        |ctx| refused(Module::new(ctx, include_bytes!("../data/no_entry_points.spv")), "a library module"),
        |e| matches!(e, Error::Module(raykit::ModuleError::NoRayTracingEntryPoints { available }) if available.is_empty()),
    )
}

#[test]
fn spirv_file_that_does_not_exist() -> anyhow::Result<()> {
    case(
        "spirv_file_that_does_not_exist",
        &["no/such/file.spv", "cargo xtask build-shaders"],
        |ctx| refused(Module::from_file(ctx, "no/such/file.spv"), "a missing file"),
        |e| matches!(e, Error::Module(raykit::ModuleError::SpirvFile { .. })),
    )
}

#[test]
fn device_crate_whose_spirv_is_not_found() -> anyhow::Result<()> {
    // The suite sets RAYKIT_SPIRV_DIR, so that is the one path looked at.
    let dir = std::env::var("RAYKIT_SPIRV_DIR").unwrap_or_default();
    vulkan_case(
        "the CPU backend needs no SPIR-V file: it runs the crate linked into the program",
        "device_crate_whose_spirv_is_not_found",
        &["no SPIR-V for device crate `no-such-device`", "no_such_device.spv", "RAYKIT_SPIRV_DIR", &dir],
        |ctx| refused(Module::from_device_crate(ctx, "no-such-device"), "a device crate never built"),
        |e| matches!(e, Error::Module(raykit::ModuleError::SpirvNotFound { tried, .. }) if !tried.is_empty()),
    )
}

#[test]
fn buffer_one_element_over_max_storage_buffer_range() -> anyhow::Result<()> {
    case(
        "buffer_one_element_over_max_storage_buffer_range",
        &["maxStorageBufferRange", "split the data"],
        |ctx| {
            let limit = ctx.limits().max_storage_buffer_range;
            let e = refused(ctx.buffer::<u32>(limit as usize / 4 + 1), "a buffer past maxStorageBufferRange")?;
            // The largest allowed one is fine (and is freed at once).
            drop(ctx.buffer::<u32>(limit as usize / 4)?);
            Ok(e)
        },
        |e| matches!(e, Error::Resource(raykit::ResourceError::BufferTooLarge { .. })),
    )
}

#[test]
fn explicit_stack_size_of_zero() -> anyhow::Result<()> {
    case(
        "explicit_stack_size_of_zero",
        &["StackSize::Explicit(0)", "StackSize::Refined"],
        |ctx| {
            let l = linked(ctx)?;
            refused(l.pipeline.set_stack_size(&raykit::stack::StackSize::Explicit(0)), "a zero stack")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::StackSize { .. })),
    )
}

#[test]
fn explicit_stack_size_below_a_programs_own_need() -> anyhow::Result<()> {
    vulkan_case(
        "a program's own stack need is the driver's figure; on the CPU backend it is 0, which no size undercuts",
        "explicit_stack_size_below_a_programs_own_need",
        &["is below", "the largest stack one of the pipeline's programs needs"],
        |ctx| {
            let s = recursive_pipeline(ctx, 2)?;
            let sizes = s.stack_sizes();
            let largest = [sizes.css_rg, sizes.css_ms, sizes.css_ch].into_iter().max().unwrap_or(0);
            anyhow::ensure!(largest > 1, "the driver reports stacks of {largest} bytes: nothing to undercut");
            refused(s.set_stack_size(&raykit::stack::StackSize::Explicit(largest as u32 - 1)), "a too small stack")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::StackSize { .. })),
    )
}

#[test]
fn call_graph_whose_callables_call_each_other() -> anyhow::Result<()> {
    case(
        "call_graph_whose_callables_call_each_other",
        &["cycle"],
        |ctx| {
            let l = linked(ctx)?;
            let mut graph = raykit::stack::CallGraph::new(1);
            let rg = graph.raygen(16);
            let (a, b) = (graph.callable(8), graph.callable(8));
            graph.calls(rg, a).calls(a, b).calls(b, a);
            refused(l.pipeline.set_stack_size(&raykit::stack::StackSize::CallGraph(&graph)), "a callable cycle")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::CallGraph { .. })),
    )
}

#[test]
fn pipeline_cache_path_that_is_a_fifo() -> anyhow::Result<()> {
    in_child("pipeline_cache_path_that_is_a_fifo", || {
        let dir = std::env::temp_dir().join(format!("raykit-fifo-cache-{}", std::process::id()));
        std::fs::create_dir_all(&dir)?;
        let options =
            || ContextOptions { pipeline_cache: raykit::PipelineCacheLocation::Dir(dir.clone()), ..Default::default() };
        // Learn the cache file's name, then put a FIFO there.
        let mut file = None;
        raykit_tests::with_context_options("pipeline_cache_path_that_is_a_fifo (probe)", options(), |ctx| {
            file = ctx.pipeline_cache_info().path;
            Ok(())
        })?;
        let file = file.ok_or_else(|| anyhow::anyhow!("the disk cache is off"))?;
        let _ = std::fs::remove_file(&file);
        let made = std::process::Command::new("mkfifo").arg(&file).status()?;
        anyhow::ensure!(made.success(), "mkfifo {} failed", file.display());
        let result = raykit_tests::with_context_options("pipeline_cache_path_that_is_a_fifo", options(), |ctx| {
            let raykit::CacheLoad::Rejected { reason } = ctx.pipeline_cache_info().load else {
                anyhow::bail!("the FIFO was not refused: {:?}", ctx.pipeline_cache_info().load);
            };
            anyhow::ensure!(
                reason.contains("is not a regular file") && reason.contains("RAYKIT_PIPELINE_CACHE"),
                "{reason}"
            );
            let err = refused(ctx.save_pipeline_cache(), "saving over a FIFO")?;
            anyhow::ensure!(matches!(err, Error::Device(raykit::DeviceError::PipelineCacheIo { .. })), "{err:?}");
            still_usable(ctx)
        });
        let _ = std::fs::remove_dir_all(&dir);
        result
    })
}

// ---------------------------------------------------------------- launch params

#[test]
fn params_layout_differs_from_the_spirv() -> anyhow::Result<()> {
    use params_device::TargetDependent;
    case(
        "params_layout_differs_from_the_spirv",
        &["`TargetDependent`", "`__raygen__rg_target_dependent`", "field `value`", "Likely cause"],
        |ctx| {
            let module = Module::from_device_crate(ctx, "params-device")?;
            let raygen = ProgramGroup::raygen(&module, params_device::RG_TARGET_DEPENDENT)?;
            refused(Pipeline::<TargetDependent>::new(ctx, &[&raygen], LinkOptions::default()), "a moved field")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::ParamsLayout(l)) if matches!(**l, LayoutError::Mismatch { struct_name: "TargetDependent", .. })),
    )
}

#[test]
fn params_type_differs_between_modules_of_a_pipeline() -> anyhow::Result<()> {
    vulkan_case(
        "the other params type is a GLSL module's: the CPU backend refuses SPIR-V modules",
        "params_type_differs_between_modules_of_a_pipeline",
        &["launch params `Params` do not match the SPIR-V of `main`"],
        |ctx| {
            let raygen = ProgramGroup::raygen(&triangle_module(ctx)?, triangle_device::RG)?;
            // A GLSL miss program whose push-constant block is `{ vec4 tint; float scale; }`.
            let other = Module::new(ctx, include_bytes!("../data/miss_other_params.rmiss.spv"))?;
            let miss = ProgramGroup::miss(&other, "main")?;
            refused(Pipeline::<Params>::new(ctx, &[&raygen, &miss], LinkOptions::default()), "two params types")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::ParamsLayout(l)) if matches!(&**l, LayoutError::Mismatch { entry, .. } if entry == "main")),
    )
}

#[test]
fn params_read_another_way_than_delivered() -> anyhow::Result<()> {
    use params_device::Large;
    vulkan_case(
        "the other params delivery is a GLSL module's: the CPU backend refuses SPIR-V modules",
        "params_read_another_way_than_delivered",
        &["`main` reads its params from push constants", "a uniform buffer (set 1, binding 0)"],
        |ctx| {
            let module = Module::from_device_crate(ctx, "params-device")?;
            let raygen = ProgramGroup::raygen(&module, params_device::RG_LARGE)?;
            let other = Module::new(ctx, include_bytes!("../data/miss_other_params.rmiss.spv"))?;
            let miss = ProgramGroup::miss(&other, "main")?;
            refused(
                Pipeline::<Large>::new(ctx, &[&raygen, &miss], LinkOptions::default()),
                "push constants for a UBO struct",
            )
        },
        |e| matches!(e, Error::Link(raykit::LinkError::ParamsLayout(l)) if matches!(**l, LayoutError::Delivery { .. })),
    )
}

// ---------------------------------------------------------------- linking

#[test]
fn max_trace_depth_above_the_device_limit() -> anyhow::Result<()> {
    case(
        "max_trace_depth_above_the_device_limit",
        &["maxRayRecursionDepth", "restructure recursive tracing as a loop"],
        |ctx| {
            let raygen = ProgramGroup::raygen(&triangle_module(ctx)?, triangle_device::RG)?;
            let limit = ctx.limits().max_ray_recursion_depth;
            for depth in [limit + 1, u32::MAX] {
                let err =
                    refused(Pipeline::<Params>::new(ctx, &[&raygen], LinkOptions { max_trace_depth: depth }), "depth")?;
                anyhow::ensure!(
                    matches!(err, Error::Link(raykit::LinkError::TraceDepthTooLarge { requested, limit: l }) if requested == depth && l == limit),
                    "{err:?}"
                );
            }
            refused(Pipeline::<Params>::new(ctx, &[&raygen], LinkOptions { max_trace_depth: limit + 1 }), "depth")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::TraceDepthTooLarge { .. })),
    )
}

#[test]
fn pipeline_without_a_raygen_group() -> anyhow::Result<()> {
    case(
        "pipeline_without_a_raygen_group",
        &["needs a raygen program group", "ProgramGroup::raygen"],
        |ctx| {
            let miss = ProgramGroup::miss(&triangle_module(ctx)?, triangle_device::MS)?;
            refused(Pipeline::<Params>::new(ctx, &[&miss], LinkOptions::default()), "a pipeline without raygen")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::NoRaygen)),
    )
}

/// A second context on the same device; its own log must stay empty too.
fn with_second_context<T>(f: impl FnOnce(&Context) -> anyhow::Result<T>) -> anyhow::Result<T> {
    let validation = std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1");
    let other = Context::new(ContextOptions { validation: Some(validation), ..Default::default() })?;
    let log = other.messages();
    let result = f(&other);
    drop(other);
    let messages = log.take();
    anyhow::ensure!(messages.is_empty(), "the second context: {messages:?}");
    anyhow::ensure!(log.context_destroyed(), "the second context was not destroyed");
    result
}

#[test]
fn pipeline_from_groups_of_another_context() -> anyhow::Result<()> {
    case(
        "pipeline_from_groups_of_another_context",
        &["different Contexts", "same Context"],
        |ctx| {
            let raygen = ProgramGroup::raygen(&triangle_module(ctx)?, triangle_device::RG)?;
            with_second_context(|other| {
                let miss = ProgramGroup::miss(&triangle_module(other)?, triangle_device::MS)?;
                refused(
                    Pipeline::<Params>::new(ctx, &[&raygen, &miss], LinkOptions::default()),
                    "groups of two contexts",
                )
            })
        },
        |e| matches!(e, Error::Device(raykit::DeviceError::ContextMismatch)),
    )
}

// ---------------------------------------------------------------- shader binding table

/// The triangle's pipeline and groups, for SBT and launch cases.
struct Linked {
    raygen: ProgramGroup,
    miss: ProgramGroup,
    hit: ProgramGroup,
    pipeline: Pipeline<Params>,
}

fn linked(ctx: &Context) -> anyhow::Result<Linked> {
    let p = triangle::Programs::rust(ctx)?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&p.raygen, &p.miss, &p.hit], LinkOptions::default())?;
    Ok(Linked { raygen: p.raygen, miss: p.miss, hit: p.hit, pipeline })
}

#[test]
fn sbt_without_a_raygen_record() -> anyhow::Result<()> {
    case(
        "sbt_without_a_raygen_record",
        &["no raygen record", "Sbt::builder(..).raygen(..)"],
        |ctx| {
            let l = linked(ctx)?;
            refused(
                Sbt::builder(&l.pipeline).miss(&l.miss, MissData { bg_color: BG_COLOR }).hit(&l.hit, ()).build(),
                "an SBT without raygen",
            )
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::Missing { region: raykit::SbtRegion::Raygen })),
    )
}

#[test]
fn sbt_record_of_the_wrong_kind_of_group() -> anyhow::Result<()> {
    case(
        "sbt_record_of_the_wrong_kind_of_group",
        &["SBT raygen record needs a raygen program group, got a miss group"],
        |ctx| {
            let l = linked(ctx)?;
            refused(Sbt::builder(&l.pipeline).raygen(&l.miss, ()).build(), "a miss group as raygen record")
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::GroupKind { region: raykit::SbtRegion::Raygen, .. })),
    )
}

#[test]
fn sbt_record_of_a_group_not_in_the_pipeline() -> anyhow::Result<()> {
    case(
        "sbt_record_of_a_group_not_in_the_pipeline",
        &["not part of the pipeline", "add it to Pipeline::new"],
        |ctx| {
            let l = linked(ctx)?;
            // The same entry point, but a group the pipeline was not linked with.
            let stranger = ProgramGroup::miss(&triangle_module(ctx)?, triangle_device::MS)?;
            refused(
                Sbt::builder(&l.pipeline)
                    .raygen(&l.raygen, ())
                    .miss(&stranger, MissData { bg_color: BG_COLOR })
                    .build(),
                "a foreign group",
            )
        },
        |e| matches!(e, Error::Link(raykit::LinkError::GroupNotInPipeline { kind: raykit::GroupKind::Miss })),
    )
}

/// 64 KiB of record data.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct HugeRecord([[u32; 4096]; 4]);

#[test]
fn sbt_record_data_too_large() -> anyhow::Result<()> {
    case(
        "sbt_record_data_too_large",
        &["SBT record data of 65536 bytes", "maxShaderGroupStride", "`Buffer<T>`"],
        |ctx| {
            anyhow::ensure!(ctx.limits().max_shader_group_stride < 65536, "this device allows 64 KiB records");
            let l = linked(ctx)?;
            let huge: HugeRecord = bytemuck::Zeroable::zeroed();
            let bg = MissData { bg_color: BG_COLOR };
            let builder = Sbt::builder(&l.pipeline).raygen(&l.raygen, ()).miss(&l.miss, bg);
            refused(builder.hit(&l.hit, huge).build(), "a 64 KiB record")
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::RecordTooLarge { size: 65536, .. })),
    )
}

/// A ray type the triangle's programs never trace: hit records at offset 2 of a
/// stride of 3, miss index 1.
struct Ghost;
impl raykit::device::RayType for Ghost {
    type Payload = Vec3;
    const SBT_OFFSET: u32 = 2;
    const SBT_STRIDE: u32 = 3;
    const MISS_INDEX: u32 = 1;
}

#[test]
fn hit_record_for_a_ray_type_the_sbt_does_not_have() -> anyhow::Result<()> {
    // raykit cannot know which ray types the programs trace; what it refuses is
    // the SBT this leaves: slot 1 (the radiance ray's second slot) is empty while
    // slot 2 is filled, so a trace reaching slot 1 would read garbage.
    case(
        "hit_record_for_a_ray_type_the_sbt_does_not_have",
        &["SBT hit slot 1 is empty", "every slot a trace can reach needs a record", "hit_at(1, ..)"],
        |ctx| {
            let l = linked(ctx)?;
            let builder =
                Sbt::builder(&l.pipeline).raygen(&l.raygen, ()).miss(&l.miss, MissData { bg_color: BG_COLOR });
            refused(builder.hit(&l.hit, ()).hit_at(2, &l.hit, ()).build(), "a ghost ray type's hit record")
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::Hole { region: raykit::SbtRegion::Hit, index: 1 })),
    )
}

#[test]
fn two_records_in_one_sbt_slot() -> anyhow::Result<()> {
    case(
        "two_records_in_one_sbt_slot",
        &["SBT miss slot 0 already holds a record", "MISS_INDEX"],
        |ctx| {
            let l = linked(ctx)?;
            let bg = MissData { bg_color: BG_COLOR };
            let builder = Sbt::builder(&l.pipeline).raygen(&l.raygen, ()).miss(&l.miss, bg).hit(&l.hit, ());
            refused(builder.miss_for::<triangle_device::Radiance, _>(&l.miss, bg).build(), "two radiance miss records")
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::SlotTaken { region: raykit::SbtRegion::Miss, index: 0 })),
    )
}

#[test]
fn launch_with_the_sbt_of_another_pipeline() -> anyhow::Result<()> {
    case(
        "launch_with_the_sbt_of_another_pipeline",
        &["the SBT was built for another pipeline", "Sbt::builder(&pipeline)"],
        |ctx| {
            let a = linked(ctx)?;
            let b = linked(ctx)?;
            let sbt = Sbt::builder(&b.pipeline)
                .raygen(&b.raygen, ())
                .miss(&b.miss, MissData { bg_color: BG_COLOR })
                .hit(&b.hit, ())
                .build()?;
            let image = ctx.buffer::<u32>(1)?;
            let params = triangle::params(1, 1, image.handle(), raykit::Traversable::NULL);
            refused(a.pipeline.launch(&sbt, &params, [1, 1, 1]), "another pipeline's SBT")
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::OfAnotherPipeline)),
    )
}

// ---------------------------------------------------------------- the SBT fits the scene
// On both backends: the CPU backend checks the scene against the SBT as Vulkan
// launches do, from the ray types the programs were declared for.

/// The triangle's GAS with a second copy of the triangle out of view (x + 10):
/// two geometries, so an instance spans two hit records.
fn two_geometry_gas(ctx: &Context) -> anyhow::Result<Gas> {
    let far = triangle::VERTICES.map(|v| v + Vec3::new(10.0, 0.0, 0.0));
    Ok(Gas::builder().triangles(Triangles::new(&triangle::VERTICES)).triangles(Triangles::new(&far)).build(ctx)?)
}

/// Renders the triangle pipeline at 16 × 16 over `ias` with an SBT of
/// `hit_records` hit records (all the triangle's hit group).
fn render_scene(ctx: &Context, l: &Linked, ias: &Ias, hit_records: usize) -> anyhow::Result<raykit::Result<Vec<u32>>> {
    let mut builder = Sbt::builder(&l.pipeline).raygen(&l.raygen, ()).miss(&l.miss, MissData { bg_color: BG_COLOR });
    for i in 0..hit_records {
        builder = builder.hit_at(i, &l.hit, ());
    }
    let sbt = builder.build()?;
    let image = ctx.buffer::<u32>(256)?;
    let params = triangle::params(16, 16, image.handle(), ias.handle());
    Ok(l.pipeline.launch(&sbt, &params, [16, 16, 1]).and_then(|()| image.read()))
}

#[test]
fn instance_sbt_offset_past_the_hit_records() -> anyhow::Result<()> {
    case(
        "instance_sbt_offset_past_the_hit_records",
        &[
            "instance 0 of the IAS in params field `handle` (SBT offset 1, 1 geometry) reaches hit record 1",
            "the SBT has 1 hit record(s)",
            "records up to index 1",
            "lower the instance's sbt_offset",
        ],
        |ctx| {
            let l = linked(ctx)?;
            let gas = Gas::triangles(ctx, &triangle::VERTICES, None)?;
            let ias = Ias::new(ctx, &[Instance::new(&gas).sbt_offset(1)])?;
            refused(render_scene(ctx, &l, &ias, 1)?, "an instance past the SBT")
        },
        |e| {
            matches!(
                e,
                Error::Launch(raykit::LaunchError::SbtTooSmallForScene {
                    instance: 0,
                    sbt_offset: 1,
                    geometries: 1,
                    slot: 1,
                    hit_records: 1,
                    ..
                })
            )
        },
    )
}

#[test]
fn instance_geometries_past_the_hit_records() -> anyhow::Result<()> {
    // Instance 1's first geometry takes record 1, the last one; its second
    // geometry would read record 2.
    case(
        "instance_geometries_past_the_hit_records",
        &["instance 1", "(SBT offset 1, 2 geometries) reaches hit record 2 = 1 + (2 - 1) × stride 1 + ray offset 0"],
        |ctx| {
            let l = linked(ctx)?;
            let gas = two_geometry_gas(ctx)?;
            let small = Gas::triangles(ctx, &triangle::VERTICES, None)?;
            let ias = Ias::new(ctx, &[Instance::new(&small), Instance::new(&gas).sbt_offset(1)])?;
            refused(render_scene(ctx, &l, &ias, 2)?, "a second geometry past the SBT")
        },
        |e| {
            matches!(
                e,
                Error::Launch(raykit::LaunchError::SbtTooSmallForScene {
                    instance: 1,
                    sbt_offset: 1,
                    geometries: 2,
                    slot: 2,
                    hit_records: 2,
                    stride: 1,
                    ray_offset: 0,
                    ..
                })
            )
        },
    )
}

#[test]
fn instance_updated_past_the_hit_records() -> anyhow::Result<()> {
    case(
        "instance_updated_past_the_hit_records",
        &["reaches hit record 4", "the SBT has 2 hit record(s)"],
        |ctx| {
            let l = linked(ctx)?;
            let gas = Gas::triangles(ctx, &triangle::VERTICES, None)?;
            let options = BuildOptions::default().allow_update(true);
            let mut ias = Ias::builder(&[Instance::new(&gas)]).options(options).build(ctx)?;
            let before = render_scene(ctx, &l, &ias, 2)??;
            anyhow::ensure!(before == triangle::render(ctx, 16, 16)?, "the scene within the SBT renders differently");
            ias.update(&[Instance::new(&gas).sbt_offset(4)])?;
            refused(render_scene(ctx, &l, &ias, 2)?, "an instance updated past the SBT")
        },
        |e| {
            matches!(
                e,
                Error::Launch(raykit::LaunchError::SbtTooSmallForScene { instance: 0, slot: 4, hit_records: 2, .. })
            )
        },
    )
}

#[test]
fn scene_whose_instances_fill_the_hit_records_exactly_renders() -> anyhow::Result<()> {
    raykit_tests::with_each_backend("scene_whose_instances_fill_the_hit_records_exactly_renders", |ctx, _| {
        let l = linked(ctx)?;
        let gas = two_geometry_gas(ctx)?;
        // The last instance's last geometry selects record 2 + (2 - 1) = 3, the
        // SBT's last; the masked-out instance would select record 9 but is never hit.
        let ias = Ias::new(
            ctx,
            &[Instance::new(&gas), Instance::new(&gas).sbt_offset(2), Instance::new(&gas).sbt_offset(8).mask(0)],
        )?;
        assert_eq!(ias.hit_records_for::<triangle_device::Radiance>(), 4);
        let got = render_scene(ctx, &l, &ias, 4)??;
        // The far copies are out of view: the optixTriangle picture, pixel for pixel.
        let reference = triangle::render(ctx, 16, 16)?;
        assert!(got == reference, "the scene renders differently from optixTriangle");
        assert!(matches!(
            render_scene(ctx, &l, &ias, 3)?,
            Err(Error::Launch(raykit::LaunchError::SbtTooSmallForScene { slot: 3, instance: 1, .. }))
        ));
        Ok(())
    })
}

// ---------------------------------------------------------------- recursion on the device

#[test]
fn recursion_past_max_trace_depth() -> anyhow::Result<()> {
    // Two layers over the whole view: the closest-hit of the second, at depth 2,
    // traces on regardless; the device refuses that trace at every pixel.
    case(
        "recursion_past_max_trace_depth",
        &[
            "16 trace(s) would have gone to depth 3, past the pipeline's max_trace_depth 2",
            "were not made",
            "raise LinkOptions::max_trace_depth",
        ],
        |ctx| {
            use stack_test_device as stack;
            let module = Module::from_device_crate(ctx, "stack-test-device")?;
            let raygen = ProgramGroup::raygen(&module, stack::RG_UNBOUNDED)?;
            let miss = ProgramGroup::miss(&module, stack::MS_UNBOUNDED)?;
            let hit = ProgramGroup::hit_group(&module).closest_hit(stack::UNBOUNDED_HIT).build()?;
            let pipeline =
                Pipeline::<stack::Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 2 })?;
            let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(&hit, ()).build()?;
            let vertices: Vec<Vec3> = [5.0, 4.0]
                .iter()
                .flat_map(|&z| {
                    let (a, b, c, d) = (
                        Vec3::new(-2.0, -2.0, z),
                        Vec3::new(2.0, -2.0, z),
                        Vec3::new(2.0, 2.0, z),
                        Vec3::new(-2.0, 2.0, z),
                    );
                    [a, b, c, a, c, d]
                })
                .collect();
            let gas = Gas::triangles(ctx, &vertices, None)?;
            let ias = Ias::single(ctx, &gas)?;
            let image = ctx.buffer::<u32>(16)?;
            let params = stack::Params {
                image: image.handle(),
                _pad: 0,
                size: raykit::glam::UVec2::splat(4),
                scene: ias.handle(),
            };
            let err = refused(pipeline.launch(&sbt, &params, [4, 4, 1]), "a recursion past max_trace_depth")?;
            if let Error::Launch(raykit::LaunchError::RecursionTooDeep { launch_indices, .. }) = &err {
                let mut got = launch_indices.clone();
                got.sort_unstable();
                let every: Vec<[u32; 3]> = (0..4).flat_map(|x| (0..4).map(move |y| [x, y, 0])).collect();
                anyhow::ensure!(got == every, "refused at {got:?}, not at every pixel");
            }
            Ok(err)
        },
        |e| {
            matches!(
                e,
                Error::Launch(raykit::LaunchError::RecursionTooDeep {
                    max_trace_depth: 2,
                    depth: 3,
                    refused: 16,
                    total: 16,
                    ..
                })
            )
        },
    )
}

// ---------------------------------------------------------------- launches

/// Launches the triangle pipeline over `dims` (nothing is traced when refused).
fn launch(ctx: &Context, dims: [u32; 3]) -> anyhow::Result<raykit::Result<()>> {
    let l = linked(ctx)?;
    let sbt = Sbt::builder(&l.pipeline)
        .raygen(&l.raygen, ())
        .miss(&l.miss, MissData { bg_color: BG_COLOR })
        .hit(&l.hit, ())
        .build()?;
    let image = ctx.buffer::<u32>(1)?;
    let params = triangle::params(1, 1, image.handle(), raykit::Traversable::NULL);
    Ok(l.pipeline.launch(&sbt, &params, dims))
}

#[test]
fn launch_with_a_zero_dimension() -> anyhow::Result<()> {
    case(
        "launch_with_a_zero_dimension",
        &["every dimension must be at least 1"],
        |ctx| {
            for dims in [[0, 1, 1], [1, 0, 1], [1, 1, 0], [0, 0, 0]] {
                let err = refused(launch(ctx, dims)?, "a zero dimension")?;
                anyhow::ensure!(
                    matches!(err, Error::Launch(raykit::LaunchError::Dimensions { dims: d, .. }) if d == dims),
                    "{err:?}"
                );
            }
            refused(launch(ctx, [16, 0, 1])?, "a zero height")
        },
        |e| matches!(e, Error::Launch(raykit::LaunchError::Dimensions { .. })),
    )
}

#[test]
fn launch_over_max_ray_dispatch_invocation_count() -> anyhow::Result<()> {
    case(
        "launch_over_max_ray_dispatch_invocation_count",
        &["invocations exceed maxRayDispatchInvocationCount", "split the launch into tiles"],
        |ctx| {
            // Each dimension within its own limit, the product over the total.
            let max = ctx.max_launch_dimensions();
            let total = ctx.limits().max_ray_dispatch_invocation_count as u64;
            let side = ((total as f64).sqrt() as u64 + 1).min(max[0]).min(max[1]);
            anyhow::ensure!(side * side > total, "cannot exceed {total} invocations within {max:?}");
            refused(launch(ctx, [side as u32, side as u32, 1])?, "too many invocations")
        },
        |e| matches!(e, Error::Launch(raykit::LaunchError::Dimensions { .. })),
    )
}

#[test]
fn launch_whose_invocation_count_overflows_64_bits() -> anyhow::Result<()> {
    // (2^32 - 1)^3 does not fit in a u64: raykit used to overflow here (a panic in
    // debug builds; in release, a product that wraps can look small).
    case(
        "launch_whose_invocation_count_overflows_64_bits",
        &["more than 2^64 invocations exceed maxRayDispatchInvocationCount"],
        |ctx| refused(launch(ctx, [u32::MAX; 3])?, "2^96 invocations"),
        |e| matches!(e, Error::Launch(raykit::LaunchError::Dimensions { .. })),
    )
}

#[test]
fn launch_wider_than_the_device_allows() -> anyhow::Result<()> {
    // Within maxRayDispatchInvocationCount in total, but wider than
    // maxComputeWorkGroupCount[0] × maxComputeWorkGroupSize[0]: raykit used to pass
    // this to vkCmdTraceRaysKHR (VUID-vkCmdTraceRaysKHR-width-03638).
    vulkan_case(
        "the CPU backend's per-dimension launch limits equal its total (2^30): no launch passes one without the other",
        "launch_wider_than_the_device_allows",
        &["maxComputeWorkGroupCount[", "split the launch into tiles"],
        |ctx| {
            // The first dimension whose own limit is below the total and fits a u32
            // (lavapipe: width; NVIDIA: height, its width limit being 2^31 × 1024).
            let total = ctx.limits().max_ray_dispatch_invocation_count as u64;
            let limits = ctx.max_launch_dimensions();
            let Some(axis) = (0..3).find(|&i| limits[i] < total && limits[i] < u32::MAX as u64) else {
                anyhow::bail!("every per-dimension limit of this device is at or above its total {total}: {limits:?}");
            };
            let mut dims = [1u32; 3];
            dims[axis] = (limits[axis] + 1) as u32;
            refused(launch(ctx, dims)?, "a launch wider than the device allows")
        },
        |e| matches!(e, Error::Launch(raykit::LaunchError::Dimensions { .. })),
    )
}

// ---------------------------------------------------------------- geometry

const TRI: [Vec3; 3] = triangle::VERTICES;

#[test]
fn gas_with_zero_primitives() -> anyhow::Result<()> {
    case(
        "gas_with_zero_primitives",
        &["at least one triangle"],
        |ctx| refused(Gas::triangles(ctx, &[], None), "a GAS without triangles"),
        |e| matches!(e, Error::Accel(raykit::AccelError::Empty { .. })),
    )
}

#[test]
fn gas_with_an_empty_index_list() -> anyhow::Result<()> {
    case(
        "gas_with_an_empty_index_list",
        &["at least one triangle"],
        |ctx| refused(Gas::triangles(ctx, &TRI, Some(&[])), "an empty index list"),
        |e| matches!(e, Error::Accel(raykit::AccelError::Empty { .. })),
    )
}

#[test]
fn gas_with_indices_out_of_range() -> anyhow::Result<()> {
    case(
        "gas_with_indices_out_of_range",
        &["index 2 is 3, but the geometry has 3 vertices", "fix the index buffer"],
        |ctx| refused(Gas::triangles(ctx, &TRI, Some(&[0, 1, 3])), "index 3 of 3 vertices"),
        |e| {
            matches!(
                e,
                Error::Accel(raykit::AccelError::IndexOutOfRange { position: 2, index: 3, vertex_count: 3, .. })
            )
        },
    )
}

#[test]
fn gas_with_non_finite_vertices() -> anyhow::Result<()> {
    case(
        "gas_with_non_finite_vertices",
        &["vertex 1 is not finite", "finite positions"],
        |ctx| {
            let nan = refused(Gas::triangles(ctx, &[TRI[0], TRI[1], Vec3::new(f32::NAN, 0.0, 0.0)], None), "a NaN")?;
            anyhow::ensure!(
                matches!(nan, Error::Accel(raykit::AccelError::NonFiniteVertex { vertex: 2, .. })),
                "{nan:?}"
            );
            refused(Gas::triangles(ctx, &[TRI[0], Vec3::new(0.0, f32::INFINITY, 0.0), TRI[2]], None), "an infinity")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::NonFiniteVertex { vertex: 1, .. })),
    )
}

#[test]
fn gas_with_an_index_list_that_is_not_whole_triangles() -> anyhow::Result<()> {
    case(
        "gas_with_an_index_list_that_is_not_whole_triangles",
        &["4 indices is not a multiple of 3", "each triangle takes three"],
        |ctx| refused(Gas::triangles(ctx, &TRI, Some(&[0, 1, 2, 0])), "four indices"),
        |e| matches!(e, Error::Accel(raykit::AccelError::TriangleCount { count: 4, .. })),
    )
}

#[test]
fn gas_with_a_vertex_list_that_is_not_whole_triangles() -> anyhow::Result<()> {
    case(
        "gas_with_a_vertex_list_that_is_not_whole_triangles",
        &["2 vertices without indices is not a multiple of 3"],
        |ctx| refused(Gas::triangles(ctx, &TRI[..2], None), "two vertices"),
        |e| matches!(e, Error::Accel(raykit::AccelError::TriangleCount { count: 2, .. })),
    )
}

#[test]
fn gas_with_a_misaligned_vertex_stride() -> anyhow::Result<()> {
    case(
        "gas_with_a_misaligned_vertex_stride",
        &["vertex stride of 14 bytes must be a multiple of 4 and at least 12", "pad the struct"],
        |ctx| {
            let bytes = [0u8; 14 * 3];
            // Too short a stride is refused the same way.
            let short = refused(Gas::builder().triangles(Triangles::strided(&bytes, 8, 3)).build(ctx), "stride 8")?;
            anyhow::ensure!(
                matches!(short, Error::Accel(raykit::AccelError::MisalignedStride { stride: 8, .. })),
                "{short:?}"
            );
            refused(Gas::builder().triangles(Triangles::strided(&bytes, 14, 3)).build(ctx), "stride 14")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::MisalignedStride { stride: 14, alignment: 4, min: 12, .. })),
    )
}

#[test]
fn gas_with_fewer_vertex_bytes_than_count_and_stride_need() -> anyhow::Result<()> {
    case(
        "gas_with_fewer_vertex_bytes_than_count_and_stride_need",
        &["vertex data of 24 bytes is too short", "need 36"],
        |ctx| {
            let bytes: &[u8] = bytemuck::cast_slice(&TRI[..2]);
            refused(
                Gas::builder().triangles(Triangles::strided(bytes, 12, 3)).build(ctx),
                "two vertices' bytes for three",
            )
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::InputTooShort { needed: 36, len: 24, .. })),
    )
}

#[test]
fn refit_with_a_changed_topology() -> anyhow::Result<()> {
    case(
        "refit_with_a_changed_topology",
        &["cannot update (refit) this GAS", "use rebuild instead"],
        |ctx| {
            let six = [TRI, TRI].concat();
            // Built without allowing updates: refused as well.
            let mut fixed = Gas::triangles(ctx, &TRI, None)?;
            let err = refused(fixed.update(&[Triangles::new(&TRI).into()]), "a refit without allow_update")?;
            anyhow::ensure!(matches!(err, Error::Accel(raykit::AccelError::UpdateRefused { .. })), "{err:?}");
            let options = BuildOptions::default().allow_update(true);
            let mut gas = Gas::builder().triangles(Triangles::new(&TRI)).options(options).build(ctx)?;
            // Same topology, moved vertices: accepted.
            let moved = TRI.map(|v| v + Vec3::new(0.0, 0.0, 0.1));
            gas.update(&[Triangles::new(&moved).into()])?;
            refused(gas.update(&[Triangles::new(&six).into()]), "a refit to twice the triangles")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::UpdateRefused { what: "GAS", .. })),
    )
}

#[test]
fn ias_without_instances() -> anyhow::Result<()> {
    case(
        "ias_without_instances",
        &["give at least one triangle, AABB or instance"],
        |ctx| refused(Ias::new(ctx, &[]), "an empty IAS"),
        |e| matches!(e, Error::Accel(raykit::AccelError::Empty { .. })),
    )
}

#[test]
fn ias_instance_fields_over_24_bits() -> anyhow::Result<()> {
    case(
        "ias_instance_fields_over_24_bits",
        &["instance 1: sbt_offset is 4294967295, over its 24-bit maximum"],
        |ctx| {
            let gas = Gas::triangles(ctx, &TRI, None)?;
            let bad = Instance::new(&gas).custom_index(1 << 24);
            let err = refused(Ias::new(ctx, &[Instance::new(&gas), bad]), "a 25-bit custom index")?;
            anyhow::ensure!(
                matches!(err, Error::Accel(raykit::AccelError::InstanceField { instance: 1, .. })),
                "{err:?}"
            );
            let bad = Instance::new(&gas).sbt_offset(u32::MAX);
            refused(Ias::new(ctx, &[Instance::new(&gas), bad]), "a 32-bit SBT offset")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::InstanceField { instance: 1, .. })),
    )
}

#[test]
fn ias_instance_with_a_non_finite_transform() -> anyhow::Result<()> {
    case(
        "ias_instance_with_a_non_finite_transform",
        &["not finite", "give a finite affine transform"],
        |ctx| {
            let gas = Gas::triangles(ctx, &TRI, None)?;
            let transform = Affine3A::from_translation(Vec3::new(0.0, f32::NAN, 0.0));
            refused(Ias::new(ctx, &[Instance::new(&gas).transform(transform)]), "a NaN translation")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::NonFiniteTransform { .. })),
    )
}

#[test]
fn ias_instancing_a_gas_of_another_context() -> anyhow::Result<()> {
    case(
        "ias_instancing_a_gas_of_another_context",
        &["different Contexts", "GASes of an IAS"],
        |ctx| {
            with_second_context(|other| refused(Ias::single(ctx, &Gas::triangles(other, &TRI, None)?), "a foreign GAS"))
        },
        |e| matches!(e, Error::Device(raykit::DeviceError::ContextMismatch)),
    )
}

/// An instance cannot reference a destroyed GAS: the `Ias` owns its `Gas`es.
/// Dropping every handle to the GAS before the launch still renders it.
#[test]
fn instance_of_a_dropped_gas_handle_still_renders() -> anyhow::Result<()> {
    with_context("instance_of_a_dropped_gas_handle_still_renders", |ctx| {
        let l = linked(ctx)?;
        let sbt = Sbt::builder(&l.pipeline)
            .raygen(&l.raygen, ())
            .miss(&l.miss, MissData { bg_color: BG_COLOR })
            .hit(&l.hit, ())
            .build()?;
        let gas = Gas::triangles(ctx, &TRI, None)?;
        let scene = Ias::single(ctx, &gas)?;
        drop(gas);
        let image = ctx.buffer::<u32>(256)?;
        l.pipeline.launch(&sbt, &triangle::params(16, 16, image.handle(), scene.handle()), [16, 16, 1])?;
        let pixels = image.read()?;
        let bg = make_color(BG_COLOR);
        anyhow::ensure!(
            pixels[0] == bg && pixels[8 * 16 + 8] != bg,
            "the triangle is gone once its Gas handle was dropped"
        );
        Ok(())
    })
}

// ---------------------------------------------------------------- context and memory

#[test]
fn no_device_matches_the_requested_name() -> anyhow::Result<()> {
    vulkan_case(
        "the name picks among Vulkan devices; the CPU backend is one device of its own",
        "no_device_matches_the_requested_name",
        &["no Vulkan device with ray-tracing pipelines", "a name containing \"no such device\"", "mesa-vulkan-drivers"],
        |ctx| {
            let options =
                ContextOptions { device_name_contains: Some("no such device".to_owned()), ..Default::default() };
            let err = refused(Context::new(options), "a device name nothing has")?;
            // The message lists every device seen, the usable one included.
            anyhow::ensure!(err.to_string().contains(ctx.device_name().as_ref()), "{err}");
            Ok(err)
        },
        |e| matches!(e, Error::Device(raykit::DeviceError::NoRayTracingDevice { devices }) if !devices.is_empty()),
    )
}

#[test]
fn buffer_of_zero_elements() -> anyhow::Result<()> {
    case(
        "buffer_of_zero_elements",
        &["buffer of 0 elements", "at least one element"],
        |ctx| refused(ctx.buffer::<u32>(0), "an empty buffer"),
        |e| matches!(e, Error::Resource(raykit::ResourceError::BufferSize { len: 0, .. })),
    )
}

#[test]
fn buffer_whose_size_overflows() -> anyhow::Result<()> {
    case(
        "buffer_whose_size_overflows",
        &["overflows 64 bits"],
        |ctx| refused(ctx.buffer::<u32>(usize::MAX), "usize::MAX elements"),
        |e| matches!(e, Error::Resource(raykit::ResourceError::BufferSize { .. })),
    )
}

#[test]
fn buffer_write_longer_than_the_buffer() -> anyhow::Result<()> {
    case(
        "buffer_write_longer_than_the_buffer",
        &["more elements than the buffer holds"],
        |ctx| {
            let mut buffer = ctx.buffer::<u32>(4)?;
            refused(buffer.write(&[1, 2, 3, 4, 5]), "five elements into four")
        },
        |e| matches!(e, Error::Resource(raykit::ResourceError::BufferSize { len: 5, .. })),
    )
}

#[test]
fn buffer_larger_than_device_memory() -> anyhow::Result<()> {
    // 4 TiB: over any device's maxStorageBufferRange (a u32), so refused before
    // the allocator is asked.
    case(
        "buffer_larger_than_device_memory",
        &["a buffer of 4398046511104 bytes", "maxStorageBufferRange", "split the data"],
        |ctx| refused(ctx.buffer::<u32>(1 << 40), "a 4 TiB buffer"),
        |e| matches!(e, Error::Resource(raykit::ResourceError::BufferTooLarge { bytes: 4_398_046_511_104, .. })),
    )
}

#[test]
fn more_live_buffers_than_the_buffer_table_holds() -> anyhow::Result<()> {
    case(
        "more_live_buffers_than_the_buffer_table_holds",
        &["the buffer table is full", "drop buffers that are no longer needed"],
        |ctx| {
            let mut live = Vec::new();
            let err = loop {
                match ctx.buffer::<u32>(1) {
                    Ok(b) => live.push(b),
                    Err(e) => break e,
                }
                anyhow::ensure!(live.len() <= 1 << 20, "a million buffers and the table is not full");
            };
            anyhow::ensure!(
                matches!(err, Error::Resource(raykit::ResourceError::BufferTableFull { capacity }) if capacity as usize == live.len()),
                "{err:?}"
            );
            // Freeing one slot makes room again.
            live.pop();
            live.push(ctx.buffer::<u32>(1)?);
            let err = refused(ctx.buffer::<u32>(1), "one buffer more than the table holds")?;
            drop(live);
            Ok(err)
        },
        |e| matches!(e, Error::Resource(raykit::ResourceError::BufferTableFull { .. })),
    )
}

// ---------------------------------------------------------------------------
// Inputs that used to crash the driver or raykit itself. Each runs in a child
// process (this test binary again, with only that test, selected by
// `RAYKIT_BAD_INPUT_CHILD`), so a regression fails the test instead of killing
// the whole test binary; a child that hangs is killed after `CHILD_TIMEOUT`.

/// Names the test a child process runs.
const CHILD_VAR: &str = "RAYKIT_BAD_INPUT_CHILD";
const CHILD_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(300);

/// Runs `body` in a child process: test `name` of this binary, alone.
fn in_child(name: &str, body: impl FnOnce() -> anyhow::Result<()>) -> anyhow::Result<()> {
    if std::env::var(CHILD_VAR).is_ok_and(|c| c == name) {
        return body();
    }
    use std::io::Read;
    let mut child = std::process::Command::new(std::env::current_exe()?)
        .args([name, "--exact", "--test-threads=1", "--nocapture"])
        .env(CHILD_VAR, name)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()?;
    // Read on threads while the child runs, so that a child writing more than
    // a pipe holds (backtraces of its panics) does not block on it.
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut text = String::new();
            if let Some(mut pipe) = pipe {
                let _ = pipe.read_to_string(&mut text);
            }
            text
        })
    };
    let out = drain(child.stdout.take().map(|o| Box::new(o) as Box<dyn Read + Send>));
    let err = drain(child.stderr.take().map(|e| Box::new(e) as Box<dyn Read + Send>));
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break status;
        }
        if start.elapsed() > CHILD_TIMEOUT {
            child.kill()?;
            child.wait()?;
            anyhow::bail!("{name}: the child process hung for {CHILD_TIMEOUT:?} and was killed");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let joined = |reader: std::thread::JoinHandle<String>| reader.join().unwrap_or_default();
    let (out, err) = (joined(out), joined(err));
    anyhow::ensure!(status.success(), "{name}: the child process failed ({status}):\n{out}\n{err}");
    anyhow::ensure!(out.contains("1 passed"), "{name}: the child process ran no test:\n{out}\n{err}");
    Ok(())
}

/// An SBT of the triangle's pipeline with `edit` applied to a builder that has
/// the raygen record.
fn triangle_sbt(
    ctx: &Context,
    edit: impl for<'a> FnOnce(raykit::SbtBuilder<'a, Params>, &'a Linked) -> raykit::SbtBuilder<'a, Params>,
) -> anyhow::Result<Error> {
    let l = linked(ctx)?;
    let builder = Sbt::builder(&l.pipeline).raygen(&l.raygen, ());
    let result = edit(builder, &l).build();
    refused(result, "the SBT")
}

#[test]
fn sbt_without_a_miss_record_for_a_pipeline_that_traces() -> anyhow::Result<()> {
    in_child("sbt_without_a_miss_record_for_a_pipeline_that_traces", || {
        case(
            "sbt_without_a_miss_record_for_a_pipeline_that_traces",
            &["0 miss record(s)", "`__raygen__rg`", "miss_at(0, ..)"],
            |ctx| triangle_sbt(ctx, |b, l| b.hit(&l.hit, ())),
            |e| {
                matches!(
                    e,
                    Error::Sbt(raykit::SbtError::Incomplete {
                        region: raykit::SbtRegion::Miss,
                        needed: 1,
                        have: 0,
                        ..
                    })
                )
            },
        )
    })
}

#[test]
fn sbt_without_a_hit_record_for_a_pipeline_with_hit_groups() -> anyhow::Result<()> {
    in_child("sbt_without_a_hit_record_for_a_pipeline_with_hit_groups", || {
        case(
            "sbt_without_a_hit_record_for_a_pipeline_with_hit_groups",
            &["0 hit record(s)", "hit_at(0, ..)"],
            |ctx| triangle_sbt(ctx, |b, l| b.miss(&l.miss, MissData { bg_color: BG_COLOR })),
            |e| {
                matches!(
                    e,
                    Error::Sbt(raykit::SbtError::Incomplete { region: raykit::SbtRegion::Hit, needed: 1, have: 0, .. })
                )
            },
        )
    })
}

#[test]
fn hit_at_usize_max() -> anyhow::Result<()> {
    in_child("hit_at_usize_max", || {
        case(
            "hit_at_usize_max",
            &[&format!("SBT hit index {} is out of range", usize::MAX), "at most 16777216", "24 bits"],
            |ctx| {
                triangle_sbt(ctx, |b, l| {
                    b.miss(&l.miss, MissData { bg_color: BG_COLOR }).hit_at(usize::MAX, &l.hit, ())
                })
            },
            |e| {
                matches!(
                    e,
                    Error::Sbt(raykit::SbtError::IndexOutOfRange {
                        region: raykit::SbtRegion::Hit,
                        limit: 16_777_216,
                        ..
                    })
                )
            },
        )
    })
}

#[test]
fn hit_for_a_huge_geometry_index() -> anyhow::Result<()> {
    in_child("hit_for_a_huge_geometry_index", || {
        case(
            "hit_for_a_huge_geometry_index",
            &["geometry × SBT_STRIDE + SBT_OFFSET", "out of range"],
            |ctx| {
                // An empty hit group: it fits any ray type.
                let empty = ProgramGroup::hit_group(&triangle_module(ctx)?).build()?;
                triangle_sbt(ctx, |b, l| {
                    b.miss(&l.miss, MissData { bg_color: BG_COLOR }).hit_for::<Ghost, _>(usize::MAX / 2, &empty, ())
                })
            },
            |e| matches!(e, Error::Sbt(raykit::SbtError::IndexOutOfRange { region: raykit::SbtRegion::Hit, .. })),
        )
    })
}

#[test]
fn miss_at_two_to_the_forty() -> anyhow::Result<()> {
    in_child("miss_at_two_to_the_forty", || {
        case(
            "miss_at_two_to_the_forty",
            &["SBT miss index 1099511627776 is out of range", "at most 65536", "16 bits"],
            |ctx| {
                triangle_sbt(ctx, |b, l| b.miss_at(1 << 40, &l.miss, MissData { bg_color: BG_COLOR }).hit(&l.hit, ()))
            },
            |e| {
                matches!(
                    e,
                    Error::Sbt(raykit::SbtError::IndexOutOfRange { region: raykit::SbtRegion::Miss, limit: 65536, .. })
                )
            },
        )
    })
}

#[test]
fn miss_index_just_past_sixteen_bits() -> anyhow::Result<()> {
    case(
        "miss_index_just_past_sixteen_bits",
        &["SBT miss index 65536 is out of range"],
        |ctx| triangle_sbt(ctx, |b, l| b.miss_at(65536, &l.miss, MissData { bg_color: BG_COLOR }).hit(&l.hit, ())),
        |e| matches!(e, Error::Sbt(raykit::SbtError::IndexOutOfRange { region: raykit::SbtRegion::Miss, .. })),
    )
}

#[test]
fn hit_index_just_past_twenty_four_bits() -> anyhow::Result<()> {
    case(
        "hit_index_just_past_twenty_four_bits",
        &["SBT hit index 16777216 is out of range"],
        |ctx| triangle_sbt(ctx, |b, l| b.miss(&l.miss, MissData { bg_color: BG_COLOR }).hit_at(1 << 24, &l.hit, ())),
        |e| matches!(e, Error::Sbt(raykit::SbtError::IndexOutOfRange { region: raykit::SbtRegion::Hit, .. })),
    )
}

#[test]
fn sbt_hit_records_a_million_slots_apart() -> anyhow::Result<()> {
    // Within the limit but with a hole: refused before anything is allocated.
    case(
        "sbt_hit_records_a_million_slots_apart",
        &["SBT hit slot 1 is empty"],
        |ctx| {
            triangle_sbt(ctx, |b, l| {
                b.miss(&l.miss, MissData { bg_color: BG_COLOR }).hit(&l.hit, ()).hit_at(1 << 20, &l.hit, ())
            })
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::Hole { region: raykit::SbtRegion::Hit, index: 1 })),
    )
}

// --- SPIR-V validated before the driver sees it ---

#[test]
fn id_bound_of_two_to_the_twenty_two() -> anyhow::Result<()> {
    case(
        "id_bound_of_two_to_the_twenty_two",
        &["ID bound 4194304 is out of range 1..=4194303"],
        |ctx| {
            let mut w = words(RAYGEN_MAIN);
            w[3] = 1 << 22;
            refused(Module::new(ctx, &bytes(&w)), "ID bound 2^22")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

#[test]
fn id_bound_at_the_limit_is_accepted() -> anyhow::Result<()> {
    with_context("id_bound_at_the_limit_is_accepted", |ctx| {
        let mut w = words(RAYGEN_MAIN);
        w[3] = raykit::module::MAX_ID_BOUND;
        Module::new(ctx, &bytes(&w))?;
        still_usable(ctx)
    })
}

/// `raygen_main.rgen.spv` with the first `OpTypeVector`'s component count made 5,
/// which is well formed but invalid (vectors have 2, 3 or 4 components).
fn five_component_vector() -> Vec<u8> {
    let mut w = words(RAYGEN_MAIN);
    let mut at = 5;
    while at < w.len() {
        let count = (w[at] >> 16) as usize;
        if w[at] & 0xffff == 23 {
            // OpTypeVector %result %component count
            w[at + 3] = 5;
            break;
        }
        at += count.max(1);
    }
    bytes(&w)
}

#[test]
fn type_level_corruption_carries_the_validators_message() -> anyhow::Result<()> {
    if !raykit::validate::spirv::validator_available() {
        anyhow::bail!("no SPIR-V validator: install spirv-tools (spirv-val)");
    }
    case(
        "type_level_corruption_carries_the_validators_message",
        &["not a SPIR-V module", "spirv-val", "Illegal number of components (5)"],
        |ctx| refused(Module::new(ctx, &five_component_vector()), "a 5-component vector"),
        |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
    )
}

const PAYLOAD_SPEC_ARRAY: &[u8] = include_bytes!("../data/payload_spec_array.rgen.spv");

/// Links `payload_spec_array.rgen` (its payload array sized by spec constant 3)
/// with constant 3 set to `length`.
fn spec_array_pipeline(ctx: &Context, length: u32) -> anyhow::Result<Error> {
    let module = Module::new(ctx, PAYLOAD_SPEC_ARRAY)?;
    let raygen = ProgramGroup::raygen(&module, "main")?;
    let constants = raykit::Specialization::new().set(3, length);
    refused(
        Pipeline::<Params>::with_specialization(ctx, &[&raygen], LinkOptions::default(), &constants),
        "an array sized by a specialization constant",
    )
}

#[test]
fn spec_constant_sizing_an_array_to_zero() -> anyhow::Result<()> {
    in_child("spec_constant_sizing_an_array_to_zero", || {
        vulkan_case(
            "SPIR-V specialized for the driver: the CPU backend runs Rust, where a constant cannot size an array to 0",
            "spec_constant_sizing_an_array_to_zero",
            &["spirv-val", "OpTypeArray"],
            |ctx| spec_array_pipeline(ctx, 0),
            |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
        )
    })
}

#[test]
fn spec_constant_sizing_an_array_to_two_to_the_thirty_one() -> anyhow::Result<()> {
    in_child("spec_constant_sizing_an_array_to_two_to_the_thirty_one", || {
        vulkan_case(
            "SPIR-V specialized for the driver: the CPU backend runs Rust, where a constant cannot size a payload array",
            "spec_constant_sizing_an_array_to_two_to_the_thirty_one",
            &["sizes array type", "2147483648 elements", "`Buffer<T>`"],
            |ctx| spec_array_pipeline(ctx, 1 << 31),
            |e| matches!(e, Error::Module(raykit::ModuleError::InvalidSpirv { .. })),
        )
    })
}

// --- Trace depth ---

#[test]
fn tracing_raygen_with_max_trace_depth_zero() -> anyhow::Result<()> {
    in_child("tracing_raygen_with_max_trace_depth_zero", || {
        case(
            "tracing_raygen_with_max_trace_depth_zero",
            &["`__raygen__rg` needs a trace depth of at least 1", "max_trace_depth 0", "LinkOptions::max_trace_depth"],
            |ctx| {
                let p = triangle::Programs::rust(ctx)?;
                refused(
                    Pipeline::<Params>::new(ctx, &[&p.raygen, &p.miss, &p.hit], LinkOptions { max_trace_depth: 0 }),
                    "a tracing raygen with depth 0",
                )
            },
            |e| matches!(e, Error::Link(raykit::LinkError::TraceDepthExceeded { needed: 1, max_trace_depth: 0, .. })),
        )
    })
}

/// The stack test's programs: a closest-hit that traces again (recursion).
fn recursive_pipeline(ctx: &Context, max_trace_depth: u32) -> raykit::Result<Pipeline<stack_test_device::Params>> {
    let module = Module::from_device_crate(ctx, "stack-test-device")?;
    let raygen = ProgramGroup::raygen(&module, stack_test_device::RG)?;
    let miss = ProgramGroup::miss(&module, stack_test_device::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(stack_test_device::LAYER_HIT).build()?;
    Pipeline::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth })
}

#[test]
fn recursive_closest_hit_with_max_trace_depth_one() -> anyhow::Result<()> {
    in_child("recursive_closest_hit_with_max_trace_depth_one", || {
        case(
            "recursive_closest_hit_with_max_trace_depth_one",
            &["needs a trace depth of at least 2", "recurses", "max_trace_depth 1"],
            |ctx| refused(recursive_pipeline(ctx, 1), "a recursive closest-hit with depth 1"),
            |e| matches!(e, Error::Link(raykit::LinkError::TraceDepthExceeded { needed: 2, max_trace_depth: 1, .. })),
        )
    })
}

#[test]
fn recursive_closest_hit_with_a_declared_depth_links() -> anyhow::Result<()> {
    with_context("recursive_closest_hit_with_a_declared_depth_links", |ctx| {
        recursive_pipeline(ctx, 2)?;
        still_usable(ctx)
    })
}

// --- Descriptor bindings against raykit's pipeline layout ---

/// Links the GLSL raygen `spirv` alone, for params `Params` (push constants).
fn link_raygen(ctx: &Context, spirv: &[u8]) -> anyhow::Result<Error> {
    let module = Module::new(ctx, spirv)?;
    let raygen = ProgramGroup::raygen(&module, "main")?;
    refused(Pipeline::<Params>::new(ctx, &[&raygen], LinkOptions::default()), "the raygen")
}

#[test]
fn descriptor_at_a_set_raykit_does_not_bind() -> anyhow::Result<()> {
    in_child("descriptor_at_a_set_raykit_does_not_bind", || {
        vulkan_case(
            "a descriptor of a GLSL module: Rust programs declare none, and the CPU backend refuses SPIR-V modules",
            "descriptor_at_a_set_raykit_does_not_bind",
            &["`main` declares a storage buffer `image` at set 2, binding 0", "has no set 2", "`Buffer<T>` handles"],
            |ctx| link_raygen(ctx, include_bytes!("../data/storage_at_set_2.rgen.spv")),
            |e| matches!(e, Error::Link(raykit::LinkError::DescriptorBinding { set: 2, binding: 0, .. })),
        )
    })
}

#[test]
fn tlas_declared_where_the_buffer_table_is() -> anyhow::Result<()> {
    in_child("tlas_declared_where_the_buffer_table_is", || {
        vulkan_case(
            "a descriptor of a GLSL module: Rust programs declare none, and the CPU backend refuses SPIR-V modules",
            "tlas_declared_where_the_buffer_table_is",
            &["an acceleration structure `scene` at set 0, binding 0", "buffer table", "`Traversable`"],
            |ctx| link_raygen(ctx, include_bytes!("../data/tlas_at_set_0_binding_0.rgen.spv")),
            |e| matches!(e, Error::Link(raykit::LinkError::DescriptorBinding { set: 0, binding: 0, .. })),
        )
    })
}

#[test]
fn image_beside_the_buffer_table() -> anyhow::Result<()> {
    in_child("image_beside_the_buffer_table", || {
        vulkan_case(
            "a descriptor of a GLSL module: Rust programs declare none, and the CPU backend refuses SPIR-V modules",
            "image_beside_the_buffer_table",
            &[
                "an image or sampler `target` at set 0, binding 1",
                "where raykit binds its texture table (combined image samplers)",
            ],
            |ctx| link_raygen(ctx, include_bytes!("../data/image_at_set_0_binding_1.rgen.spv")),
            |e| matches!(e, Error::Link(raykit::LinkError::DescriptorBinding { set: 0, binding: 1, .. })),
        )
    })
}

// --- Params: what the bytes mean ---

/// The triangle's params as a host that declared `size` as `IVec2` would describe
/// them: same offsets and sizes, another kind of number.
#[repr(transparent)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
struct SizeAsSigned(Params);

const SIZE_AS_SIGNED_FIELDS: [raykit::device::FieldLayout; 8] = {
    let f = <Params as raykit::LaunchParams>::LAYOUT.fields;
    let mut out = [f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7]];
    out[1].type_name = "IVec2";
    out[1].shape =
        raykit::device::Shape::Numeric(raykit::device::Scalar { kind: raykit::device::ScalarKind::Signed, bits: 32 });
    out
};

impl raykit::LaunchParams for SizeAsSigned {
    const LAYOUT: raykit::device::ParamsLayout = raykit::device::ParamsLayout {
        name: "SizeAsSigned",
        size: <Params as raykit::LaunchParams>::LAYOUT.size,
        fields: &SIZE_AS_SIGNED_FIELDS,
    };
}

#[test]
fn params_field_of_the_same_size_but_another_kind() -> anyhow::Result<()> {
    case(
        "params_field_of_the_same_size_but_another_kind",
        &["`size`", "type IVec2", "vector of 2 × u32", "holds i32"],
        |ctx| {
            let p = triangle::Programs::rust(ctx)?;
            refused(
                Pipeline::<SizeAsSigned>::new(ctx, &[&p.raygen, &p.miss, &p.hit], LinkOptions::default()),
                "params whose size field is signed on the host",
            )
        },
        |e| matches!(e, Error::Link(raykit::LinkError::ParamsLayout(l)) if matches!(&**l, LayoutError::Mismatch { field, .. } if field == "size")),
    )
}

// --- Ray types the programs trace, read from the SPIR-V ---

/// The shadows pipeline of the program model: raygen traces `ShadowedRadiance`
/// (miss 0, hit offset 0), its closest-hit traces `Shadow` (miss 1, hit offset 1).
struct Shadows {
    raygen: ProgramGroup,
    miss: ProgramGroup,
    shadow_miss: ProgramGroup,
    shade: ProgramGroup,
    shadow_hit: ProgramGroup,
    pipeline: Pipeline<program_model_device::Params>,
}

fn shadows(ctx: &Context) -> anyhow::Result<Shadows> {
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let raygen = ProgramGroup::raygen(&module, program_model_device::RG_SHADOWS)?;
    let miss = ProgramGroup::miss(&module, program_model_device::MS_SHADOWS)?;
    let shadow_miss = ProgramGroup::miss(&module, program_model_device::MS_SHADOW)?;
    let shade = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SHADE_SHADOWED).build()?;
    let shadow_hit = ProgramGroup::hit_group(&module).closest_hit(program_model_device::SHADOW_HIT).build()?;
    let pipeline =
        Pipeline::new(ctx, &[&raygen, &miss, &shadow_miss, &shade, &shadow_hit], LinkOptions { max_trace_depth: 2 })?;
    Ok(Shadows { raygen, miss, shadow_miss, shade, shadow_hit, pipeline })
}

#[test]
fn sbt_without_the_miss_record_of_a_traced_ray_type() -> anyhow::Result<()> {
    in_child("sbt_without_the_miss_record_of_a_traced_ray_type", || {
        case(
            "sbt_without_the_miss_record_of_a_traced_ray_type",
            &["1 miss record(s)", "`__closesthit__shade_shadowed`", "miss_at(1, ..)"],
            |ctx| {
                let s = shadows(ctx)?;
                let sbt = Sbt::builder(&s.pipeline)
                    .raygen(&s.raygen, ())
                    .miss_for::<program_model_device::ShadowedRadiance, _>(&s.miss, ())
                    .hit_for::<program_model_device::ShadowedRadiance, _>(0, &s.shade, ())
                    .hit_for::<program_model_device::Shadow, _>(0, &s.shadow_hit, ());
                refused(sbt.build(), "an SBT without the shadow miss record")
            },
            |e| {
                matches!(
                    e,
                    Error::Sbt(raykit::SbtError::Incomplete {
                        region: raykit::SbtRegion::Miss,
                        needed: 2,
                        have: 1,
                        ..
                    })
                )
            },
        )
    })
}

#[test]
fn sbt_without_the_hit_record_of_a_traced_ray_type() -> anyhow::Result<()> {
    in_child("sbt_without_the_hit_record_of_a_traced_ray_type", || {
        case(
            "sbt_without_the_hit_record_of_a_traced_ray_type",
            &["1 hit record(s)", "`__closesthit__shade_shadowed`", "hit_at(1, ..)"],
            |ctx| {
                let s = shadows(ctx)?;
                let sbt = Sbt::builder(&s.pipeline)
                    .raygen(&s.raygen, ())
                    .miss_for::<program_model_device::ShadowedRadiance, _>(&s.miss, ())
                    .miss_for::<program_model_device::Shadow, _>(&s.shadow_miss, ())
                    .hit_for::<program_model_device::ShadowedRadiance, _>(0, &s.shade, ());
                refused(sbt.build(), "an SBT without the shadow hit record")
            },
            |e| {
                matches!(
                    e,
                    Error::Sbt(raykit::SbtError::Incomplete { region: raykit::SbtRegion::Hit, needed: 2, have: 1, .. })
                )
            },
        )
    })
}

#[test]
fn hit_for_a_geometry_past_twenty_four_bits() -> anyhow::Result<()> {
    case(
        "hit_for_a_geometry_past_twenty_four_bits",
        &["SBT hit index 16777216 is out of range"],
        |ctx| {
            triangle_sbt(ctx, |b, l| {
                b.miss(&l.miss, MissData { bg_color: BG_COLOR }).hit_for::<triangle_device::Radiance, _>(
                    1 << 24,
                    &l.hit,
                    (),
                )
            })
        },
        |e| matches!(e, Error::Sbt(raykit::SbtError::IndexOutOfRange { region: raykit::SbtRegion::Hit, .. })),
    )
}

#[test]
fn recursive_closest_hit_in_a_library_with_max_trace_depth_one() -> anyhow::Result<()> {
    in_child("recursive_closest_hit_in_a_library_with_max_trace_depth_one", || {
        case(
            "recursive_closest_hit_in_a_library_with_max_trace_depth_one",
            &["`__closesthit__layer_hit` needs a trace depth of at least 2", "max_trace_depth 1"],
            |ctx| {
                anyhow::ensure!(ctx.supports_pipeline_libraries(), "this device has no pipeline libraries");
                let module = Module::from_device_crate(ctx, "stack-test-device")?;
                let hit = ProgramGroup::hit_group(&module).closest_hit(stack_test_device::LAYER_HIT).build()?;
                let options = raykit::LibraryOptions { max_trace_depth: 1, interface: None };
                refused(raykit::PipelineLibrary::<stack_test_device::Params>::new(ctx, &[&hit], options), "the library")
            },
            |e| matches!(e, Error::Link(raykit::LinkError::TraceDepthExceeded { needed: 2, .. })),
        )
    })
}

#[test]
fn complete_sbt_of_two_ray_types_builds_and_renders() -> anyhow::Result<()> {
    with_context("complete_sbt_of_two_ray_types_builds_and_renders", |ctx| {
        let s = shadows(ctx)?;
        Sbt::builder(&s.pipeline)
            .raygen(&s.raygen, ())
            .miss_for::<program_model_device::ShadowedRadiance, _>(&s.miss, ())
            .miss_for::<program_model_device::Shadow, _>(&s.shadow_miss, ())
            .hit_for::<program_model_device::ShadowedRadiance, _>(0, &s.shade, ())
            .hit_for::<program_model_device::Shadow, _>(0, &s.shadow_hit, ())
            .build()?;
        still_usable(ctx)
    })
}

// --- Groups know their ray type ---

#[test]
fn miss_group_placed_for_another_ray_type() -> anyhow::Result<()> {
    case(
        "miss_group_placed_for_another_ray_type",
        &[
            "`__miss__ms_shadows` was declared for ray type `ShadowedRadiance`",
            "miss_for::<Shadow>",
            "place it with miss_for::<ShadowedRadiance>",
        ],
        |ctx| {
            let s = shadows(ctx)?;
            let sbt = Sbt::builder(&s.pipeline)
                .raygen(&s.raygen, ())
                .miss_for::<program_model_device::Shadow, _>(&s.miss, ());
            refused(sbt.build(), "the radiance miss placed for the shadow ray")
        },
        |e| {
            matches!(
                e,
                Error::Sbt(raykit::SbtError::RayTypeMismatch {
                    region: raykit::SbtRegion::Miss,
                    declared: "ShadowedRadiance",
                    ..
                })
            )
        },
    )
}

#[test]
fn hit_group_placed_for_another_ray_type() -> anyhow::Result<()> {
    case(
        "hit_group_placed_for_another_ray_type",
        &["`__closesthit__shadow_hit` was declared for ray type `Shadow`", "hit_for::<ShadowedRadiance>"],
        |ctx| {
            let s = shadows(ctx)?;
            let sbt = Sbt::builder(&s.pipeline)
                .raygen(&s.raygen, ())
                .hit_for::<program_model_device::ShadowedRadiance, _>(0, &s.shadow_hit, ());
            refused(sbt.build(), "the shadow hit group placed for the radiance ray")
        },
        |e| {
            matches!(
                e,
                Error::Sbt(raykit::SbtError::RayTypeMismatch {
                    region: raykit::SbtRegion::Hit,
                    declared: "Shadow",
                    ..
                })
            )
        },
    )
}

// ------------------------------------------------- records, callables, hit kinds

/// Whether `e` is `RecordTooSmall` for `region` record `index`, reading `reads` of `given` bytes.
fn record_too_small(e: &Error, region: raykit::SbtRegion, index: usize, reads: usize, given: usize) -> bool {
    matches!(e, Error::Sbt(raykit::SbtError::RecordTooSmall { region: r, index: i, reads: n, given: g, .. })
        if (*r, *i, *n, *g) == (region, index, reads, given))
}

#[test]
fn miss_record_given_no_data_for_a_program_that_reads_12_bytes() -> anyhow::Result<()> {
    // Accepted once, and the miss program read the hit record's handle (or
    // zeros on the CPU) as its colour: the background came out black.
    case(
        "miss_record_given_no_data_for_a_program_that_reads_12_bytes",
        &["miss record 0 carries 0 bytes", "`__miss__ms` reads 12 bytes", "#[record]"],
        |ctx| triangle_sbt(ctx, |b, l| b.miss(&l.miss, ()).hit(&l.hit, ())),
        |e| record_too_small(e, raykit::SbtRegion::Miss, 0, 12, 0),
    )
}

#[test]
fn miss_record_of_a_smaller_type_than_the_program_reads() -> anyhow::Result<()> {
    case(
        "miss_record_of_a_smaller_type_than_the_program_reads",
        &["miss record 1 carries 8 bytes", "reads 12 bytes"],
        |ctx| {
            triangle_sbt(ctx, |b, l| {
                b.miss(&l.miss, MissData { bg_color: BG_COLOR }).miss(&l.miss, [0.5f32; 2]).hit(&l.hit, ())
            })
        },
        |e| record_too_small(e, raykit::SbtRegion::Miss, 1, 12, 8),
    )
}

#[test]
fn miss_record_larger_than_the_program_reads_is_accepted_and_read_as_its_prefix() -> anyhow::Result<()> {
    raykit_tests::with_each_backend("miss_record_larger_than_the_program_reads", |ctx, _| {
        let l = linked(ctx)?;
        let data = [BG_COLOR.x, BG_COLOR.y, BG_COLOR.z, 7.0];
        let sbt = Sbt::builder(&l.pipeline).raygen(&l.raygen, ()).miss(&l.miss, data).hit(&l.hit, ()).build()?;
        let gas = Gas::triangles(ctx, &triangle::VERTICES, None)?;
        let scene = Ias::single(ctx, &gas)?;
        let image = ctx.buffer::<u32>(16 * 16)?;
        l.pipeline.launch(&sbt, &triangle::params(16, 16, image.handle(), scene.handle()), [16, 16, 1])?;
        let pixels = image.read()?;
        anyhow::ensure!(pixels[0] == make_color(BG_COLOR), "corner {:#010x} is not the background", pixels[0]);
        still_usable(ctx)
    })
}

#[test]
fn glsl_miss_record_given_no_data() -> anyhow::Result<()> {
    vulkan_case(
        "a SPIR-V module (GLSL): the CPU backend runs Rust programs and refuses it (CpuRefusal::SpirvModule)",
        "glsl_miss_record_given_no_data",
        &["miss record 0 carries 0 bytes", "`main` reads 12 bytes"],
        |ctx| {
            let p = triangle::Programs::glsl(ctx)?;
            let pipeline = Pipeline::<Params>::new(ctx, &[&p.raygen, &p.miss, &p.hit], LinkOptions::default())?;
            refused(Sbt::builder(&pipeline).raygen(&p.raygen, ()).miss(&p.miss, ()).hit(&p.hit, ()).build(), "the SBT")
        },
        |e| record_too_small(e, raykit::SbtRegion::Miss, 0, 12, 0),
    )
}

#[test]
fn wgsl_miss_reading_4012_bytes_against_a_12_byte_record() -> anyhow::Result<()> {
    vulkan_case(
        "a WGSL module (SPIR-V through naga): the CPU backend refuses SPIR-V modules",
        "wgsl_miss_reading_4012_bytes_against_a_12_byte_record",
        &["miss record 0 carries 12 bytes", "`ms` reads 4012 bytes"],
        |ctx| {
            let source = triangle::WGSL.replace(
                "struct MissData { bg_color: Vec3f }",
                "struct MissData { bg_color: Vec3f, more: array<f32, 1000> }",
            );
            anyhow::ensure!(source != triangle::WGSL, "the WGSL twin's MissData changed");
            let module = Module::from_wgsl_named(ctx, &source, "big_record.wgsl")?;
            let raygen = ProgramGroup::raygen(&module, "rg")?;
            let miss = ProgramGroup::miss(&module, "ms")?;
            let hit = ProgramGroup::hit_group(&module).closest_hit("ch").build()?;
            let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions::default())?;
            let built = Sbt::builder(&pipeline)
                .raygen(&raygen, ())
                .miss(&miss, MissData { bg_color: BG_COLOR })
                .hit(&hit, ())
                .build();
            refused(built, "the SBT")
        },
        |e| record_too_small(e, raykit::SbtRegion::Miss, 0, 4012, 12),
    )
}

/// The GLSL raygen that calls callable 2, and the callable that answers it.
fn callable_programs(ctx: &Context) -> anyhow::Result<(ProgramGroup, ProgramGroup)> {
    let raygen = Module::new(ctx, include_bytes!("../data/raygen_calls_callable_2.rgen.spv"))?;
    let callable = Module::new(ctx, include_bytes!("../data/callable_white.rcall.spv"))?;
    Ok((ProgramGroup::raygen(&raygen, "main")?, ProgramGroup::callable(&callable, "main")?))
}

#[test]
fn sbt_without_the_callable_a_program_calls() -> anyhow::Result<()> {
    vulkan_case(
        "the calling raygen is a GLSL module: the CPU backend refuses SPIR-V modules",
        "sbt_without_the_callable_a_program_calls",
        &["2 callable record(s)", "`main` calls callable 2", ".callable(..)"],
        |ctx| {
            let (raygen, callable) = callable_programs(ctx)?;
            let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &callable], LinkOptions::default())?;
            // None, then two: both short of index 2.
            let none = refused(Sbt::builder(&pipeline).raygen(&raygen, ()).build(), "an SBT without callables")?;
            anyhow::ensure!(matches!(&none, Error::Sbt(raykit::SbtError::CallableMissing { have: 0, .. })), "{none:?}");
            let two = Sbt::builder(&pipeline).raygen(&raygen, ()).callable(&callable, ()).callable(&callable, ());
            let err = refused(two.build(), "an SBT with two callables")?;
            // Three are enough, and the launch runs.
            let three = Sbt::builder(&pipeline)
                .raygen(&raygen, ())
                .callable(&callable, ())
                .callable(&callable, ())
                .callable(&callable, ())
                .build()?;
            let image = ctx.buffer::<u32>(1)?;
            let params = triangle::params(1, 1, image.handle(), raykit::Traversable::NULL);
            pipeline.launch(&three, &params, [4, 4, 1])?;
            Ok(err)
        },
        |e| {
            matches!(e, Error::Sbt(raykit::SbtError::CallableMissing { what, have: 2, program })
                if what.as_str() == "callable 2" && program.as_str() == "main")
        },
    )
}

/// The accel test's programs with a procedural hit group (the sphere
/// intersection) at hit record 0 and a triangles one at 1, launched over an
/// instance of a GAS of AABBs or triangles whose SBT offset is `sbt_offset`
/// and whose mask is `mask`;
/// returns pixel (1, 1), which sees the geometry.
fn launch_with_hit_kinds(ctx: &Context, aabbs: bool, sbt_offset: u32, mask: u8) -> raykit::Result<u32> {
    use accel_test_device::{ColorData, Params as AccelParams};
    let module = Module::from_device_crate(ctx, "accel-test-device")?;
    let raygen = ProgramGroup::raygen(&module, accel_test_device::RG)?;
    let miss = ProgramGroup::miss(&module, accel_test_device::MS)?;
    let sphere = ProgramGroup::hit_group(&module)
        .intersection(accel_test_device::IS_SPHERE)
        .closest_hit(accel_test_device::CH_RECORD)
        .build()?;
    let triangles = ProgramGroup::hit_group(&module).closest_hit(accel_test_device::CH_RECORD).build()?;
    let pipeline =
        Pipeline::<AccelParams>::new(ctx, &[&raygen, &miss, &sphere, &triangles], LinkOptions { max_trace_depth: 1 })?;
    let color = ColorData { color: Vec3::ONE };
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss(&miss, ColorData { color: Vec3::ZERO })
        .hit(&sphere, color)
        .hit(&triangles, color)
        .build()?;
    let gas = if aabbs {
        Gas::aabbs(ctx, &[raykit::Aabb::new(Vec3::new(-1.4, -0.4, -0.4), Vec3::new(-0.6, 0.4, 0.4))])?
    } else {
        Gas::triangles(ctx, &triangle::VERTICES, None)?
    };
    // Pixel (1, 1) of the window sees world (-1.25, 0.25): inside the sphere of
    // AABB 0 (centre (-1, 0), radius 0.4), and inside the triangle moved there.
    let moved = if aabbs { Affine3A::IDENTITY } else { Affine3A::from_translation(Vec3::new(-1.25, 0.25, 0.0)) };
    let scene = Ias::new(ctx, &[Instance::new(&gas).transform(moved).sbt_offset(sbt_offset).mask(mask)])?;
    let image = ctx.buffer::<u32>(16)?;
    let params = AccelParams {
        image: image.handle(),
        width: 4,
        height: 4,
        _pad: 0,
        x0: -2.0,
        y0: -1.0,
        x1: 0.0,
        y1: 1.0,
        scene: scene.handle(),
    };
    pipeline.launch(&sbt, &params, [4, 4, 1])?;
    Ok(image.read()?[5])
}

#[test]
fn procedural_hit_group_for_a_triangle_gas() -> anyhow::Result<()> {
    case(
        "procedural_hit_group_for_a_triangle_gas",
        &["has triangles (geometry 0 of its GAS)", "hit record 0", "procedural hit group", "`__raygen__rg`"],
        |ctx| {
            // Each kind at its own record renders the geometry white …
            let white = accel_test_device::pack_unorm(Vec3::ONE);
            for (aabbs, offset) in [(true, 0), (false, 1)] {
                let pixel = launch_with_hit_kinds(ctx, aabbs, offset, 0xff)?;
                anyhow::ensure!(pixel == white, "AABBs {aabbs}: pixel (1, 1) is {pixel:#010x}, not white");
            }
            // … and triangles at the procedural group's record are refused.
            refused(launch_with_hit_kinds(ctx, false, 0, 0xff), "a procedural hit group for triangles")
        },
        |e| {
            matches!(
                e,
                Error::Launch(raykit::LaunchError::HitGroupKind {
                    instance: 0,
                    geometry: 0,
                    slot: 0,
                    aabbs: false,
                    ..
                })
            )
        },
    )
}

#[test]
fn triangles_hit_group_for_an_aabb_gas() -> anyhow::Result<()> {
    case(
        "triangles_hit_group_for_an_aabb_gas",
        &["has AABBs", "hit record 1", "triangles hit group", ".intersection(..)"],
        |ctx| refused(launch_with_hit_kinds(ctx, true, 1, 0xff), "a triangles hit group for AABBs"),
        |e| matches!(e, Error::Launch(raykit::LaunchError::HitGroupKind { slot: 1, aabbs: true, .. })),
    )
}

/// A CPU context, with packet tracing (lanes) on or off.
fn cpu_context(packets: bool) -> anyhow::Result<Context> {
    let options = ContextOptions {
        backend: Some(raykit::Backend::Cpu),
        cpu_packets: Some(packets),
        ..raykit_tests::test_options()
    };
    Ok(Context::new(options)?)
}

/// A launch of the accel test's `raygen`, its miss program and the hit group
/// `hit` makes of its module, with one ray per pixel of a `width × height`
/// window onto [-1, 1]² (`accel_test_device::pixel_position`) into `gas`: its
/// params and what the launch returned.
fn accel_launch(
    ctx: &Context,
    raygen: impl raykit::EntryName,
    hit: impl FnOnce(&Module) -> raykit::Result<ProgramGroup>,
    gas: &Gas,
    (width, height): (u32, u32),
) -> anyhow::Result<(accel_test_device::Params, raykit::Result<()>)> {
    use accel_test_device::{ColorData, Params as AccelParams};
    let module = Module::from_device_crate(ctx, "accel-test-device")?;
    let raygen = ProgramGroup::raygen(&module, raygen)?;
    let miss = ProgramGroup::miss(&module, accel_test_device::MS)?;
    let hit = hit(&module)?;
    let pipeline = Pipeline::<AccelParams>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss(&miss, ColorData { color: Vec3::ZERO })
        .hit(&hit, ())
        .build()?;
    let scene = Ias::single(ctx, gas)?;
    let image = ctx.buffer::<u32>((width * height) as usize)?;
    let params = AccelParams {
        image: image.handle(),
        width,
        height,
        _pad: 0,
        x0: -1.0,
        y0: -1.0,
        x1: 1.0,
        y1: 1.0,
        scene: scene.handle(),
    };
    let launched = pipeline.launch(&sbt, &params, [width, height, 1]);
    Ok((params, launched))
}

/// The launch error of a CPU program that overflows its stack: the raygen
/// itself, or a closest-hit it traces into.
fn overflow_error(ctx: &Context, in_closest_hit: bool) -> anyhow::Result<Error> {
    let raygen = if in_closest_hit { accel_test_device::RG } else { accel_test_device::RG_RECURSING };
    let hit = |module: &Module| ProgramGroup::hit_group(module).closest_hit(accel_test_device::CH_RECURSING).build();
    let gas = Gas::triangles(ctx, &triangle::VERTICES, None)?;
    let (_, launched) = accel_launch(ctx, raygen, hit, &gas, (4, 4))?;
    refused(launched, "a launch whose program recurses without end")
}

#[test]
fn cpu_program_recursing_without_end() -> anyhow::Result<()> {
    // Killed the process with SIGSEGV once: in a child.
    in_child("cpu_program_recursing_without_end", || {
        for packets in [false, true] {
            let ctx = cpu_context(packets)?;
            for (in_closest_hit, program, index) in
                [(false, "__raygen__rg_recursing", [0, 0, 0]), (true, "__closesthit__ch_recursing", [1, 2, 0])]
            {
                let err = overflow_error(&ctx, in_closest_hit)?;
                let label = format!("packets {packets}, {program}");
                match &err {
                    Error::Launch(raykit::LaunchError::StackOverflow { program: p, launch_index, .. }) => {
                        anyhow::ensure!(p == program, "{label}: named {p}");
                        // The closest-hit runs where the triangle covers the
                        // window: (1, 2) is the first such index in launch order.
                        anyhow::ensure!(*launch_index == index, "{label}: at {launch_index:?}");
                    }
                    other => anyhow::bail!("{label}: {other:?}"),
                }
                let text = err.to_string();
                anyhow::ensure!(text.contains("overflowed its stack") && text.contains(program), "{text}");
                // The context goes on: twice more, then a picture.
                anyhow::ensure!(matches!(
                    overflow_error(&ctx, in_closest_hit)?,
                    Error::Launch(raykit::LaunchError::StackOverflow { .. })
                ));
                still_usable(&ctx)?;
            }
        }
        Ok(())
    })
}

/// The launch error of a CPU launch of orthographic rays into one box whose
/// intersection program recurses without end (`recursing`) or panics, and the
/// first launch index, in launch order, whose ray enters the box.
fn intersection_failure(ctx: &Context, recursing: bool) -> anyhow::Result<(Error, [u32; 3])> {
    use raykit::glam::{UVec2, Vec2};
    let intersection = if recursing { accel_test_device::IS_RECURSING } else { accel_test_device::IS_PANICKING };
    let hit = |module: &Module| ProgramGroup::hit_group(module).intersection(intersection).build();
    // Four pixel centres lie inside the box, none on its sides.
    let (lo, hi) = (Vec2::new(-0.3, -0.3), Vec2::new(-0.05, -0.05));
    let gas = Gas::aabbs(ctx, &[raykit::Aabb::new(lo.extend(-1.0), hi.extend(1.0))])?;
    let (params, launched) = accel_launch(ctx, accel_test_device::RG, hit, &gas, (16, 16))?;
    let first = (0..params.height)
        .flat_map(|y| (0..params.width).map(move |x| (x, y)))
        .find(|&(x, y)| {
            let p = accel_test_device::pixel_position(UVec2::new(x, y), &params);
            p.cmpgt(lo).all() && p.cmplt(hi).all()
        })
        .ok_or_else(|| anyhow::anyhow!("no ray enters the box"))?;
    let err = refused(launched, "a launch whose intersection program fails")?;
    Ok((err, [first.0, first.1, 0]))
}

#[test]
fn cpu_intersection_program_failing_in_packets_and_alone() -> anyhow::Result<()> {
    // Overflows killed the process with SIGSEGV once: in a child.
    in_child("cpu_intersection_program_failing_in_packets_and_alone", || {
        for packets in [false, true] {
            let ctx = cpu_context(packets)?;
            for recursing in [true, false] {
                let label = format!("packets {packets}, recursing {recursing}");
                let (err, first) = intersection_failure(&ctx, recursing)?;
                match &err {
                    Error::Launch(LaunchError::StackOverflow { program, launch_index, .. }) if recursing => {
                        anyhow::ensure!(program == "__intersection__is_recursing", "{label}: named {program}");
                        anyhow::ensure!(*launch_index == first, "{label}: at {launch_index:?}, not {first:?}");
                    }
                    Error::Launch(LaunchError::ProgramPanicked { program, launch_index, message }) if !recursing => {
                        anyhow::ensure!(program == "__intersection__is_panicking", "{label}: named {program}");
                        anyhow::ensure!(*launch_index == first, "{label}: at {launch_index:?}, not {first:?}");
                        anyhow::ensure!(message.contains("the ray entered box 0"), "{label}: {message}");
                    }
                    other => anyhow::bail!("{label}: {other:?}"),
                }
                // The same error again, then a picture.
                anyhow::ensure!(intersection_failure(&ctx, recursing)?.0.to_string() == err.to_string(), "{label}");
                still_usable(&ctx)?;
            }
            // With packets on, the rays went in packets (the walk ran the
            // failing programs); with them off, none did.
            anyhow::ensure!((ctx.packet_rays() > 0) == packets, "packets {packets}: {} packet rays", ctx.packet_rays());
        }
        Ok(())
    })
}

/// The texture test's pipeline (every group of `tests/device/texture`) and an
/// SBT for it built as that test builds it, with `ch_data` as the first
/// closest-hit's record and the callable only when `callable` says so.
fn texture_sbt<T: raykit::SbtRecordData>(ctx: &Context, ch_data: T, callable: bool) -> anyhow::Result<Error> {
    use texture_test_device::{ViaAnyHit, ViaCallable, ViaClosestHit, ViaMiss};
    use texture_test_device::{AH, CH, CH_CALL, MS, MS_SAMPLE, RG, SAMPLE_TEXTURE};
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
    let pipeline = Pipeline::<texture_test_device::Params>::new(ctx, &refs, LinkOptions { max_trace_depth: 1 })?;
    let [rg, ms, ms_sample, ch, ah, ch_call, sample] = &groups;
    let mut builder = Sbt::builder(&pipeline)
        .raygen(rg, ())
        .miss_for::<ViaClosestHit, _>(ms, ())
        .miss_for::<ViaMiss, _>(ms_sample, ())
        .hit_for::<ViaClosestHit, _>(0, ch, ch_data)
        .hit_for::<ViaAnyHit, _>(0, ah, ())
        .hit_for::<ViaCallable, _>(0, ch_call, ());
    if callable {
        builder = builder.callable(sample, ());
    }
    refused(builder.build(), "the texture test's SBT")
}

#[test]
fn hit_record_given_no_data_for_a_closest_hit_that_reads_one() -> anyhow::Result<()> {
    let reads = std::mem::size_of::<texture_test_device::HitRecord>();
    case(
        "hit_record_given_no_data_for_a_closest_hit_that_reads_one",
        &["hit record 0 carries 0 bytes", "`__closesthit__ch` reads"],
        |ctx| texture_sbt(ctx, (), true),
        |e| record_too_small(e, raykit::SbtRegion::Hit, 0, reads, 0),
    )
}

#[test]
fn sbt_without_the_callable_a_rust_closest_hit_calls() -> anyhow::Result<()> {
    case(
        "sbt_without_the_callable_a_rust_closest_hit_calls",
        &["0 callable record(s)", "`__closesthit__ch_call` calls callable 0"],
        |ctx| texture_sbt(ctx, texture_test_device::HitRecord { texture: raykit::Texture2D::NULL }, false),
        |e| {
            matches!(e, Error::Sbt(raykit::SbtError::CallableMissing { what, have: 0, program })
                if what.as_str() == "callable 0" && program.as_str() == "__closesthit__ch_call")
        },
    )
}

#[test]
fn hit_group_of_the_other_kind_for_an_instance_no_ray_can_hit_is_accepted() -> anyhow::Result<()> {
    raykit_tests::with_each_backend("hit_group_of_the_other_kind_for_an_instance_no_ray_can_hit", |ctx, _| {
        // Mask 0: no ray hits the triangle, so its procedural record is never run.
        let pixel = launch_with_hit_kinds(ctx, false, 0, 0)?;
        anyhow::ensure!(
            pixel == accel_test_device::pack_unorm(Vec3::ZERO),
            "pixel (1, 1) is {pixel:#010x}, not the miss"
        );
        still_usable(ctx)
    })
}

// ------------------------------------------------- geometry: boxes, spheres, compaction

#[test]
fn aabb_whose_min_is_above_its_max() -> anyhow::Result<()> {
    case(
        "aabb_whose_min_is_above_its_max",
        &["AABB 0", "min is greater than max"],
        |ctx| refused(Gas::aabbs(ctx, &[raykit::Aabb::new(Vec3::ONE, Vec3::ZERO)]), "an inside-out box"),
        |e| matches!(e, Error::Accel(raykit::AccelError::InvalidAabb { .. })),
    )
}

#[test]
fn triangles_and_boxes_in_one_gas() -> anyhow::Result<()> {
    case(
        "triangles_and_boxes_in_one_gas",
        &[],
        |ctx| {
            let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
            let boxes = [raykit::Aabb::new(Vec3::ZERO, Vec3::ONE)];
            refused(
                Gas::builder().triangles(Triangles::new(&tri)).aabbs(raykit::Aabbs::new(&boxes)).build(ctx),
                "triangles and boxes in one GAS",
            )
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::MixedGeometryTypes { .. })),
    )
}

#[test]
fn compaction_of_a_gas_built_without_it() -> anyhow::Result<()> {
    case(
        "compaction_of_a_gas_built_without_it",
        &[],
        |ctx| refused(Gas::triangles(ctx, &[Vec3::ZERO, Vec3::X, Vec3::Y], None)?.compact(), "compaction"),
        |e| matches!(e, Error::Accel(raykit::AccelError::CompactionNotAllowed)),
    )
}

#[test]
fn spheres_with_fewer_radii_than_centres() -> anyhow::Result<()> {
    case(
        "spheres_with_fewer_radii_than_centres",
        &["2", "1"],
        |ctx| refused(Gas::spheres(ctx, &[Vec3::ZERO, Vec3::X], &[1.0]), "two centres, one radius"),
        |e| matches!(e, Error::Accel(raykit::AccelError::SphereCount { centres: 2, radii: 1 })),
    )
}

#[test]
fn sphere_with_a_nan_radius() -> anyhow::Result<()> {
    case(
        "sphere_with_a_nan_radius",
        &["NaN", "give a finite radius"],
        |ctx| refused(Gas::spheres(ctx, &[Vec3::ZERO], &[f32::NAN]), "a NaN radius"),
        |e| matches!(e, Error::Accel(raykit::AccelError::InvalidSphere { sphere: 0, .. })),
    )
}

#[test]
fn moving_spheres_with_fewer_ends_than_starts() -> anyhow::Result<()> {
    case(
        "moving_spheres_with_fewer_ends_than_starts",
        &["2 start centres", "1 end centres", "one end centre per start centre"],
        |ctx| {
            let ends = [Vec3::X];
            refused(Gas::moving_spheres(ctx, &[Vec3::ZERO, Vec3::X], &ends, &[1.0, 1.0]), "two starts, one end")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::MovingSphereCount { start: 2, end: 1 })),
    )
}

// ---------------------------------------------------------------- textures

/// An sRGB texture of `width × height` from `data`.
fn srgb_texture(ctx: &Context, width: u32, height: u32, data: &[u8], mips: Mipmaps) -> raykit::Result<Texture> {
    Texture::new(ctx, TextureFormat::Rgba8Srgb, width, height, data, mips, SamplerOptions::default())
}

#[test]
fn texture_of_zero_width() -> anyhow::Result<()> {
    case(
        "texture_of_zero_width",
        &["at least 1"],
        |ctx| refused(srgb_texture(ctx, 0, 4, &[], Mipmaps::One), "a texture 0 texels wide"),
        |e| matches!(e, Error::Resource(ResourceError::TextureSize { width: 0, .. })),
    )
}

#[test]
fn texture_wider_than_the_device_allows() -> anyhow::Result<()> {
    case(
        "texture_wider_than_the_device_allows",
        &["maxImageDimension2D"],
        |ctx| {
            let max = raykit::texture::max_texture_size(ctx);
            refused(srgb_texture(ctx, max + 1, 1, &[], Mipmaps::One), "a texture past maxImageDimension2D")
        },
        |e| matches!(e, Error::Resource(ResourceError::TextureSize { .. })),
    )
}

#[test]
fn texture_data_shorter_than_its_level() -> anyhow::Result<()> {
    case(
        "texture_data_shorter_than_its_level",
        &["bytes_per_texel"],
        |ctx| refused(srgb_texture(ctx, 4, 4, &[0; 60], Mipmaps::Generate), "60 bytes for 64"),
        |e| matches!(e, Error::Resource(ResourceError::TextureData { level: 0, expected: 64, got: 60, .. })),
    )
}

#[test]
fn mip_level_of_the_wrong_size() -> anyhow::Result<()> {
    case(
        "mip_level_of_the_wrong_size",
        &["must be 2×2"],
        |ctx| {
            let levels = [
                MipLevel { width: 4, height: 4, data: vec![0; 64] },
                MipLevel { width: 1, height: 1, data: vec![0; 4] },
            ];
            let texture = Texture::from_levels(ctx, TextureFormat::Rgba8Srgb, &levels, SamplerOptions::default());
            refused(texture, "a 1×1 level after a 4×4 one")
        },
        |e| matches!(e, Error::Resource(ResourceError::TextureSize { .. })),
    )
}

#[test]
fn image_of_16_bit_integer_channels() -> anyhow::Result<()> {
    case(
        "image_of_16_bit_integer_channels",
        &["to_rgba32f"],
        |ctx| {
            let deep = image::DynamicImage::ImageRgba16(image::ImageBuffer::new(2, 2));
            refused(Texture::from_image(ctx, &deep, false, Mipmaps::One, SamplerOptions::default()), "16-bit integers")
        },
        |e| matches!(e, Error::Resource(ResourceError::TextureFormat { .. })),
    )
}

// ---------------------------------------------------------------- handles, records, buffers

/// The triangle's SBT over `l`.
fn full_sbt(l: &Linked) -> anyhow::Result<Sbt> {
    Ok(Sbt::builder(&l.pipeline)
        .raygen(&l.raygen, ())
        .miss(&l.miss, MissData { bg_color: BG_COLOR })
        .hit(&l.hit, ())
        .build()?)
}

#[test]
fn launch_with_the_handle_of_a_dropped_buffer() -> anyhow::Result<()> {
    case(
        "launch_with_the_handle_of_a_dropped_buffer",
        &["`image`"],
        |ctx| {
            let l = linked(ctx)?;
            let sbt = full_sbt(&l)?;
            let image = ctx.buffer::<u32>(1)?;
            let stale = image.handle();
            drop(image);
            let params = triangle::params(1, 1, stale, raykit::Traversable::NULL);
            refused(l.pipeline.launch(&sbt, &params, [1, 1, 1]), "a dropped buffer's handle")
        },
        |e| matches!(e, Error::Launch(LaunchError::InvalidHandle { record: None, field, .. }) if field == "image"),
    )
}

#[test]
fn sbt_update_past_the_last_record() -> anyhow::Result<()> {
    case(
        "sbt_update_past_the_last_record",
        &[],
        |ctx| refused(full_sbt(&linked(ctx)?)?.update(SbtRegion::Hit, 1, ()), "an update of hit record 1 of 1"),
        |e| matches!(e, Error::Sbt(raykit::SbtError::Update { .. })),
    )
}

#[test]
fn sbt_update_larger_than_the_record() -> anyhow::Result<()> {
    case(
        "sbt_update_larger_than_the_record",
        &[],
        |ctx| refused(full_sbt(&linked(ctx)?)?.update(SbtRegion::Miss, 0, [0u8; 4096]), "4096 bytes of miss data"),
        |e| matches!(e, Error::Sbt(raykit::SbtError::Update { .. })),
    )
}

#[test]
fn buffer_write_past_its_end() -> anyhow::Result<()> {
    case(
        "buffer_write_past_its_end",
        &[],
        |ctx| refused(ctx.buffer::<u32>(4)?.write_at(3, &[1, 2]), "a write of elements 3..5 of 4"),
        |e| matches!(e, Error::Resource(ResourceError::BufferRange { start: 3, end: 5, len: 4 })),
    )
}

#[test]
fn element_laid_out_differently_in_the_spirv() -> anyhow::Result<()> {
    case(
        "element_laid_out_differently_in_the_spirv",
        &["`value`"],
        |ctx| {
            let module = Module::from_device_crate(ctx, "params-device")?;
            refused(module.check_element::<params_device::elements::Shifted>(), "a shifted element")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::ElementLayout(_))),
    )
}

#[test]
fn wgsl_with_a_syntax_error() -> anyhow::Result<()> {
    case(
        "wgsl_with_a_syntax_error",
        &["triangle.wgsl"],
        |ctx| {
            let source = triangle::WGSL.replacen("vec3f(miss_data.bg_color);", "vec3f(miss_data.bg_color)", 1);
            anyhow::ensure!(source != triangle::WGSL, "the triangle's WGSL changed");
            refused(Module::from_wgsl_named(ctx, &source, "triangle.wgsl"), "WGSL without a `;`")
        },
        |e| matches!(e, Error::Module(raykit::ModuleError::Wgsl(_))),
    )
}

// ---------------------------------------------------------------- params, exceptions

/// Launch params of 80 KiB: past the 64 KiB a launch can deliver.
#[repr(C)]
#[derive(Copy, Clone, raykit::bytemuck::Pod, raykit::bytemuck::Zeroable, raykit::LaunchParams)]
#[bytemuck(crate = "raykit::bytemuck")]
struct HugeParams {
    words: [[u32; 4096]; 5],
}

#[test]
fn params_larger_than_a_launch_delivers() -> anyhow::Result<()> {
    case(
        "params_larger_than_a_launch_delivers",
        &["81920"],
        |ctx| {
            let p = triangle::Programs::rust(ctx)?;
            refused(Pipeline::<HugeParams>::new(ctx, &[&p.raygen], LinkOptions::default()), "80 KiB of params")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::ParamsTooLarge { size: 81920, .. })),
    )
}

fn program_model(ctx: &Context) -> anyhow::Result<Module> {
    Ok(Module::from_device_crate(ctx, "program-model-device")?)
}

#[test]
fn two_exception_programs_in_one_pipeline() -> anyhow::Result<()> {
    case(
        "two_exception_programs_in_one_pipeline",
        &[],
        |ctx| {
            let module = program_model(ctx)?;
            let raygen = ProgramGroup::raygen(&module, program_model_device::RG_THROW)?;
            let first = ProgramGroup::exception(&module, program_model_device::ON_EXCEPTION)?;
            let second = ProgramGroup::exception(&module, program_model_device::ON_EXCEPTION)?;
            let groups = [&raygen, &first, &second];
            refused(Pipeline::<program_model_device::Params>::new(ctx, &groups, LinkOptions::default()), "two")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::SeveralExceptionPrograms)),
    )
}

#[test]
fn programs_that_throw_user_exceptions() -> anyhow::Result<()> {
    case(
        "programs_that_throw_user_exceptions",
        &["2"],
        |ctx| {
            let module = program_model(ctx)?;
            let raygen = ProgramGroup::raygen(&module, program_model_device::RG_THROW)?;
            let pipeline = Pipeline::<program_model_device::Params>::new(ctx, &[&raygen], LinkOptions::default())?;
            let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
            let image = ctx.buffer::<u32>(16 * 16)?;
            let spheres = ctx.buffer_from::<raykit::glam::Vec4>(&[raykit::glam::Vec4::ZERO])?;
            let gas = Gas::triangles(ctx, &[Vec3::ZERO, Vec3::X, Vec3::Y], None)?;
            let scene = Ias::single(ctx, &gas)?;
            let params = program_model_device::Params {
                image: image.handle(),
                spheres: spheres.handle(),
                size: raykit::glam::UVec2::splat(16),
                scene: scene.handle(),
            };
            refused(pipeline.launch(&sbt, &params, [16, 16, 1]), "a launch whose programs throw")
        },
        |e| matches!(e, Error::Launch(LaunchError::UserExceptions { total: 2, .. })),
    )
}

// ---------------------------------------------------------------- contexts and device groups

#[test]
fn device_index_past_the_usable_devices() -> anyhow::Result<()> {
    case(
        "device_index_past_the_usable_devices",
        &["device index 99", "use an index below"],
        |ctx| {
            let options = ContextOptions { backend: Some(ctx.backend()), device_index: Some(99), ..Default::default() };
            refused(Context::new(options), "device index 99")
        },
        |e| matches!(e, Error::Device(raykit::DeviceError::DeviceIndexOutOfRange { index: 99, .. })),
    )
}

/// A band state for device-group cases: `row_len` counters a row.
struct Rows {
    buffer: raykit::DeviceBuffer<u32>,
    row_len: usize,
}

impl Rows {
    fn new(ctx: &Context, rows: u32, row_len: usize) -> raykit::Result<Rows> {
        Ok(Rows { buffer: ctx.buffer(rows as usize * row_len)?, row_len })
    }
}

impl BandRows for Rows {
    type Item = u32;
    fn row_len(&self) -> usize {
        self.row_len
    }
    fn read_rows(&self, rows: std::ops::Range<u32>, out: &mut [u32]) -> raykit::Result<()> {
        self.buffer.read_into(rows.start as usize * self.row_len, out)
    }
    fn write_rows(&mut self, rows: std::ops::Range<u32>, data: &[u32]) -> raykit::Result<()> {
        self.buffer.write_at(rows.start as usize * self.row_len, data)
    }
}

/// A group of two contexts of `ctx`'s device, split over 8 rows of 4.
fn split_of_two(ctx: &Context) -> anyhow::Result<raykit::Split<Rows>> {
    let group = DeviceGroup::new(vec![ctx.clone(), ctx.clone()])?;
    Ok(group.split(8, |c| Rows::new(c, 8, 4))?)
}

#[test]
fn device_group_of_no_devices() -> anyhow::Result<()> {
    case(
        "device_group_of_no_devices",
        &[],
        |_| refused(DeviceGroup::new(Vec::new()), "a group of no devices"),
        |e| matches!(e, Error::DeviceGroup(DeviceGroupError::Empty)),
    )
}

#[test]
fn device_group_split_of_no_rows() -> anyhow::Result<()> {
    case(
        "device_group_split_of_no_rows",
        &[],
        |ctx| refused(DeviceGroup::new(vec![ctx.clone()])?.split(0, |c| Rows::new(c, 1, 1)), "a split of 0 rows"),
        |e| matches!(e, Error::DeviceGroup(DeviceGroupError::EmptySplit)),
    )
}

#[test]
fn device_group_bands_of_different_row_lengths() -> anyhow::Result<()> {
    case(
        "device_group_bands_of_different_row_lengths",
        &[],
        |ctx| {
            let group = DeviceGroup::new(vec![ctx.clone(), ctx.clone()])?;
            let made = std::sync::atomic::AtomicU32::new(0);
            let split = group.split(4, |c| {
                let first = made.fetch_add(1, std::sync::atomic::Ordering::Relaxed) == 0;
                Rows::new(c, 4, if first { 4 } else { 3 })
            });
            refused(split, "rows of 4 and of 3")
        },
        // The states are built in parallel: either device may get the rows of 3.
        |e| {
            matches!(e, Error::DeviceGroup(DeviceGroupError::BandRowLength { device: 1, found, expected })
                if found + expected == 7 && found != expected)
        },
    )
}

#[test]
fn device_group_weights_that_are_negative() -> anyhow::Result<()> {
    case(
        "device_group_weights_that_are_negative",
        &[],
        |ctx| refused(split_of_two(ctx)?.set_balance(Balance::Weights(vec![1.0, -1.0])), "a weight of -1"),
        |e| matches!(e, Error::DeviceGroup(DeviceGroupError::BandWeights { .. })),
    )
}

#[test]
fn device_group_gather_before_any_launch() -> anyhow::Result<()> {
    case(
        "device_group_gather_before_any_launch",
        &[],
        |ctx| refused(split_of_two(ctx)?.gather_vec(), "a gather before a launch"),
        |e| matches!(e, Error::DeviceGroup(DeviceGroupError::NotLaunched { first: 0, end: 8 })),
    )
}

#[test]
fn device_group_gather_into_too_few_elements() -> anyhow::Result<()> {
    case(
        "device_group_gather_into_too_few_elements",
        &[],
        |ctx| {
            let mut split = split_of_two(ctx)?;
            split.launch(|state, band| {
                let first = band.first_row() as usize * state.row_len;
                state.buffer.write_at(first, &vec![1; band.row_count() as usize * state.row_len])
            })?;
            refused(split.gather(&mut [0u32; 5]), "a gather of 32 elements into 5")
        },
        |e| matches!(e, Error::DeviceGroup(DeviceGroupError::GatherSize { rows: 8, row_len: 4, len: 5 })),
    )
}

// ---------------------------------------------------------------- pipeline libraries

/// The triangle's groups, linked, and library options covering all of them.
fn library_parts(ctx: &Context) -> anyhow::Result<(Linked, LibraryOptions)> {
    let l = linked(ctx)?;
    let interface = PipelineLibrary::<Params>::interface_for(&[&l.raygen, &l.miss, &l.hit]);
    Ok((l, LibraryOptions { max_trace_depth: 1, interface: Some(interface) }))
}

#[test]
fn library_of_no_groups() -> anyhow::Result<()> {
    case(
        "library_of_no_groups",
        &[],
        |ctx| refused(PipelineLibrary::<Params>::new(ctx, &[], LibraryOptions::default()), "an empty library"),
        |e| matches!(e, Error::Link(raykit::LinkError::EmptyLibrary)),
    )
}

#[test]
fn libraries_made_for_another_trace_depth() -> anyhow::Result<()> {
    case(
        "libraries_made_for_another_trace_depth",
        &["LibraryOptions::max_trace_depth"],
        |ctx| {
            let (l, options) = library_parts(ctx)?;
            let common = PipelineLibrary::<Params>::new(ctx, &[&l.raygen, &l.miss], options)?;
            let hits = PipelineLibrary::<Params>::new(ctx, &[&l.hit], options)?;
            refused(Pipeline::link(ctx, &[&common, &hits], LinkOptions { max_trace_depth: 2 }), "depths 1 and 2")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::LibraryMismatch { what: "max_trace_depth", index: 0, .. })),
    )
}

#[test]
fn libraries_of_different_interfaces() -> anyhow::Result<()> {
    case(
        "libraries_of_different_interfaces",
        &["interface_for"],
        |ctx| {
            let (l, options) = library_parts(ctx)?;
            let common = PipelineLibrary::<Params>::new(ctx, &[&l.raygen, &l.miss], options)?;
            let wider =
                LibraryOptions { interface: Some(InterfaceSizes { payload: 64, hit_attributes: 8 }), ..options };
            let hits = PipelineLibrary::<Params>::new(ctx, &[&l.hit], wider)?;
            refused(Pipeline::link(ctx, &[&common, &hits], LinkOptions::default()), "two interfaces")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::LibraryMismatch { what: "interface", index: 1, .. })),
    )
}

#[test]
fn library_interface_smaller_than_its_programs_payload() -> anyhow::Result<()> {
    case(
        "library_interface_smaller_than_its_programs_payload",
        &["__raygen__"],
        |ctx| {
            let (l, options) = library_parts(ctx)?;
            let narrow =
                LibraryOptions { interface: Some(InterfaceSizes { payload: 4, hit_attributes: 0 }), ..options };
            refused(PipelineLibrary::<Params>::new(ctx, &[&l.raygen], narrow), "a 4-byte payload interface")
        },
        |e| {
            matches!(e, Error::Link(raykit::LinkError::LibraryInterfaceTooSmall { what: "ray payload", given: 4, program, .. })
                if program.starts_with("__raygen__"))
        },
    )
}

#[test]
fn library_hit_attributes_past_the_device_limit() -> anyhow::Result<()> {
    case(
        "library_hit_attributes_past_the_device_limit",
        &[],
        |ctx| {
            let (l, options) = library_parts(ctx)?;
            let attributes = ctx.limits().max_ray_hit_attribute_size + 4;
            let huge = LibraryOptions {
                interface: Some(InterfaceSizes { payload: 64, hit_attributes: attributes }),
                ..options
            };
            refused(PipelineLibrary::<Params>::new(ctx, &[&l.hit], huge), "hit attributes past the limit")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::HitAttributesTooLarge { .. })),
    )
}

#[test]
fn group_in_two_libraries_of_one_pipeline() -> anyhow::Result<()> {
    case(
        "group_in_two_libraries_of_one_pipeline",
        &[],
        |ctx| {
            let (l, options) = library_parts(ctx)?;
            let common = PipelineLibrary::<Params>::new(ctx, &[&l.raygen, &l.miss], options)?;
            let misses = PipelineLibrary::<Params>::new(ctx, &[&l.miss], options)?;
            let hits = PipelineLibrary::<Params>::new(ctx, &[&l.hit], options)?;
            refused(Pipeline::link(ctx, &[&common, &misses, &hits], LinkOptions::default()), "the miss group twice")
        },
        |e| {
            matches!(
                e,
                Error::Link(raykit::LinkError::GroupInSeveralLibraries {
                    kind: raykit::GroupKind::Miss,
                    first: 0,
                    second: 1
                })
            )
        },
    )
}

#[test]
fn libraries_without_a_raygen_group() -> anyhow::Result<()> {
    case(
        "libraries_without_a_raygen_group",
        &[],
        |ctx| {
            let (l, options) = library_parts(ctx)?;
            let misses = PipelineLibrary::<Params>::new(ctx, &[&l.miss], options)?;
            let hits = PipelineLibrary::<Params>::new(ctx, &[&l.hit], options)?;
            refused(Pipeline::link(ctx, &[&misses, &hits], LinkOptions::default()), "no raygen")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::NoRaygen)),
    )
}

// ---------------------------------------------------------------- device limits

#[test]
fn ias_of_more_instances_than_the_device_allows() -> anyhow::Result<()> {
    case(
        "ias_of_more_instances_than_the_device_allows",
        &["maxInstanceCount", "split the input"],
        |ctx| {
            let gas = Gas::triangles(ctx, &[Vec3::ZERO, Vec3::X, Vec3::Y], None)?;
            let limit = usize::try_from(ctx.limits().max_instance_count)?;
            anyhow::ensure!(limit <= 1 << 24, "maxInstanceCount {limit}: too many instances to make here");
            let instances = vec![Instance::new(&gas); limit + 1];
            refused(Ias::new(ctx, &instances), "one instance past maxInstanceCount")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::Limit { limit_name: "maxInstanceCount", .. })),
    )
}

#[test]
fn texture_past_a_full_texture_table() -> anyhow::Result<()> {
    case(
        "texture_past_a_full_texture_table",
        &["4095"],
        |ctx| {
            let mut textures = Vec::new();
            loop {
                match srgb_texture(ctx, 1, 1, &[255; 4], Mipmaps::One) {
                    Ok(t) => textures.push(t),
                    Err(e) => {
                        anyhow::ensure!(textures.len() == 4095, "refused after {} textures", textures.len());
                        // A slot freed is a slot to use again.
                        textures.pop();
                        textures.push(srgb_texture(ctx, 1, 1, &[255; 4], Mipmaps::One)?);
                        return Ok(e);
                    }
                }
                anyhow::ensure!(textures.len() <= 4096, "4096 textures were accepted");
            }
        },
        |e| matches!(e, Error::Resource(ResourceError::TextureTableFull { capacity: 4095 })),
    )
}

// ---------------------------------------------------------------- what only the CPU backend refuses

#[test]
fn gpu_timestamps_on_the_cpu_backend() -> anyhow::Result<()> {
    cpu_case(
        "GPU timestamps are part of Vulkan: a Vulkan context gives a LaunchTimer",
        "gpu_timestamps_on_the_cpu_backend",
        &["GPU timestamps", "Backend::Vulkan"],
        |ctx| refused(raykit::LaunchTimer::new(ctx), "a launch timer"),
        |e| matches!(e, Error::Device(raykit::DeviceError::NotOnCpuBackend { .. })),
    )
}

/// The triangle's params, field for field, as another type.
#[repr(C)]
#[derive(Copy, Clone, raykit::bytemuck::Pod, raykit::bytemuck::Zeroable, raykit::LaunchParams)]
#[bytemuck(crate = "raykit::bytemuck")]
struct TwinParams {
    image: raykit::Buffer<u32>,
    size: raykit::glam::UVec2,
    cam_eye: Vec3,
    cam_u: Vec3,
    cam_v: Vec3,
    cam_w: Vec3,
    _pad: u32,
    handle: raykit::Traversable,
}

#[test]
fn params_of_another_type_with_the_same_layout() -> anyhow::Result<()> {
    cpu_case(
        "a Rust program on the CPU reads its params through its own type; Vulkan compares layouts, and this one matches",
        "params_of_another_type_with_the_same_layout",
        &["TwinParams", "Params"],
        |ctx| {
            let p = triangle::Programs::rust(ctx)?;
            refused(Pipeline::<TwinParams>::new(ctx, &[&p.raygen], LinkOptions::default()), "a twin params type")
        },
        |e| matches!(e, Error::Link(raykit::LinkError::CpuTypeMismatch { what: "launch params", .. })),
    )
}

#[test]
fn params_of_another_type_with_the_same_layout_link_on_vulkan() -> anyhow::Result<()> {
    with_context("params_of_another_type_with_the_same_layout_link_on_vulkan", |ctx| {
        let p = triangle::Programs::rust(ctx)?;
        Pipeline::<TwinParams>::new(ctx, &[&p.raygen], LinkOptions::default())?;
        Ok(())
    })
}

#[test]
fn mesh_with_fewer_normals_than_positions() -> anyhow::Result<()> {
    case(
        "mesh_with_fewer_normals_than_positions",
        &["3 normals for 4 positions", "one per position"],
        |ctx| {
            let quad = raykit::Mesh::quad(Vec3::ZERO, Vec3::X, Vec3::Y);
            refused(Gas::mesh(ctx, &raykit::Mesh { normals: Some(vec![Vec3::Z; 3]), ..quad }), "three normals")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::MeshAttribute { attribute: "normals", .. })),
    )
}

#[test]
fn mesh_with_a_nan_texture_coordinate() -> anyhow::Result<()> {
    case(
        "mesh_with_a_nan_texture_coordinate",
        &["texture coordinate 2", "not finite"],
        |ctx| {
            let mut quad = raykit::Mesh::quad(Vec3::ZERO, Vec3::X, Vec3::Y);
            if let Some(uvs) = &mut quad.uvs {
                uvs[2].x = f32::NAN;
            }
            refused(Gas::mesh(ctx, &quad), "a NaN uv")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::MeshAttribute { attribute: "uvs", .. })),
    )
}

#[test]
fn refit_of_a_mesh_gas() -> anyhow::Result<()> {
    case(
        "refit_of_a_mesh_gas",
        &["Gas::mesh"],
        |ctx| {
            let quad = raykit::Mesh::quad(Vec3::ZERO, Vec3::X, Vec3::Y);
            let mut gas = Gas::mesh(ctx, &quad)?;
            let input = raykit::Triangles::new(&quad.positions).indices_u32(&quad.indices);
            refused(gas.update(&[input.into()]), "a refit")
        },
        |e| matches!(e, Error::Accel(raykit::AccelError::UpdateRefused { what: "GAS", .. })),
    )
}

#[test]
fn texture_from_a_missing_image_file() -> anyhow::Result<()> {
    case(
        "texture_from_a_missing_image_file",
        &["no-such-picture.png", "PNG or JPEG"],
        |ctx| {
            let path = std::env::temp_dir().join("raykit-no-such-picture.png");
            refused(Texture::load(ctx, &path, true, Mipmaps::One, SamplerOptions::default()), "a missing file")
        },
        |e| matches!(e, Error::Resource(raykit::ResourceError::ImageFile { .. })),
    )
}

#[test]
fn texture_from_a_file_that_is_no_image() -> anyhow::Result<()> {
    case(
        "texture_from_a_file_that_is_no_image",
        &["not-an-image.png"],
        |ctx| {
            let path = std::env::temp_dir().join(format!("raykit-{}-not-an-image.png", std::process::id()));
            std::fs::write(&path, b"these bytes are no picture")?;
            let result = Texture::load(ctx, &path, true, Mipmaps::One, SamplerOptions::default());
            std::fs::remove_file(&path)?;
            refused(result, "a text file")
        },
        |e| matches!(e, Error::Resource(raykit::ResourceError::ImageFile { .. })),
    )
}
