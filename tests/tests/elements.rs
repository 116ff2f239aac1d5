//! User structs in buffers: `#[derive(Element)]` structs go into a
//! `DeviceBuffer<T>` on the host, a program reads and writes them as `Buffer<T>`,
//! and every field arrives exactly, on each backend; a struct laid out
//! differently on the host and in the SPIR-V is refused, naming the field.

use params_device::elements::{ElementParams, Material, Shifted, Sphere, RG_ELEMENTS};
use raykit::glam::{IVec2, Vec3};
use raykit::{Buffer, Element, Error, LayoutError, LinkOptions, Module, ModuleError, Pipeline, ProgramGroup, Sbt};
use raykit_tests::{with_context, with_each_backend};

/// Sixteen spheres with distinct, exactly representable values in every field.
fn spheres() -> Vec<Sphere> {
    (0..16u32)
        .map(|i| {
            let f = i as f32;
            Sphere {
                centre: Vec3::new(f + 0.25, -f * 1.5, 100.0 + f),
                radius: 0.125 * (f + 1.0),
                id: 0x0123_4567_89ab_0000 + u64::from(i),
                material: Material { albedo: Vec3::new(0.5, f / 16.0, 1.0 - f / 32.0), kind: 3 * i },
                neighbours: IVec2::new(i as i32 - 8, 1000 - i as i32),
                texels: Buffer::from_table_index(40 + i),
                bias: -(i as i32) * 7,
            }
        })
        .collect()
}

/// What the program makes of sphere `i`, written out field by field (not through
/// the crate's `transformed`).
fn expected(s: &Sphere, i: u32) -> Sphere {
    Sphere {
        centre: Vec3::new(2.0 * s.centre.x, 2.0 * s.centre.y, 2.0 * s.centre.z),
        radius: s.radius + 0.5,
        id: s.id + (u64::from(i) << 32),
        material: Material {
            albedo: Vec3::new(s.material.albedo.z, s.material.albedo.y, s.material.albedo.x),
            kind: s.material.kind + i,
        },
        neighbours: IVec2::new(-s.neighbours.y, s.neighbours.x),
        texels: Buffer::from_table_index(s.texels.raw() + 1),
        bias: s.bias - i as i32,
    }
}

#[test]
fn user_structs_in_buffers_round_trip_through_a_program_exactly() -> anyhow::Result<()> {
    with_each_backend("user_structs_in_buffers_round_trip_through_a_program_exactly", |ctx, _backend| {
        assert_eq!(Sphere::WORDS, 14);
        assert_eq!(std::mem::size_of::<Sphere>(), 56);
        let module = Module::from_device_crate(ctx, "params-device")?;
        // The SPIR-V records the device layout of both structs; it matches the host's.
        module.check_element::<Sphere>()?;
        module.check_element::<Material>()?;
        let raygen = ProgramGroup::raygen(&module, RG_ELEMENTS)?;
        let pipeline = Pipeline::<ElementParams>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let input = spheres();
        let spheres_in = ctx.buffer_from(&input)?;
        let out = ctx.buffer::<Sphere>(input.len())?;
        let materials = ctx.buffer::<Material>(input.len())?;
        let params = ElementParams { spheres: spheres_in.handle(), out: out.handle(), materials: materials.handle() };
        pipeline.launch(&sbt, &params, [input.len() as u32, 1, 1])?;
        let want: Vec<Sphere> = input.iter().zip(0..).map(|(s, i)| expected(s, i)).collect();
        assert_eq!(out.read()?, want);
        let want_materials: Vec<Material> = want.iter().map(|s| s.material).collect();
        assert_eq!(materials.read()?, want_materials);
        // The words on the host are the struct's bytes: 14 words a sphere, fields in order.
        let words: &[u32] = bytemuck::cast_slice(&want[..1]);
        assert_eq!(words[0], want[0].centre.x.to_bits());
        assert_eq!(words[4], want[0].id as u32);
        assert_eq!(words[5], (want[0].id >> 32) as u32);
        assert_eq!(words[9], want[0].material.kind);
        assert_eq!(words[13], want[0].bias as u32);
        Ok(())
    })
}

#[test]
fn an_element_laid_out_differently_in_the_spirv_is_refused_naming_the_field() -> anyhow::Result<()> {
    with_context("an_element_laid_out_differently_in_the_spirv_is_refused_naming_the_field", |ctx| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        let err = module.check_element::<Shifted>().err().ok_or_else(|| anyhow::anyhow!("Shifted was accepted"))?;
        let Error::Module(ModuleError::ElementLayout(layout)) = &err else { anyhow::bail!("{err:?}") };
        // On the host `value` is word 0; in the SPIR-V a device-only field is.
        assert!(
            matches!(&**layout, LayoutError::ElementMismatch { struct_name: "Shifted", field, .. } if field == "value"),
            "{layout:?}"
        );
        let text = err.to_string();
        assert!(text.contains("`value`") && text.contains("cargo xtask build-shaders"), "{text}");
        // The build-time check (the test the derive generates in a device crate,
        // skipped for this struct) gives the same message.
        let build_time = raykit::spirv::check_element_file(&raykit::spirv_path("params-device"), &Shifted::SHAPE)
            .err()
            .ok_or_else(|| anyhow::anyhow!("the build-time check accepted Shifted"))?;
        assert_eq!(build_time.to_string(), text);
        Ok(())
    })
}

/// An element defined outside any device crate: no SPIR-V records it.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, Element)]
struct HostOnly {
    value: u32,
}

#[test]
fn a_module_that_does_not_record_the_element_says_where_to_look() -> anyhow::Result<()> {
    with_context("a_module_that_does_not_record_the_element_says_where_to_look", |ctx| {
        let module = Module::from_device_crate(ctx, "params-device")?;
        let err = module.check_element::<HostOnly>().err().ok_or_else(|| anyhow::anyhow!("HostOnly was accepted"))?;
        assert!(
            matches!(&err, Error::Module(ModuleError::ElementLayout(e))
                if matches!(&**e, LayoutError::ElementNotRecorded { struct_name: "HostOnly", .. })),
            "{err:?}"
        );
        assert!(err.to_string().contains("__raykit_element__HostOnly"), "{err}");
        Ok(())
    })
}
