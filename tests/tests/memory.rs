//! Where buffers live: device-local by default, reached by the host in place
//! where it can map them and through staging copies elsewhere. The staging path
//! is forced on drivers whose device-local memory the host maps (lavapipe) with
//! the `fault-injection` hook `Context::force_staging_copies`, so it is tested
//! here whatever the device; every result is compared with the in-place one.

use raykit::glam::Vec4;
use raykit::{Backend, BufferMemory, Context, DeviceBuffer, Gas, Ias, LinkOptions, Pipeline, Sbt};
use raykit_tests::{with_context, with_each_backend};
use triangle_device::{MissData, Params};

/// A triangle picture rendered into a buffer that `staging` says is reached
/// through staging copies or not: the pixels through `read`, `read_async` and
/// `read_into` in two halves.
fn triangle_reads(ctx: &Context, staging: bool) -> anyhow::Result<[Vec<u32>; 3]> {
    ctx.force_staging_copies(staging);
    let (width, height) = (96u32, 64u32);
    let triangle::Programs { raygen, miss, hit } = triangle::Programs::rust(ctx)?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
    let sbt = Sbt::builder(&pipeline)
        .raygen(&raygen, ())
        .miss(&miss, MissData { bg_color: triangle::BG_COLOR })
        .hit(&hit, ())
        .build()?;
    let gas = Gas::triangles(ctx, &triangle::VERTICES, None)?;
    let ias = Ias::single(ctx, &gas)?;
    let image = DeviceBuffer::<u32>::zeroed(ctx, (width * height) as usize)?;
    assert_eq!(image.is_host_mapped(), !staging || ctx.backend() == Backend::Cpu);
    let params = triangle::params(width, height, image.handle(), ias.handle());
    pipeline.launch(&sbt, &params, [width, height, 1])?;
    let read = image.read()?;
    let read_async = image.read_async()?.wait()?;
    let mut halves = vec![0u32; read.len()];
    let (a, b) = halves.split_at_mut(read.len() / 2);
    image.read_into(0, a)?;
    image.read_into(read.len() / 2, b)?;
    drop((gas, ias));
    ctx.force_staging_copies(false);
    Ok([read, read_async, halves])
}

#[test]
fn a_launch_written_device_local_buffer_reads_the_same_through_staging_as_in_place() -> anyhow::Result<()> {
    with_each_backend("a_launch_written_device_local_buffer_reads_the_same_through_staging_as_in_place", |ctx, _| {
        let in_place = triangle_reads(ctx, false)?;
        let staged = triangle_reads(ctx, true)?;
        raykit_tests::check_triangle_picture(&in_place[0], 96, 64)?;
        for (what, (a, b)) in ["read", "read_async", "read_into"].iter().zip(in_place.iter().zip(&staged)) {
            assert_eq!(a, b, "{what} through staging differs from {what} in place");
            assert_eq!(a, &in_place[0], "{what} differs from read");
        }
        Ok(())
    })
}

#[test]
fn writes_and_uploads_through_staging_land_where_in_place_ones_do() -> anyhow::Result<()> {
    with_context("writes_and_uploads_through_staging_land_where_in_place_ones_do", |ctx| {
        let data: Vec<u32> = (0..1000u32).map(|i| i.wrapping_mul(2_654_435_761)).collect();
        for staging in [false, true] {
            ctx.force_staging_copies(staging);
            let mut buffer = DeviceBuffer::from_slice(ctx, &data)?;
            assert_eq!(buffer.read()?, data, "from_slice (staging {staging})");
            buffer.write_at(100, &[7, 8, 9])?;
            buffer.write(&[1, 2])?;
            let mut want = data.clone();
            want[..2].copy_from_slice(&[1, 2]);
            want[100..103].copy_from_slice(&[7, 8, 9]);
            assert_eq!(buffer.read()?, want, "write and write_at (staging {staging})");
            let zeroed = DeviceBuffer::<Vec4>::zeroed(ctx, 333)?;
            assert!(zeroed.read()?.iter().all(|v| *v == Vec4::ZERO), "zeroed (staging {staging})");
        }
        ctx.force_staging_copies(false);
        Ok(())
    })
}

#[test]
fn host_visible_kinds_map_without_a_copy_and_keep_their_kind() -> anyhow::Result<()> {
    with_each_backend("host_visible_kinds_map_without_a_copy_and_keep_their_kind", |ctx, backend| {
        ctx.force_staging_copies(true);
        for memory in [BufferMemory::HostRead, BufferMemory::HostWrite] {
            let buffer = DeviceBuffer::from_slice_in(ctx, &[5u32, 6, 7], memory)?;
            assert!(buffer.is_host_mapped(), "{memory:?} is mapped");
            let want = if backend == Backend::Cpu { BufferMemory::DeviceLocal } else { memory };
            assert_eq!(buffer.memory(), want);
            assert_eq!(buffer.read()?, [5, 6, 7]);
        }
        assert_eq!(DeviceBuffer::<u32>::zeroed(ctx, 4)?.memory(), BufferMemory::DeviceLocal);
        ctx.force_staging_copies(false);
        Ok(())
    })
}

/// The path tracer accumulates 100 launches into its device-local buffer; read
/// through staging after every tenth, the sums are those read in place.
#[test]
fn a_progressive_accumulation_of_100_launches_reads_the_same_through_staging() -> anyhow::Result<()> {
    with_context("a_progressive_accumulation_of_100_launches_reads_the_same_through_staging", |ctx| {
        let accumulate = |staging: bool| -> anyhow::Result<Vec<Vec<Vec4>>> {
            ctx.force_staging_copies(staging);
            let programs = path_tracer::Programs::rust(ctx)?;
            let scene = path_tracer::Scene::new(ctx)?;
            let mut renderer = path_tracer::Renderer::new(ctx, &programs, &scene, 24, 24)?;
            let mut steps = Vec::new();
            for launch in 1..=100 {
                renderer.launch(1)?;
                if launch % 10 == 0 {
                    steps.push(renderer.accumulation()?);
                }
            }
            ctx.force_staging_copies(false);
            Ok(steps)
        };
        let in_place = accumulate(false)?;
        let staged = accumulate(true)?;
        assert_eq!(in_place.len(), 10);
        for (step, (a, b)) in in_place.iter().zip(&staged).enumerate() {
            assert!(a == b, "the accumulation after {} launches differs through staging", (step + 1) * 10);
        }
        let rays: f64 = in_place[9].iter().map(|v| v.w as f64).sum();
        assert!(rays >= 100.0 * 24.0 * 24.0, "100 launches traced {rays} rays");
        Ok(())
    })
}

/// A buffer dropped while its copy to the host is held on the device (by the
/// submission gate) is freed only after the copy: the read gets its contents, and
/// a buffer made meanwhile does not take over its memory early.
#[test]
fn a_buffer_dropped_during_its_staging_copy_is_not_freed_early() -> anyhow::Result<()> {
    with_each_backend("a_buffer_dropped_during_its_staging_copy_is_not_freed_early", |ctx, backend| {
        for staging in [false, true] {
            ctx.force_staging_copies(staging);
            let data: Vec<u32> = (0..4096u32).map(|i| i ^ 0x5a5a_5a5a).collect();
            let buffer = DeviceBuffer::from_slice(ctx, &data)?;
            let gate = ctx.close_submission_gate()?;
            let pending = buffer.read_async()?;
            drop(buffer);
            // (The CPU backend's gate holds launches; its reads copy at once.)
            if backend == Backend::Vulkan {
                assert!(!pending.is_done()?, "the copy is held on the device");
            }
            // Made (and, through staging, uploaded: a host wait opens the gate) after the drop.
            let other = DeviceBuffer::from_slice(ctx, &vec![0xdead_beefu32; data.len()])?;
            drop(gate);
            assert_eq!(pending.wait()?, data, "the read of a dropped buffer (staging {staging})");
            assert!(other.read()?.iter().all(|&w| w == 0xdead_beef));
        }
        ctx.force_staging_copies(false);
        Ok(())
    })
}

/// Reads and writes of no elements copy nothing and change nothing, in place
/// and through staging, at the start, the middle and the end of a buffer (a
/// Vulkan copy of 0 bytes is invalid: the validation layer would say so); a
/// buffer of no elements is refused alike on both backends.
#[test]
fn reads_and_writes_of_no_elements_copy_nothing_on_both_backends() -> anyhow::Result<()> {
    with_each_backend("reads_and_writes_of_no_elements_copy_nothing_on_both_backends", |ctx, backend| {
        let data: Vec<u32> = (10..18).collect();
        for staging in [false, true] {
            ctx.force_staging_copies(staging);
            for memory in [BufferMemory::DeviceLocal, BufferMemory::HostRead, BufferMemory::HostWrite] {
                let mut buffer = DeviceBuffer::from_slice_in(ctx, &data, memory)?;
                let what = format!("{backend:?}, {memory:?}, staging {staging}");
                for first in [0, 3, data.len()] {
                    buffer.read_into(first, &mut [])?;
                    buffer.write_at(first, &[])?;
                }
                buffer.write(&[])?;
                assert_eq!(buffer.read()?, data, "{what}: an empty write changed the buffer");
                // One past the end is still out of range, empty or not.
                let err = buffer.read_into(data.len() + 1, &mut []).err();
                assert!(
                    matches!(err, Some(raykit::Error::Resource(raykit::ResourceError::BufferRange { .. }))),
                    "{what}: {err:?}"
                );
                let err = buffer.write_at(data.len() + 1, &[]).err();
                assert!(
                    matches!(err, Some(raykit::Error::Resource(raykit::ResourceError::BufferRange { .. }))),
                    "{what}: {err:?}"
                );
            }
        }
        ctx.force_staging_copies(false);
        for err in [DeviceBuffer::<u32>::zeroed(ctx, 0).err(), DeviceBuffer::<u32>::from_slice(ctx, &[]).err()] {
            let text = err.as_ref().map(ToString::to_string).unwrap_or_default();
            assert!(
                matches!(err, Some(raykit::Error::Resource(raykit::ResourceError::BufferSize { len: 0, .. })))
                    && text.contains("at least one element"),
                "{backend:?}: a buffer of no elements: {err:?}"
            );
        }
        Ok(())
    })
}
