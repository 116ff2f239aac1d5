//! The harness itself: it must catch leaks, or "zero leaks across the suite"
//! means nothing. Each test here leaks on purpose inside `with_context`, checks
//! that the harness fails with the reason, and then cleans up, so the test
//! itself leaves nothing behind.
//!
//! Contexts on one GPU share its device, and the layer reports objects left alive
//! when the device is destroyed, with its last context: the tests here take turns,
//! so each test's context is the only one on the device of this test binary.

use std::sync::{Mutex, MutexGuard};

use raykit::ash::vk;
use raykit_tests::{with_context, with_context_validation};

/// Held by each test of this file while it runs.
fn one_at_a_time() -> MutexGuard<'static, ()> {
    static TURN: Mutex<()> = Mutex::new(());
    TURN.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// A raykit object that outlives the test keeps the context (and its device)
/// alive: the harness reports that the context was not destroyed. Releasing the
/// object afterwards destroys the context, with nothing for the layer to report.
#[test]
fn harness_reports_a_raykit_object_that_outlives_the_test() -> anyhow::Result<()> {
    let _turn = one_at_a_time();
    let mut kept = None;
    let mut log = None;
    let result = with_context("leaks a buffer on purpose", |ctx| {
        log = Some(ctx.messages());
        // As good as `std::mem::forget(buffer)` for the harness, but reversible.
        kept = Some(ctx.buffer::<u32>(16)?);
        Ok(())
    });
    let Err(err) = result else { anyhow::bail!("the harness did not notice a buffer that outlived its test") };
    let text = err.to_string();
    assert!(text.contains("context was not destroyed") && text.contains("std::mem::forget"), "{text}");
    let Some(log) = log else {
        // No device and RAYKIT_REQUIRE_DEVICE unset: the harness skipped.
        return Ok(());
    };
    assert!(!log.context_destroyed());
    // Releasing the buffer releases the last hold on the context.
    drop(kept.take());
    assert!(log.context_destroyed(), "dropping the last raykit object did not destroy the context");
    let messages = log.take();
    assert!(messages.is_empty(), "destroying the context late: {messages:?}");
    Ok(())
}

/// A Vulkan object left alive when the device is destroyed (with its last context)
/// is reported by the validation layer to that context's log, which is still
/// routed at that point; the harness turns the report into a failure naming the
/// object.
#[test]
fn harness_reports_vulkan_objects_left_alive_at_device_destruction() -> anyhow::Result<()> {
    let _turn = one_at_a_time();
    let mut created = false;
    let result = with_context_validation("leaks a VkSampler on purpose", true, |ctx| {
        let info = vk::SamplerCreateInfo::default();
        // SAFETY: a valid create info on the context's live device. The sampler is
        // deliberately never destroyed: this test checks that the leak is reported.
        let _sampler = unsafe { ctx.raw_device().expect("a Vulkan context").create_sampler(&info, None) }?;
        created = true;
        Ok(())
    });
    if !created {
        // No device and RAYKIT_REQUIRE_DEVICE unset: the harness skipped.
        return result;
    }
    let Err(err) = result else {
        anyhow::bail!("the harness did not notice a VkSampler left alive at vkDestroyDevice")
    };
    let text = err.to_string();
    eprintln!("the harness reported, as it should:\n{text}");
    assert!(text.contains("validation message"), "{text}");
    assert!(text.contains("VkSampler") && text.contains("has not been destroyed"), "{text}");
    Ok(())
}

/// The same check passes when the test cleans up after itself.
#[test]
fn harness_passes_a_test_that_cleans_up() -> anyhow::Result<()> {
    let _turn = one_at_a_time();
    with_context_validation("creates and destroys a VkSampler", true, |ctx| {
        let info = vk::SamplerCreateInfo::default();
        // SAFETY: a valid create info on the context's live device.
        let sampler = unsafe { ctx.raw_device().expect("a Vulkan context").create_sampler(&info, None) }?;
        // SAFETY: the sampler was made above and is not in use.
        unsafe { ctx.raw_device().expect("a Vulkan context").destroy_sampler(sampler, None) };
        let buffer = ctx.buffer::<u32>(16)?;
        drop(buffer);
        Ok(())
    })
}
