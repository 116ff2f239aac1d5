//! The `stack` suite: for the example and test pipelines, the stack sizes the
//! driver reports per group, the size each of raykit's estimates gives
//! (conservative, refined, call graph) and the size Vulkan defines for a pipeline
//! without dynamic stack state (the driver default). No timing: the numbers are
//! the driver's and the formulas'.

use raykit::stack::{self, GroupRole};
use raykit::{CallDepths, CallGraph, Context, GroupStackSizes, LinkOptions, Module, Pipeline, ProgramGroup};

/// One pipeline's figures.
pub struct Row {
    /// What the pipeline is.
    pub name: &'static str,
    /// `max_trace_depth`.
    pub depth: u32,
    /// Each group's name, role and driver-reported sizes.
    pub groups: Vec<(&'static str, GroupRole, GroupStackSizes)>,
    /// [`stack::conservative`], total bytes.
    pub conservative: u64,
    /// [`stack::refined`], total bytes.
    pub refined: u64,
    /// [`CallGraph::estimate`].
    pub call_graph: u64,
    /// [`stack::vulkan_default`].
    pub driver_default: u64,
}

fn row<P: raykit::LaunchParams>(
    name: &'static str,
    pipeline: &Pipeline<P>,
    names: &[&'static str],
    depths: CallDepths,
    graph: &CallGraph,
) -> anyhow::Result<Row> {
    let sizes = pipeline.stack_sizes();
    let groups = pipeline.all_group_stack_sizes().into_iter().zip(names).map(|((role, s), n)| (*n, role, s)).collect();
    Ok(Row {
        name,
        depth: pipeline.max_trace_depth(),
        groups,
        conservative: stack::conservative(&sizes, &depths).total(),
        refined: stack::refined(&sizes, &depths).total(),
        call_graph: graph.estimate()?,
        driver_default: pipeline.driver_default_stack_size(),
    })
}

fn triangle(ctx: &Context) -> anyhow::Result<Row> {
    let module = Module::from_device_crate(ctx, "triangle-device")?;
    let rg = ProgramGroup::raygen(&module, triangle_device::RG)?;
    let ms = ProgramGroup::miss(&module, triangle_device::MS)?;
    let ch = ProgramGroup::hit_group(&module).closest_hit(triangle_device::CH).build()?;
    let p = Pipeline::<triangle_device::Params>::new(ctx, &[&rg, &ms, &ch], LinkOptions { max_trace_depth: 1 })?;
    let mut g = CallGraph::new(1);
    let radiance = g.ray_type();
    let n_rg = g.raygen(p.group_stack_sizes(&rg)?.general);
    g.miss(radiance, p.group_stack_sizes(&ms)?.general);
    g.hit(radiance, p.group_stack_sizes(&ch)?);
    g.traces(n_rg, radiance);
    row("triangle (examples/triangle)", &p, &["rg", "ms", "ch"], CallDepths::new(1), &g)
}

fn shadows(ctx: &Context) -> anyhow::Result<Row> {
    use program_model_device as d;
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let rg = ProgramGroup::raygen(&module, d::RG_SHADOWS)?;
    let ms = ProgramGroup::miss(&module, d::MS_SHADOWS)?;
    let ms_shadow = ProgramGroup::miss(&module, d::MS_SHADOW)?;
    let shade = ProgramGroup::hit_group(&module).closest_hit(d::SHADE_SHADOWED).build()?;
    let shadow_hit = ProgramGroup::hit_group(&module).closest_hit(d::SHADOW_HIT).build()?;
    let p = Pipeline::<d::Params>::new(
        ctx,
        &[&rg, &ms, &ms_shadow, &shade, &shadow_hit],
        LinkOptions { max_trace_depth: 2 },
    )?;
    // OptiX's path-tracer example: css_rg + max(css_ms1, css_ch1 + max(css_ms2, css_ch2)).
    let mut g = CallGraph::new(2);
    let (camera, shadow) = (g.ray_type(), g.ray_type());
    let n_rg = g.raygen(p.group_stack_sizes(&rg)?.general);
    g.miss(camera, p.group_stack_sizes(&ms)?.general);
    let n_shade = g.hit(camera, p.group_stack_sizes(&shade)?);
    g.miss(shadow, p.group_stack_sizes(&ms_shadow)?.general);
    g.hit(shadow, p.group_stack_sizes(&shadow_hit)?);
    g.traces(n_rg, camera).traces(n_shade, shadow);
    row(
        "shadows (examples/program_model, 2 ray types)",
        &p,
        &["rg_shadows", "ms_shadows", "ms_shadow", "shade_shadowed", "shadow_hit"],
        CallDepths::new(2),
        &g,
    )
}

fn materials(ctx: &Context) -> anyhow::Result<Row> {
    use program_model_device as d;
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let rg = ProgramGroup::raygen(&module, d::RG)?;
    let ms = ProgramGroup::miss(&module, d::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(d::MATERIAL_SHADE).build()?;
    let callables = [
        ProgramGroup::callable(&module, d::RED)?,
        ProgramGroup::callable(&module, d::GREEN)?,
        ProgramGroup::callable(&module, d::BLUE)?,
    ];
    let p = Pipeline::<d::Params>::new(
        ctx,
        &[&rg, &ms, &hit, &callables[0], &callables[1], &callables[2]],
        LinkOptions { max_trace_depth: 1 },
    )?;
    let mut g = CallGraph::new(1);
    let radiance = g.ray_type();
    let n_rg = g.raygen(p.group_stack_sizes(&rg)?.general);
    g.miss(radiance, p.group_stack_sizes(&ms)?.general);
    let n_hit = g.hit(radiance, p.group_stack_sizes(&hit)?);
    g.traces(n_rg, radiance);
    for c in &callables {
        let n = g.callable(p.group_stack_sizes(c)?.general);
        g.calls(n_hit, n);
    }
    let depths = CallDepths::new(1).direct_callables(1).continuation_callables(1);
    row(
        "materials (examples/program_model, callables)",
        &p,
        &["rg", "ms", "material_shade", "red (dc)", "green (dc)", "blue (cc)"],
        depths,
        &g,
    )
}

fn spheres(ctx: &Context) -> anyhow::Result<Row> {
    use program_model_device as d;
    let module = Module::from_device_crate(ctx, "program-model-device")?;
    let rg = ProgramGroup::raygen(&module, d::RG)?;
    let ms = ProgramGroup::miss(&module, d::MS)?;
    let hit = ProgramGroup::hit_group(&module).intersection(d::SPHERE).closest_hit(d::SPHERE_SHADE).build()?;
    let p = Pipeline::<d::Params>::new(ctx, &[&rg, &ms, &hit], LinkOptions { max_trace_depth: 1 })?;
    let mut g = CallGraph::new(1);
    let radiance = g.ray_type();
    let n_rg = g.raygen(p.group_stack_sizes(&rg)?.general);
    g.miss(radiance, p.group_stack_sizes(&ms)?.general);
    g.hit(radiance, p.group_stack_sizes(&hit)?);
    g.traces(n_rg, radiance);
    row(
        "spheres (examples/program_model, intersection)",
        &p,
        &["rg", "ms", "sphere+sphere_shade"],
        CallDepths::new(1),
        &g,
    )
}

fn layered(ctx: &Context) -> anyhow::Result<Row> {
    use stack_test_device as d;
    let module = Module::from_device_crate(ctx, "stack-test-device")?;
    let rg = ProgramGroup::raygen(&module, d::RG)?;
    let ms = ProgramGroup::miss(&module, d::MS)?;
    let hit = ProgramGroup::hit_group(&module).closest_hit(d::LAYER_HIT).build()?;
    let p = Pipeline::<d::Params>::new(ctx, &[&rg, &ms, &hit], LinkOptions { max_trace_depth: d::MAX_DEPTH })?;
    let mut g = CallGraph::new(d::MAX_DEPTH);
    let ray = g.ray_type();
    let n_rg = g.raygen(p.group_stack_sizes(&rg)?.general);
    g.miss(ray, p.group_stack_sizes(&ms)?.general);
    let n_hit = g.hit(ray, p.group_stack_sizes(&hit)?);
    g.traces(n_rg, ray).traces(n_hit, ray);
    row(
        "layered (tests/device/stack, recursive closest-hit)",
        &p,
        &["rg", "ms", "layer_hit"],
        CallDepths::new(d::MAX_DEPTH),
        &g,
    )
}

/// Runs the suite.
pub fn run(ctx: &Context) -> anyhow::Result<Vec<Row>> {
    Ok(vec![triangle(ctx)?, shadows(ctx)?, materials(ctx)?, spheres(ctx)?, layered(ctx)?])
}

fn role(r: GroupRole) -> &'static str {
    match r {
        GroupRole::Raygen => "raygen",
        GroupRole::Miss => "miss",
        GroupRole::Hit => "hit",
        GroupRole::DirectCallable => "direct callable",
        GroupRole::ContinuationCallable => "continuation callable",
        GroupRole::Callable => "callable",
        _ => "other",
    }
}

/// The suite's report: estimates per pipeline, then the per-group sizes.
pub fn markdown(rows: &[Row], device: &str) -> String {
    let mut s = format!("Pipeline stack sizes on {device}, in bytes (the one number `vkCmdSetRayTracingPipelineStackSizeKHR` takes).\n\n");
    s.push_str("| pipeline | max_trace_depth | conservative | refined | call graph | driver default |\n|---|---:|---:|---:|---:|---:|\n");
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            r.name, r.depth, r.conservative, r.refined, r.call_graph, r.driver_default
        ));
    }
    s.push_str(
        "\nPer-group sizes from `vkGetRayTracingShaderGroupStackSizeKHR` (0 where the group has no such shader):\n\n",
    );
    s.push_str("| pipeline | group | role | general | closest-hit | any-hit | intersection |\n|---|---|---|---:|---:|---:|---:|\n");
    for r in rows {
        for (name, g_role, g) in &r.groups {
            s.push_str(&format!(
                "| {} | {} | {} | {} | {} | {} | {} |\n",
                r.name.split(' ').next().unwrap_or(r.name),
                name,
                role(*g_role),
                g.general,
                g.closest_hit,
                g.any_hit,
                g.intersection
            ));
        }
    }
    s
}

/// The suite's JSON.
pub fn json(rows: &[Row]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                serde_json::json!({
                    "pipeline": r.name,
                    "max_trace_depth": r.depth,
                    "conservative": r.conservative,
                    "refined": r.refined,
                    "call_graph": r.call_graph,
                    "driver_default": r.driver_default,
                    "groups": r.groups.iter().map(|(n, g_role, g)| serde_json::json!({
                        "group": n, "role": role(*g_role), "general": g.general,
                        "closest_hit": g.closest_hit, "any_hit": g.any_hit, "intersection": g.intersection,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect(),
    )
}
