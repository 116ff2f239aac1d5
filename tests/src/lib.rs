//! Shared harness of raykit's integration tests.
//!
//! [`with_context`] creates a [`Context`] with the Khronos validation layer on
//! (when `RAYKIT_VALIDATION=1`, as `cargo xtask test` sets it), runs the test,
//! destroys the context and fails if the layer said anything — during the test or
//! at destruction, where it reports Vulkan objects left alive (the debug messenger
//! is destroyed after the device for this reason). It also fails when the context
//! could not be destroyed because a raykit object still holds it (leaked with
//! `std::mem::forget`, or kept past the test). Without a ray-tracing device the
//! test fails when `RAYKIT_REQUIRE_DEVICE=1` (CI and `cargo xtask test`), and
//! otherwise prints a loud SKIPPED line.

use raykit::{Context, ContextOptions, Error};

/// Runs `test` with a fresh context; checks the validation log afterwards.
pub fn with_context(name: &str, test: impl FnOnce(&Context) -> anyhow::Result<()>) -> anyhow::Result<()> {
    let validation = std::env::var("RAYKIT_VALIDATION").is_ok_and(|v| v == "1");
    with_context_validation(name, validation, test)
}

/// [`with_context`] with validation on or off whatever the environment says.
pub fn with_context_validation(
    name: &str,
    validation: bool,
    test: impl FnOnce(&Context) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let ctx = match Context::new(ContextOptions { validation: Some(validation), ..Default::default() }) {
        Ok(ctx) => ctx,
        Err(e @ (Error::NoRayTracingDevice { .. } | Error::LoaderMissing(_))) => {
            if std::env::var("RAYKIT_REQUIRE_DEVICE").is_ok_and(|v| v == "1") {
                anyhow::bail!("{name}: RAYKIT_REQUIRE_DEVICE=1 and no usable device: {e}");
            }
            eprintln!("SKIPPED {name}: no ray-tracing device ({e}); set RAYKIT_REQUIRE_DEVICE=1 to make this a failure");
            return Ok(());
        }
        Err(e) => return Err(e.into()),
    };
    let log = ctx.messages();
    let result = test(&ctx);
    drop(ctx);
    let destroyed = log.context_destroyed();
    let messages = log.take();
    result?;
    if !destroyed {
        anyhow::bail!(
            "{name}: the context was not destroyed at the end of the test: a raykit object still holds it \
             (leaked with std::mem::forget, kept in a static or past the test, or in a reference cycle)"
        );
    }
    if !messages.is_empty() {
        let text: Vec<String> = messages.iter().map(|m| m.to_string()).collect();
        anyhow::bail!("{name}: {} validation message(s):\n{}", messages.len(), text.join("\n"));
    }
    Ok(())
}

/// Unpacks RGBA8 into `[r, g, b, a]`.
pub fn rgba(pixel: u32) -> [u8; 4] {
    pixel.to_le_bytes()
}

/// Largest per-channel difference between two RGBA8 pixels.
pub fn channel_distance(a: u32, b: u32) -> u8 {
    rgba(a).iter().zip(rgba(b)).map(|(x, y)| x.abs_diff(y)).max().unwrap_or(0)
}
