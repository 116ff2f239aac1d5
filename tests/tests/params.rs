//! Typed launch params: structs of every supported shape reach the device with
//! every field's value intact, whichever way raykit delivers them; structs whose
//! layout differs between the host and the SPIR-V are refused at link time with
//! an error naming the field.

use params_device::{Aligned, Inner, Large, Mixed, NestedDependent, TargetDependent, Words};
use raykit::glam::{Mat4, UVec2, Vec2, Vec3, Vec3A, Vec4};
use raykit::{
    Context, Error, LaunchParams, LayoutError, LinkOptions, Module, ParamsDelivery, Pipeline, ProgramGroup, Sbt,
};
use raykit_tests::{with_context, with_each_backend};

/// Launches `entry` once with `params` (whose `out` is replaced by a fresh buffer)
/// and returns the words it wrote.
fn round_trip<P: LaunchParams + Words>(
    ctx: &Context,
    entry: raykit::EntryPoint,
    mut params: P,
    set_out: impl Fn(&mut P, raykit::Buffer<u32>),
    words: usize,
) -> anyhow::Result<(Vec<u32>, ParamsDelivery)> {
    let module = Module::from_device_crate(ctx, "params-device")?;
    let raygen = ProgramGroup::raygen(&module, entry)?;
    let pipeline = Pipeline::<P>::new(ctx, &[&raygen], LinkOptions::default())?;
    let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
    let out = ctx.buffer::<u32>(words)?;
    set_out(&mut params, out.handle());
    pipeline.launch(&sbt, &params, [1, 1, 1])?;
    Ok((out.read()?, pipeline.params_delivery()))
}

fn expected<P: Words>(params: &P) -> Vec<u32> {
    let mut words = Vec::new();
    params.words(&mut words);
    words
}

/// Distinct, recognisable values: no two words alike, none zero.
fn f(i: u32) -> f32 {
    1.0 + i as f32 * 0.25
}

#[test]
fn mixed_scalars_vectors_arrays_and_nested_structs_arrive_exactly() -> anyhow::Result<()> {
    with_each_backend("mixed_scalars_vectors_arrays_and_nested_structs_arrive_exactly", |ctx, _backend| {
        let params = Mixed {
            out: raykit::Buffer::from_table_index(0),
            a: 0xdead_beef,
            b: -3.5,
            d: -42,
            c: 0x0123_4567_89ab_cdef,
            v2: Vec2::new(f(1), f(2)),
            uv2: UVec2::new(7, 0xffff_fff0),
            v3: Vec3::new(f(3), f(4), f(5)),
            e: f(6),
            arr: [11, 22, 33, 44],
            inner: Inner { x: f(7), y: 99, z: Vec2::new(f(8), f(9)) },
        };
        let want = expected(&params);
        let (got, delivery) = round_trip(ctx, params_device::RG_MIXED, params, |p, b| p.out = b, want.len())?;
        assert_eq!(delivery, ParamsDelivery::PushConstants);
        assert_eq!(got, want);
        Ok(())
    })
}

#[test]
fn glam_16_byte_aligned_types_arrive_exactly() -> anyhow::Result<()> {
    with_each_backend("glam_16_byte_aligned_types_arrive_exactly", |ctx, _backend| {
        let params = Aligned {
            out: raykit::Buffer::from_table_index(0),
            _pad: [0; 3],
            v4: Vec4::new(f(1), f(2), f(3), f(4)),
            v3a: Vec3A::new(f(5), f(6), f(7)),
            m4: Mat4::from_cols_array(&std::array::from_fn(|i| f(10 + i as u32))),
        };
        let want = expected(&params);
        let (got, delivery) = round_trip(ctx, params_device::RG_ALIGNED, params, |p, b| p.out = b, want.len())?;
        assert_eq!(delivery, ParamsDelivery::PushConstants);
        assert_eq!(got, want);
        Ok(())
    })
}

#[test]
fn params_over_the_push_constant_budget_go_through_a_uniform_buffer() -> anyhow::Result<()> {
    with_each_backend("params_over_the_push_constant_budget_go_through_a_uniform_buffer", |ctx, _backend| {
        assert!(std::mem::size_of::<Large>() > raykit::device::PUSH_CONSTANT_BUDGET);
        let params = Large {
            out: raykit::Buffer::from_table_index(0),
            _pad: [0; 3],
            m: Mat4::from_cols_array(&std::array::from_fn(|i| f(i as u32))),
            v: std::array::from_fn(|i| Vec4::splat(f(100 + i as u32)) + Vec4::new(0.0, 0.5, 1.0, 1.5)),
            tail: std::array::from_fn(|i| f(200 + i as u32)),
            id: u64::MAX - 12345,
            _pad2: 0,
        };
        let want = expected(&params);
        let (got, delivery) = round_trip(ctx, params_device::RG_LARGE, params, |p, b| p.out = b, want.len())?;
        assert_eq!(delivery, ParamsDelivery::UniformBuffer { set: 1, binding: 0 });
        assert_eq!(got, want);
        // Two launches in a row with different values: each sees its own.
        let module = Module::from_device_crate(ctx, "params-device")?;
        let raygen = ProgramGroup::raygen(&module, params_device::RG_LARGE)?;
        let pipeline = Pipeline::<Large>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let out = ctx.buffer::<u32>(want.len())?;
        for id in [1u64, 2] {
            let p = Large { out: out.handle(), id, ..params };
            pipeline.launch(&sbt, &p, [1, 1, 1])?;
            assert_eq!(out.read()?, expected(&p));
        }
        Ok(())
    })
}

#[test]
fn async_launches_in_flight_each_see_their_own_uniform_params() -> anyhow::Result<()> {
    with_each_backend("async_launches_in_flight_each_see_their_own_uniform_params", |ctx, _backend| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        let raygen = ProgramGroup::raygen(&module, params_device::RG_LARGE)?;
        let pipeline = Pipeline::<Large>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let base = Large {
            out: raykit::Buffer::from_table_index(0),
            _pad: [0; 3],
            m: Mat4::from_cols_array(&std::array::from_fn(|i| f(i as u32))),
            v: std::array::from_fn(|i| Vec4::splat(f(100 + i as u32))),
            tail: std::array::from_fn(|i| f(200 + i as u32)),
            id: 0,
            _pad2: 0,
        };
        let len = expected(&base).len();
        let outs = (0..4).map(|_| ctx.buffer::<u32>(len)).collect::<raykit::Result<Vec<_>>>()?;
        let params: Vec<Large> =
            outs.iter().enumerate().map(|(i, out)| Large { out: out.handle(), id: 1000 + i as u64, ..base }).collect();
        // All four submitted before any is waited for: one uniform buffer, four values.
        let launches =
            params.iter().map(|p| pipeline.launch_async(&sbt, p, [1, 1, 1])).collect::<raykit::Result<Vec<_>>>()?;
        for launch in launches {
            launch.wait()?;
        }
        for (out, p) in outs.iter().zip(&params) {
            assert_eq!(out.read()?, expected(p));
        }
        Ok(())
    })
}

fn layout_error(err: &Error) -> Option<&LayoutError> {
    match err {
        Error::Link(raykit::LinkError::ParamsLayout(e)) => Some(e),
        _ => None,
    }
}

fn link_error<P: LaunchParams>(ctx: &Context, groups: &[&ProgramGroup]) -> anyhow::Result<Error> {
    match Pipeline::<P>::new(ctx, groups, LinkOptions::default()) {
        Ok(_) => anyhow::bail!("Pipeline::<{}> linked, but its layout differs from the SPIR-V", P::LAYOUT.name),
        Err(e) => Ok(e),
    }
}

#[test]
fn a_field_at_another_offset_in_the_spirv_is_refused_by_name() -> anyhow::Result<()> {
    with_context("a_field_at_another_offset_in_the_spirv_is_refused_by_name", |ctx| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        let raygen = ProgramGroup::raygen(&module, params_device::RG_TARGET_DEPENDENT)?;
        let err = link_error::<TargetDependent>(ctx, &[&raygen])?;
        let Some(LayoutError::Mismatch { struct_name, entry, field, host, device, .. }) = layout_error(&err) else {
            anyhow::bail!("expected ParamsLayoutMismatch, got {err:?}");
        };
        assert_eq!(
            (*struct_name, entry.as_str(), field.as_str()),
            ("TargetDependent", "__raygen__rg_target_dependent", "value")
        );
        // The first difference: at offset 4 the host has `value`, the SPIR-V its padding.
        assert!(host.contains("offset 4") && host.contains("[f32;4]") && device.contains("array of 3"), "{err}");
        Ok(())
    })
}

#[test]
fn a_nested_field_that_differs_is_named_with_its_path() -> anyhow::Result<()> {
    with_context("a_nested_field_that_differs_is_named_with_its_path", |ctx| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        let raygen = ProgramGroup::raygen(&module, params_device::RG_NESTED_DEPENDENT)?;
        let err = link_error::<NestedDependent>(ctx, &[&raygen])?;
        // `inner` has one field on the host and two in the SPIR-V: the check
        // descends into the nested struct and names the path.
        assert!(
            matches!(layout_error(&err), Some(LayoutError::Mismatch { field, .. }) if field.starts_with("inner.")),
            "{err:?}"
        );
        Ok(())
    })
}

#[test]
fn a_pipeline_typed_with_another_struct_is_refused() -> anyhow::Result<()> {
    with_context("a_pipeline_typed_with_another_struct_is_refused", |ctx| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        let raygen = ProgramGroup::raygen(&module, params_device::RG_ALIGNED)?;
        let err = link_error::<Mixed>(ctx, &[&raygen])?;
        let text = err.to_string();
        assert!(matches!(layout_error(&err), Some(LayoutError::Mismatch { struct_name: "Mixed", .. })), "{err:?}");
        assert!(text.contains("__raygen__rg_aligned"), "{text}");
        // The context is still usable: the right type links.
        Pipeline::<Aligned>::new(ctx, &[&raygen], LinkOptions::default())?;
        Ok(())
    })
}

#[test]
fn modules_of_one_pipeline_must_agree_on_the_params() -> anyhow::Result<()> {
    with_context("modules_of_one_pipeline_must_agree_on_the_params", |ctx| {
        let triangle = Module::from_device_crate(ctx, "triangle-device")?;
        let raygen = ProgramGroup::raygen(&triangle, triangle_device::RG)?;
        // A GLSL miss program whose push-constant block is `{ vec4 tint; float scale; }`.
        let other = Module::new(ctx, include_bytes!("../data/miss_other_params.rmiss.spv"))?;
        let miss = ProgramGroup::miss(&other, "main")?;
        let err = link_error::<triangle_device::Params>(ctx, &[&raygen, &miss])?;
        assert!(
            matches!(layout_error(&err), Some(LayoutError::Mismatch { entry, struct_name: "Params", .. }) if entry == "main"),
            "{err:?}"
        );
        Ok(())
    })
}

#[test]
fn a_program_reading_params_another_way_than_raykit_delivers_them_is_refused() -> anyhow::Result<()> {
    with_context("a_program_reading_params_another_way_than_raykit_delivers_them_is_refused", |ctx| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        let raygen = ProgramGroup::raygen(&module, params_device::RG_LARGE)?;
        // The GLSL miss reads push constants; `Large` travels in a uniform buffer.
        let other = Module::new(ctx, include_bytes!("../data/miss_other_params.rmiss.spv"))?;
        let miss = ProgramGroup::miss(&other, "main")?;
        let err = link_error::<Large>(ctx, &[&raygen, &miss])?;
        assert!(matches!(layout_error(&err), Some(LayoutError::Delivery { entry, .. }) if entry == "main"), "{err:?}");
        assert!(err.to_string().contains("uniform buffer (set 1, binding 0)"), "{err}");
        Ok(())
    })
}

#[test]
fn the_reflected_blocks_match_the_derived_layouts() -> anyhow::Result<()> {
    with_context("the_reflected_blocks_match_the_derived_layouts", |ctx| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        for (entry, layout) in [
            (params_device::RG_MIXED, Mixed::LAYOUT),
            (params_device::RG_ALIGNED, Aligned::LAYOUT),
            (params_device::RG_LARGE, Large::LAYOUT),
        ] {
            let info = module
                .entry_points()
                .iter()
                .find(|e| e.name == entry.name)
                .ok_or_else(|| anyhow::anyhow!("{} missing", entry.name))?;
            assert!(!info.params.is_empty(), "{} declares no params block", entry.name);
            let block = info
                .params
                .iter()
                .find(|b| b.delivery == raykit::params_delivery::<Mixed>() || layout.size > 128)
                .ok_or_else(|| anyhow::anyhow!("no block"))?;
            // rust-gpu wraps the struct in a one-member block.
            let members = match block.members.as_slice() {
                [raykit::BlockMember { ty: raykit::BlockType::Struct(inner), .. }] if layout.fields.len() > 1 => inner,
                other => other,
            };
            let offsets: Vec<u32> = members.iter().map(|m| m.offset).collect();
            let host: Vec<u32> = layout.fields.iter().map(|f| f.offset).collect();
            assert_eq!(offsets, host, "{}", entry.name);
        }
        Ok(())
    })
}

#[test]
fn the_build_time_check_gives_the_link_time_message() -> anyhow::Result<()> {
    with_context("the_build_time_check_gives_the_link_time_message", |ctx| {
        // What `cargo xtask build-shaders` runs for each `#[params]` program (the
        // test `#[raygen]` generates), on a program that opted out of it.
        let path = raykit::spirv_path("params-device");
        let build_time = raykit::spirv::check_file(
            &path,
            params_device::RG_TARGET_DEPENDENT.name,
            &TargetDependent::LAYOUT,
            raykit::device::uses_push_constants::<TargetDependent>(),
        )
        .err()
        .ok_or_else(|| anyhow::anyhow!("the build-time check accepted TargetDependent"))?;
        let module = Module::from_device_crate(ctx, "params-device")?;
        let raygen = ProgramGroup::raygen(&module, params_device::RG_TARGET_DEPENDENT)?;
        let link_time = link_error::<TargetDependent>(ctx, &[&raygen])?;
        assert_eq!(build_time.to_string(), link_time.to_string());
        Ok(())
    })
}
