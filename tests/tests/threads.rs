//! Any number of contexts on any number of threads: contexts made for one GPU share
//! its `VkDevice`, and each keeps its own validation messages.
//!
//! `RAYKIT_THREADS` sets the number of threads (8 by default).

use std::sync::Barrier;

use raykit::{Context, Gas, Ias, LinkOptions, Pipeline, Sbt};
use raykit_tests::{check_triangle_picture, context_or_skip, names_object, provoke_validation_error, test_options};
use triangle::{Programs, BG_COLOR, VERTICES};
use triangle_device::{MissData, Params};

const ROUNDS: usize = 10;
const LAUNCHES: usize = 20;
const WIDTH: u32 = 48;
const HEIGHT: u32 = 36;

fn thread_count() -> anyhow::Result<usize> {
    match std::env::var("RAYKIT_THREADS") {
        Ok(v) => v.parse().map_err(|e| anyhow::anyhow!("RAYKIT_THREADS={v:?}: {e}")),
        Err(_) => Ok(8),
    }
}

/// What one thread did in one round.
struct Outcome {
    device: u64,
    messages: Vec<raykit::ValidationMessage>,
    destroyed: bool,
    provoked: bool,
}

/// One thread's round: its own context and optixTriangle scene, `LAUNCHES`
/// launches each checked against the CPU reference; `provoke` makes the
/// validation layer report an error about one of its objects while every other
/// context of the round is alive.
fn round(gate: &Barrier, provoke: bool) -> anyhow::Result<Outcome> {
    let made = (|| -> anyhow::Result<_> {
        let ctx = Context::new(test_options())?;
        let Programs { raygen, miss, hit } = Programs::rust(&ctx)?;
        let pipeline = Pipeline::<Params>::new(&ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
        let sbt = Sbt::builder(&pipeline)
            .raygen(&raygen, ())
            .miss(&miss, MissData { bg_color: BG_COLOR })
            .hit(&hit, ())
            .build()?;
        let gas = Gas::triangles(&ctx, &VERTICES, None)?;
        let scene = Ias::single(&ctx, &gas)?;
        Ok((ctx, pipeline, sbt, gas, scene))
    })();
    // Every thread passes each gate, also after an error, so none waits forever.
    gate.wait();
    let result = made.and_then(|(ctx, pipeline, sbt, gas, scene)| {
        let provoked = provoke && provoke_validation_error(&ctx, "misused buffer")?;
        let mut image = ctx.buffer::<u32>((WIDTH * HEIGHT) as usize)?;
        let params = triangle::params(WIDTH, HEIGHT, image.handle(), scene.handle());
        for launch in 0..LAUNCHES {
            image.write(&vec![0; (WIDTH * HEIGHT) as usize])?;
            pipeline.launch(&sbt, &params, [WIDTH, HEIGHT, 1])?;
            check_triangle_picture(&image.read()?, WIDTH, HEIGHT)
                .map_err(|e| anyhow::anyhow!("launch {launch}: {e}"))?;
        }
        let device = raykit::ash::vk::Handle::as_raw(ctx.raw_device().expect("a Vulkan context").handle());
        let log = ctx.messages();
        drop((image, pipeline, sbt, scene, gas));
        Ok((ctx, log, device, provoked))
    });
    // Every context of the round is alive until here.
    gate.wait();
    let (ctx, log, device, provoked) = result?;
    drop(ctx);
    Ok(Outcome { device, messages: log.take(), destroyed: log.context_destroyed(), provoked })
}

#[test]
fn contexts_on_many_threads_share_one_device_and_keep_their_own_messages() -> anyhow::Result<()> {
    let name = "contexts_on_many_threads_share_one_device_and_keep_their_own_messages";
    let threads = thread_count()?;
    anyhow::ensure!(threads >= 1, "RAYKIT_THREADS must be at least 1");
    // Fails or skips loudly without a device, as the harness does.
    let Some(probe) = context_or_skip(name, test_options())? else { return Ok(()) };
    drop(probe);
    if !raykit_tests::validation_on() {
        eprintln!("{name}: validation is off (RAYKIT_VALIDATION!=1): the message routing is not checked");
    }
    let gate = &Barrier::new(threads);
    let started = std::time::Instant::now();
    for r in 0..ROUNDS {
        let provoker = r % threads;
        let outcomes: Vec<anyhow::Result<Outcome>> = std::thread::scope(|scope| {
            let handles: Vec<_> =
                (0..threads).map(|t| scope.spawn(move || round(gate, t == provoker))).collect::<Vec<_>>();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_else(|_| Err(anyhow::anyhow!("a thread panicked"))))
                .collect()
        });
        let outcomes: Vec<Outcome> = outcomes
            .into_iter()
            .enumerate()
            .map(|(t, o)| o.map_err(|e| anyhow::anyhow!("round {r}, thread {t}: {e}")))
            .collect::<anyhow::Result<_>>()?;
        for (t, o) in outcomes.iter().enumerate() {
            anyhow::ensure!(o.destroyed, "round {r}, thread {t}: the context was not destroyed");
            anyhow::ensure!(
                o.device == outcomes[0].device,
                "round {r}: threads 0 and {t} had contexts on different devices at the same time"
            );
            if o.provoked {
                anyhow::ensure!(
                    !o.messages.is_empty() && o.messages.iter().all(|m| names_object(m, "misused buffer")),
                    "round {r}, thread {t}: expected only the provoked message(s), got {:#?}",
                    o.messages
                );
            } else {
                let text: Vec<String> = o.messages.iter().map(|m| m.to_string()).collect();
                anyhow::ensure!(
                    text.is_empty(),
                    "round {r}, thread {t}: {} message(s):\n{}",
                    text.len(),
                    text.join("\n")
                );
            }
        }
    }
    eprintln!(
        "{name}: {threads} threads × {ROUNDS} rounds × {LAUNCHES} launches ({} pictures checked) in {:.2} s",
        threads * ROUNDS * LAUNCHES,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Pipelines made, launched and dropped on many threads with no barrier between
/// them, so creations on some threads overlap destructions on others (NVIDIA's
/// driver deadlocks when it runs those two at once; raykit keeps them apart).
#[test]
fn pipelines_created_and_dropped_on_many_threads_at_once_all_render() -> anyhow::Result<()> {
    const PIPELINES: usize = 12;
    let name = "pipelines_created_and_dropped_on_many_threads_at_once_all_render";
    let threads = thread_count()?;
    anyhow::ensure!(threads >= 1, "RAYKIT_THREADS must be at least 1");
    let Some(probe) = context_or_skip(name, test_options())? else { return Ok(()) };
    drop(probe);
    let started = std::time::Instant::now();
    let results: Vec<anyhow::Result<Vec<String>>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                scope.spawn(move || -> anyhow::Result<Vec<String>> {
                    let ctx = Context::new(test_options())?;
                    let log = ctx.messages();
                    let gas = Gas::triangles(&ctx, &VERTICES, None)?;
                    let scene = Ias::single(&ctx, &gas)?;
                    let image = ctx.buffer::<u32>((WIDTH * HEIGHT) as usize)?;
                    let params = triangle::params(WIDTH, HEIGHT, image.handle(), scene.handle());
                    for p in 0..PIPELINES {
                        let Programs { raygen, miss, hit } = Programs::rust(&ctx)?;
                        let pipeline =
                            Pipeline::<Params>::new(&ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: 1 })?;
                        let sbt = Sbt::builder(&pipeline)
                            .raygen(&raygen, ())
                            .miss(&miss, MissData { bg_color: BG_COLOR })
                            .hit(&hit, ())
                            .build()?;
                        pipeline.launch(&sbt, &params, [WIDTH, HEIGHT, 1])?;
                        check_triangle_picture(&image.read()?, WIDTH, HEIGHT)
                            .map_err(|e| anyhow::anyhow!("thread {t}, pipeline {p}: {e}"))?;
                        // Dropped here, while other threads are creating theirs.
                        drop((sbt, pipeline, raygen, miss, hit));
                    }
                    drop((image, scene, gas, ctx));
                    anyhow::ensure!(log.context_destroyed(), "thread {t}: the context was not destroyed");
                    Ok(log.take().iter().map(|m| m.to_string()).collect())
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap_or_else(|_| Err(anyhow::anyhow!("a thread panicked")))).collect()
    });
    for (t, result) in results.into_iter().enumerate() {
        let messages = result?;
        anyhow::ensure!(messages.is_empty(), "thread {t}: {} message(s):\n{}", messages.len(), messages.join("\n"));
    }
    eprintln!(
        "{name}: {threads} threads × {PIPELINES} pipelines made, launched and dropped in {:.2} s",
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
