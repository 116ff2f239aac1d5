//! Pipeline stack sizing on a real driver: per-group sizes come from the driver,
//! each estimate is consistent with the others, and a closest-hit that recurses
//! six trace levels deep with a local array live across each trace renders as
//! its CPU reference says with the computed stack size.

use raykit::glam::{UVec2, Vec3};
use raykit::stack::{self, GroupRole};
use raykit::{
    CallDepths, CallGraph, Context, Error, Gas, Ias, LinkOptions, Module, Pipeline, ProgramGroup, Sbt, StackSize,
};
use raykit_tests::{channel_distance, with_context, with_each_backend};
use stack_test_device::{
    layer_square, layer_z, layers_over, pack, reference, reference_unbounded, Params, LAYERS, MAX_DEPTH,
};

const SIZE: u32 = 96;

struct Scene {
    raygen: ProgramGroup,
    miss: ProgramGroup,
    hit: ProgramGroup,
    pipeline: Pipeline<Params>,
}

fn scene(ctx: &Context) -> anyhow::Result<Scene> {
    let module = Module::from_device_crate(ctx, "stack-test-device")?;
    let raygen = ProgramGroup::raygen(&module, stack_test_device::RG)?;
    let miss = ProgramGroup::miss(&module, stack_test_device::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(stack_test_device::LAYER_HIT).build()?;
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth: MAX_DEPTH })?;
    Ok(Scene { raygen, miss, hit, pipeline })
}

/// The call graph of the layered scene: raygen traces the one ray type, whose
/// closest-hit traces it again.
fn call_graph(s: &Scene) -> anyhow::Result<CallGraph> {
    let mut graph = CallGraph::new(MAX_DEPTH);
    let ray = graph.ray_type();
    let rg = graph.raygen(s.raygen.stack_sizes(&s.pipeline)?.general);
    graph.miss(ray, s.pipeline.group_stack_sizes(&s.miss)?.general);
    let hit = graph.hit(ray, s.pipeline.group_stack_sizes(&s.hit)?);
    graph.traces(rg, ray).traces(hit, ray);
    Ok(graph)
}

fn layers_gas(ctx: &Context) -> raykit::Result<Gas> {
    let mut vertices = Vec::new();
    for l in 0..LAYERS {
        let (cx, cy, h) = layer_square(l);
        let z = layer_z(l);
        let (a, b, c, d) = (
            Vec3::new(cx - h, cy - h, z),
            Vec3::new(cx + h, cy - h, z),
            Vec3::new(cx + h, cy + h, z),
            Vec3::new(cx - h, cy + h, z),
        );
        vertices.extend_from_slice(&[a, b, c, a, c, d]);
    }
    Gas::triangles(ctx, &vertices, None)
}

fn render(ctx: &Context, s: &Scene) -> anyhow::Result<Vec<u32>> {
    let sbt = Sbt::builder(&s.pipeline).raygen(&s.raygen, ()).miss(&s.miss, ()).hit(&s.hit, ()).build()?;
    let gas = layers_gas(ctx)?;
    let ias = Ias::single(ctx, &gas)?;
    let image = ctx.buffer::<u32>((SIZE * SIZE) as usize)?;
    let params = Params { image: image.handle(), _pad: 0, size: UVec2::splat(SIZE), scene: ias.handle() };
    s.pipeline.launch(&sbt, &params, [SIZE, SIZE, 1])?;
    Ok(image.read()?)
}

/// Share of pixels within 2/255 of the CPU reference, and how many pixels the
/// reference sees through all five layers.
fn compare(got: &[u32]) -> (f64, usize) {
    let (mut close, mut deep) = (0usize, 0usize);
    for y in 0..SIZE {
        for x in 0..SIZE {
            let index = UVec2::new(x, y);
            if channel_distance(got[(y * SIZE + x) as usize], pack(reference(index, UVec2::splat(SIZE)))) <= 2 {
                close += 1;
            }
            let (origin, _) = stack_test_device::ortho_ray(index, UVec2::splat(SIZE));
            let all = (0..LAYERS).all(|l| {
                let (cx, cy, h) = layer_square(l);
                (origin.x - cx).abs() <= h && (origin.y - cy).abs() <= h
            });
            deep += usize::from(all);
        }
    }
    (close as f64 / (SIZE * SIZE) as f64, deep)
}

#[test]
fn recursive_closest_hit_renders_with_the_call_graph_stack_size() -> anyhow::Result<()> {
    with_context("recursive_closest_hit_renders_with_the_call_graph_stack_size", |ctx| {
        let s = scene(ctx)?;
        let graph = call_graph(&s)?;
        let estimate = graph.estimate()?;
        let set = s.pipeline.set_stack_size(&StackSize::CallGraph(&graph))?;
        assert_eq!(u64::from(set), estimate);
        assert_eq!(s.pipeline.stack_size(), set);
        let sizes = s.pipeline.stack_sizes();
        let depths = CallDepths::new(MAX_DEPTH);
        // One ray type, no traversal programs: the call graph and the refined
        // formula agree; the conservative one is never smaller.
        assert_eq!(estimate, stack::refined(&sizes, &depths).total());
        assert!(estimate <= stack::conservative(&sizes, &depths).total());
        assert_eq!(s.pipeline.driver_default_stack_size(), stack::vulkan_default(&sizes, MAX_DEPTH));
        // css_rg + MAX_DEPTH levels of max(css_ch, css_ms).
        assert_eq!(estimate, sizes.css_rg + u64::from(MAX_DEPTH) * sizes.css_ch.max(sizes.css_ms));
        eprintln!(
            "stack sizes {sizes:?}: call graph {estimate}, driver default {}",
            s.pipeline.driver_default_stack_size()
        );

        let got = render(ctx, &s)?;
        let (share, deep) = compare(&got);
        assert!(deep > 100, "only {deep} pixels see all {LAYERS} layers");
        assert!(share >= 0.995, "only {:.2}% of pixels within 2/255 of the reference", share * 100.0);
        Ok(())
    })
}

#[test]
fn every_stack_choice_renders_the_same_picture() -> anyhow::Result<()> {
    with_each_backend("every_stack_choice_renders_the_same_picture", |ctx, _backend| {
        let s = scene(ctx)?;
        let graph = call_graph(&s)?;
        let default = render(ctx, &s)?;
        let depths = CallDepths::new(MAX_DEPTH);
        let big = u32::try_from(stack::conservative(&s.pipeline.stack_sizes(), &depths).total())? + 256;
        for choice in [
            StackSize::Conservative(depths),
            StackSize::Refined(depths),
            StackSize::CallGraph(&graph),
            StackSize::Explicit(big),
        ] {
            let bytes = s.pipeline.set_stack_size(&choice)?;
            let got = render(ctx, &s)?;
            assert!(got == default, "{choice:?} ({bytes} bytes) renders differently from the driver default");
        }
        Ok(())
    })
}

#[test]
fn groups_report_their_driver_stack_sizes() -> anyhow::Result<()> {
    with_context("groups_report_their_driver_stack_sizes", |ctx| {
        let s = scene(ctx)?;
        let roles: Vec<GroupRole> = s.pipeline.all_group_stack_sizes().iter().map(|(r, _)| *r).collect();
        assert_eq!(roles, [GroupRole::Raygen, GroupRole::Miss, GroupRole::Hit]);
        let hit = s.pipeline.group_stack_sizes(&s.hit)?;
        // Only the shaders a group has are asked for.
        assert_eq!((hit.general, hit.any_hit, hit.intersection), (0, 0, 0));
        let rg = s.pipeline.group_stack_sizes(&s.raygen)?;
        assert_eq!((rg.closest_hit, rg.any_hit, rg.intersection), (0, 0, 0));
        // A group of another pipeline is refused.
        let other = ProgramGroup::miss(&Module::from_device_crate(ctx, "stack-test-device")?, stack_test_device::MS)?;
        assert!(matches!(
            s.pipeline.group_stack_sizes(&other),
            Err(Error::Link(raykit::LinkError::GroupNotInPipeline { .. }))
        ));
        Ok(())
    })
}

#[test]
fn estimates_deeper_than_the_pipeline_are_refused() -> anyhow::Result<()> {
    with_each_backend("estimates_deeper_than_the_pipeline_are_refused", |ctx, _backend| {
        let s = scene(ctx)?;
        let before = s.pipeline.stack_size();
        let err = s.pipeline.set_stack_size(&StackSize::Refined(CallDepths::new(MAX_DEPTH + 1)));
        assert!(matches!(err, Err(Error::Link(raykit::LinkError::StackSize { .. }))), "{err:?}");
        let graph = CallGraph::new(MAX_DEPTH + 1);
        assert!(matches!(
            s.pipeline.set_stack_size(&StackSize::CallGraph(&graph)),
            Err(Error::Link(raykit::LinkError::StackSize { .. }))
        ));
        assert_eq!(s.pipeline.stack_size(), before, "a refused choice leaves the size as it was");
        // And the link itself refuses a depth over the device's limit.
        let limit = ctx.limits().max_ray_recursion_depth;
        let too_deep =
            Pipeline::<Params>::new(ctx, &[&s.raygen, &s.miss, &s.hit], LinkOptions { max_trace_depth: limit + 1 });
        assert!(matches!(too_deep, Err(Error::Link(raykit::LinkError::TraceDepthTooLarge { .. }))));
        Ok(())
    })
}

/// The unbounded recursion of `unbounded_hit` linked with `max_trace_depth`:
/// the launch's result and its picture.
fn render_unbounded(ctx: &Context, max_trace_depth: u32) -> anyhow::Result<(raykit::Result<()>, Vec<u32>)> {
    let module = Module::from_device_crate(ctx, "stack-test-device")?;
    let raygen = ProgramGroup::raygen(&module, stack_test_device::RG_UNBOUNDED)?;
    let miss = ProgramGroup::miss(&module, stack_test_device::MS_UNBOUNDED)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(stack_test_device::UNBOUNDED_HIT).build()?;
    // Accepted: the closest-hit recurses, and the depth is declared explicitly.
    let pipeline = Pipeline::<Params>::new(ctx, &[&raygen, &miss, &hit], LinkOptions { max_trace_depth })?;
    let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).miss(&miss, ()).hit(&hit, ()).build()?;
    let gas = layers_gas(ctx)?;
    let ias = Ias::single(ctx, &gas)?;
    let image = ctx.buffer::<u32>((SIZE * SIZE) as usize)?;
    let params = Params { image: image.handle(), _pad: 0, size: UVec2::splat(SIZE), scene: ias.handle() };
    let result = pipeline.launch(&sbt, &params, [SIZE, SIZE, 1]);
    Ok((result, image.read()?))
}

/// Share of pixels within 2/255 of `reference_unbounded` at `max_trace_depth`.
fn share_like_unbounded_reference(got: &[u32], max_trace_depth: u32) -> f64 {
    let size = UVec2::splat(SIZE);
    let close = (0..SIZE * SIZE)
        .filter(|&i| {
            let index = UVec2::new(i % SIZE, i / SIZE);
            channel_distance(got[i as usize], pack(reference_unbounded(index, size, max_trace_depth))) <= 2
        })
        .count();
    close as f64 / (SIZE * SIZE) as f64
}

#[test]
fn unbounded_recursion_within_max_trace_depth_renders() -> anyhow::Result<()> {
    with_each_backend("unbounded_recursion_within_max_trace_depth_renders", |ctx, _backend| {
        // Five layers: five closest-hits deep, the miss at depth 6.
        let (result, got) = render_unbounded(ctx, LAYERS + 1)?;
        result?;
        let share = share_like_unbounded_reference(&got, LAYERS + 1);
        assert!(share >= 0.995, "only {:.2}% of pixels within 2/255 of the reference", share * 100.0);
        // Deep enough for every layer: the picture of the depth-checking program.
        let size = UVec2::splat(SIZE);
        let same = (0..SIZE * SIZE)
            .filter(|&i| {
                let index = UVec2::new(i % SIZE, i / SIZE);
                channel_distance(got[i as usize], pack(reference(index, size))) <= 2
            })
            .count();
        assert!(same as f64 >= 0.995 * f64::from(SIZE * SIZE), "{same} pixels like the bounded program's");
        Ok(())
    })
}

#[test]
fn unbounded_recursion_past_max_trace_depth_is_refused_on_the_device() -> anyhow::Result<()> {
    with_each_backend("unbounded_recursion_past_max_trace_depth_is_refused_on_the_device", |ctx, _backend| {
        let size = UVec2::splat(SIZE);
        for max_trace_depth in [3, LAYERS] {
            let (result, got) = render_unbounded(ctx, max_trace_depth)?;
            // The closest-hit at depth max_trace_depth has its trace refused: one
            // refusal per pixel whose ray goes through that many layers.
            let deep: Vec<[u32; 3]> = (0..SIZE * SIZE)
                .map(|i| UVec2::new(i % SIZE, i / SIZE))
                .filter(|&index| layers_over(index, size) >= max_trace_depth)
                .map(|index| [index.x, index.y, 0])
                .collect();
            assert!(deep.len() > 100, "only {} pixels go {max_trace_depth} layers deep", deep.len());
            match result {
                Err(Error::Launch(raykit::LaunchError::RecursionTooDeep {
                    max_trace_depth: m,
                    depth,
                    refused,
                    launch_indices,
                    user_exceptions,
                    total,
                })) => {
                    assert_eq!((m, depth), (max_trace_depth, max_trace_depth + 1));
                    assert_eq!(total as usize, deep.len(), "one refusal per deep pixel");
                    let capacity = raykit::device::exception::EXCEPTION_CAPACITY as usize;
                    assert_eq!(refused, deep.len().min(capacity));
                    assert_eq!(launch_indices.len(), refused);
                    assert!(user_exceptions.is_empty(), "{user_exceptions:?}");
                    for index in &launch_indices {
                        assert!(
                            deep.contains(index),
                            "refusal at {index:?}, a pixel not {max_trace_depth} layers deep"
                        );
                    }
                    let mut unique = launch_indices.clone();
                    unique.sort_unstable();
                    unique.dedup();
                    assert_eq!(unique.len(), launch_indices.len(), "a pixel refused twice");
                }
                other => anyhow::bail!("max_trace_depth {max_trace_depth}: expected RecursionTooDeep, got {other:?}"),
            }
            // The launch ran to its end: the refused closest-hits shaded over the background.
            let share = share_like_unbounded_reference(&got, max_trace_depth);
            assert!(share >= 0.995, "only {:.2}% of pixels within 2/255 of the reference", share * 100.0);
        }
        Ok(())
    })
}
