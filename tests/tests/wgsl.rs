//! WGSL programs through naga: what raykit refuses, and why. (The pictures are
//! in triangle.rs and path_tracer.rs, against the CPU references.)

use raykit::{Error, LayoutError, LinkOptions, Module, Pipeline, ProgramGroup, WgslError};
use raykit_tests::with_context;

fn wgsl_error(result: raykit::Result<Module>) -> anyhow::Result<WgslError> {
    match result {
        Ok(_) => anyhow::bail!("the module loaded, but it should have been refused"),
        Err(Error::Module(raykit::ModuleError::Wgsl(e))) => Ok(*e),
        Err(other) => anyhow::bail!("expected Error::Module(raykit::ModuleError::Wgsl), got {other:?}"),
    }
}

/// The triangle's WGSL with `from` replaced by `to` (which must occur).
fn triangle_with(from: &str, to: &str) -> String {
    assert!(triangle::WGSL.contains(from), "the triangle's WGSL no longer contains {from:?}");
    triangle::WGSL.replacen(from, to, 1)
}

#[test]
fn a_wgsl_program_whose_params_disagree_with_the_host_struct_is_refused_with_the_layout_message() -> anyhow::Result<()>
{
    with_context("a_wgsl_program_whose_params_disagree_with_the_host_struct_is_refused", |ctx| {
        // WGSL's vec3<f32> is 16-byte aligned: declared so, `cam_u` moves from the
        // host's offset 24 to 32 (the mistake the prelude's Vec3f avoids).
        let source =
            triangle_with("    cam_u: Vec3f,", "    cam_u: vec3<f32>,").replace("vec3f(params.cam_u)", "params.cam_u");
        let module = Module::from_wgsl_named(ctx, &source, "triangle_vec3.wgsl")?;
        let raygen = ProgramGroup::raygen(&module, "rg")?;
        let err = match Pipeline::<triangle_device::Params>::new(ctx, &[&raygen], LinkOptions::default()) {
            Ok(_) => anyhow::bail!("linked, though `cam_u` sits elsewhere in the WGSL"),
            Err(e) => e,
        };
        let Error::Link(raykit::LinkError::ParamsLayout(layout)) = &err else {
            anyhow::bail!("expected Error::Link(raykit::LinkError::ParamsLayout), got {err:?}")
        };
        let LayoutError::Mismatch { struct_name, entry, field, host, device, .. } = layout.as_ref() else {
            anyhow::bail!("expected a layout mismatch, got {layout:?}");
        };
        assert_eq!((*struct_name, entry.as_str(), field.as_str()), ("Params", "rg", "cam_u"), "{err}");
        assert!(host.contains("offset 24") && device.contains("offset 32"), "{err}");
        assert!(err.to_string().contains("do not match the SPIR-V of `rg`: field `cam_u`"), "{err}");
        // The right struct links.
        let good = Module::from_wgsl(ctx, triangle::WGSL)?;
        Pipeline::<triangle_device::Params>::new(ctx, &[&ProgramGroup::raygen(&good, "rg")?], LinkOptions::default())?;
        Ok(())
    })
}

#[test]
fn a_wgsl_syntax_error_reports_its_span() -> anyhow::Result<()> {
    with_context("a_wgsl_syntax_error_reports_its_span", |ctx| {
        // Line 56 of the triangle's WGSL, `    incoming_color = vec3f(miss_data.bg_color);`, loses its `;`.
        let source = triangle_with("vec3f(miss_data.bg_color);", "vec3f(miss_data.bg_color)");
        let line = source.lines().position(|l| l.contains("vec3f(miss_data.bg_color)")).map(|i| i as u32 + 1);
        let err = wgsl_error(Module::from_wgsl_named(ctx, &source, "triangle.wgsl"))?;
        let WgslError::Parse { path, line: at_line, column, rendered, .. } = &err else {
            anyhow::bail!("expected a parse error, got {err:?}");
        };
        // The error is at the start of the next line's `}`.
        assert_eq!(path, "triangle.wgsl");
        assert_eq!((Some(*at_line), *column), (line.map(|l| l + 1), 1), "{err}");
        assert!(rendered.contains(&format!("triangle.wgsl:{at_line}:1")), "{rendered}");
        assert!(rendered.contains('^'), "no caret under the span:\n{rendered}");
        Ok(())
    })
}

#[test]
fn a_wgsl_validation_error_reports_its_span() -> anyhow::Result<()> {
    with_context("a_wgsl_validation_error_reports_its_span", |ctx| {
        // traceRay's payload must be a ray_payload global, not a local variable.
        let source = format!(
            "{}\nfn trace_into_local(origin: vec3<f32>, dir: vec3<f32>) -> vec3<f32> {{\n    var local = vec3<f32>(0.0);\n    \
             traceRay(scene, RayDesc(0u, 0xffu, 0.0, 1e16, origin, dir), &local);\n    return local;\n}}\n",
            triangle::WGSL
        );
        let line = source.lines().position(|l| l.starts_with("fn trace_into_local")).map(|i| i as u32 + 1);
        let err = wgsl_error(Module::from_wgsl_named(ctx, &source, "triangle.wgsl"))?;
        let WgslError::Validation { line: at_line, message, rendered, .. } = &err else {
            anyhow::bail!("expected a validation error, got {err:?}");
        };
        assert_eq!(*at_line, line, "{err}");
        assert!(message.contains("`ray_payload`"), "{message}");
        assert!(
            rendered.contains(&format!("triangle.wgsl:{}:1", line.unwrap_or(0))) && rendered.contains('^'),
            "{rendered}"
        );
        // Entry-point errors come without a span from naga; they still name the entry point.
        let source = triangle_with(
            "@builtin(num_ray_invocations) dims: vec3<u32>)",
            "@builtin(num_ray_invocations) dims: vec3<u32>, @builtin(ray_t_current_max) t: f32)",
        );
        let err = wgsl_error(Module::from_wgsl_named(ctx, &source, "triangle.wgsl"))?;
        assert!(matches!(err, WgslError::Validation { .. }), "{err:?}");
        assert!(err.to_string().contains("Entry point rg at RayGeneration is invalid"), "{err}");
        Ok(())
    })
}

#[test]
fn stages_and_intrinsics_naga_lacks_are_refused_by_name() -> anyhow::Result<()> {
    with_context("stages_and_intrinsics_naga_lacks_are_refused_by_name", |ctx| {
        let intersection = triangle_with("@closest_hit @incoming_payload(incoming_color)", "@intersection");
        let err = wgsl_error(Module::from_wgsl(ctx, &intersection))?;
        let WgslError::Unsupported { feature, line, .. } = &err else {
            anyhow::bail!("expected Unsupported, got {err:?}");
        };
        assert_eq!(feature, "intersection");
        assert!(*line > 1 && err.to_string().contains("write this program in Rust (rust-gpu) or GLSL"), "{err}");

        let callable = triangle_with("@miss @incoming_payload(incoming_color)", "@callable");
        let err = wgsl_error(Module::from_wgsl(ctx, &callable))?;
        assert!(matches!(&err, WgslError::Unsupported { feature, .. } if feature == "callable"), "{err:?}");

        let ignore = triangle_with("    let b = barycentrics;", "    ignoreIntersection();\n    let b = barycentrics;");
        let err = wgsl_error(Module::from_wgsl(ctx, &ignore))?;
        assert!(matches!(&err, WgslError::Unsupported { feature, .. } if feature == "ignoreIntersection"), "{err:?}");
        Ok(())
    })
}

#[test]
fn declarations_against_raykits_conventions_are_refused_with_the_fix() -> anyhow::Result<()> {
    with_context("declarations_against_raykits_conventions_are_refused_with_the_fix", |ctx| {
        // The traversable names a params member that is not a Traversable.
        let wrong_member = triangle_with("@group(2) @binding(7) var scene", "@group(2) @binding(6) var scene");
        let err = wgsl_error(Module::from_wgsl(ctx, &wrong_member))?;
        assert!(
            matches!(&err, WgslError::Convention { reason, .. } if reason.contains("member 6, which is not a Traversable")),
            "{err:?}"
        );
        // An acceleration structure at a binding raykit does not fill.
        let unbound = triangle_with("@group(2) @binding(7) var scene", "@group(0) @binding(1) var scene");
        let err = wgsl_error(Module::from_wgsl(ctx, &unbound))?;
        assert!(err.to_string().contains("declare it at @group(2) @binding(K)"), "{err}");
        Ok(())
    })
}

/// `params_device::Large` (192 bytes) in WGSL: over the push-constant budget, so
/// raykit delivers it in a uniform buffer at set 1, binding 0, which WGSL declares
/// `var<storage, read>` there (WGSL's uniform layout would pad each struct member
/// to 16 bytes; raykit turns the binding into its uniform buffer).
const LARGE_WGSL: &str = r#"
enable wgpu_ray_tracing_pipeline;
enable wgpu_binding_array;
struct Words { words: array<u32> }
@group(0) @binding(0) var<storage, read_write> buffers: binding_array<Words>;
struct Large {
    out: u32,
    pad: array<u32, 3>,
    m: mat4x4<f32>,
    v: array<vec4<f32>, 4>,
    tail: array<f32, 8>,
    id: vec2<u32>,
    pad2: vec2<u32>,
}
@group(1) @binding(0) var<storage, read> params: Large;

@ray_generation
fn rg() {
    var i = 0u;
    for (var c = 0u; c < 4u; c++) {
        for (var r = 0u; r < 4u; r++) { buffers[params.out & 4095u].words[i] = bitcast<u32>(params.m[c][r]); i++; }
    }
    for (var k = 0u; k < 4u; k++) {
        for (var r = 0u; r < 4u; r++) { buffers[params.out & 4095u].words[i] = bitcast<u32>(params.v[k][r]); i++; }
    }
    for (var k = 0u; k < 8u; k++) { buffers[params.out & 4095u].words[i] = bitcast<u32>(params.tail[k]); i++; }
    buffers[params.out & 4095u].words[i] = params.id.x;
    buffers[params.out & 4095u].words[i + 1u] = params.id.y;
}
"#;

#[test]
fn wgsl_params_over_the_push_constant_budget_arrive_exactly_through_the_uniform_buffer() -> anyhow::Result<()> {
    use raykit::glam::{Mat4, Vec4};
    with_context("wgsl_params_over_the_push_constant_budget_arrive_exactly_through_the_uniform_buffer", |ctx| {
        let module = Module::from_wgsl_named(ctx, LARGE_WGSL, "large.wgsl")?;
        let blocks = &module.entry_points()[0].params;
        assert_eq!(
            blocks.iter().map(|b| b.delivery).collect::<Vec<_>>(),
            [raykit::ParamsDelivery::UniformBuffer { set: 1, binding: 0 }]
        );
        let raygen = ProgramGroup::raygen(&module, "rg")?;
        let pipeline = Pipeline::<params_device::Large>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = raykit::Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let out = ctx.buffer::<u32>(42)?;
        let f = |i: u32| 1.0 + i as f32 * 0.25;
        let params = params_device::Large {
            out: out.handle(),
            _pad: [0; 3],
            m: Mat4::from_cols_array(&std::array::from_fn(|i| f(i as u32))),
            v: std::array::from_fn(|i| Vec4::splat(f(100 + i as u32)) + Vec4::new(0.0, 0.5, 1.0, 1.5)),
            tail: std::array::from_fn(|i| f(200 + i as u32)),
            id: u64::MAX - 12345,
            _pad2: 0,
        };
        pipeline.launch(&sbt, &params, [1, 1, 1])?;
        let mut want: Vec<u32> = params.m.to_cols_array().iter().map(|x| x.to_bits()).collect();
        want.extend(params.v.iter().flat_map(|v| v.to_array()).map(f32::to_bits));
        want.extend(params.tail.iter().map(|x| x.to_bits()));
        want.extend([params.id as u32, (params.id >> 32) as u32]);
        assert_eq!(out.read()?, want);
        Ok(())
    })
}
