//! Pipeline stack sizing: OptiX's stack-size formulas on Vulkan's one stack.
//!
//! Every program of a ray-tracing pipeline may need stack: a recursive
//! closest-hit keeps its locals alive while the ray it traced is shaded, a
//! callable runs on top of its caller. The driver knows each program's own need
//! ([`vkGetRayTracingShaderGroupStackSizeKHR`], per group and per shader of the
//! group: general, closest-hit, any-hit, intersection; raykit reports it as
//! [`GroupStackSizes`]); only the application knows how the programs call each
//! other. The pipeline stack is the sum of the programs' stacks along the deepest
//! chain of calls, set with [`vkCmdSetRayTracingPipelineStackSizeKHR`] (raykit's
//! pipelines have this dynamic state; see [`StackSize`] for the choices).
//!
//! The estimates here follow the OptiX Programming Guide ("Pipeline Stack Size"),
//! from coarse to tight:
//!
//! 1. [`conservative`]: every level of tracing may run the largest closest-hit or
//!    miss program, each with the deepest continuation-callable tree on top, plus
//!    intersection and any-hit stacks on top of everything.
//! 2. [`refined`]: intersection and any-hit run during traversal, before the
//!    closest-hit or miss of the same level, so they are offset against one level
//!    instead of being added; and direct callables are counted by where they are
//!    called from (traversal: any-hit and intersection; state: raygen, miss,
//!    closest-hit) with separate depths.
//! 3. [`CallGraph`]: which ray types each program traces and which callables it
//!    calls; the stack is the heaviest path through that graph, so a shadow ray's
//!    programs are only stacked on the closest-hit that traces them. For the
//!    guide's path tracer (camera and shadow rays) this gives `css_rg + max(css_ms1, css_ch1 + max(css_ms2, css_ch2))`
//!    instead of `css_rg + 2 * max(css_ch1, css_ch2, css_ms1, css_ms2)`.
//!
//! [`vulkan_default`] is what the Vulkan specification lets a pipeline without the
//! dynamic state use ("Ray Tracing Pipeline Stack"), from the same per-group sizes.
//!
//! # OptiX's two stacks and Vulkan's one
//!
//! OptiX sets three numbers: the direct stack of direct callables called from
//! traversal, the same from state, and the continuation stack. Vulkan has one
//! stack for every shader, callables included, so raykit sets their sum
//! ([`StackEstimate::total`]). Vulkan forbids `OpExecuteCallableKHR` in any-hit and
//! intersection shaders, so the traversal term is zero on Vulkan unless a call
//! depth from traversal is given; it is kept to reproduce OptiX's formulas.
//! Vulkan does not distinguish direct from continuation callables either: both
//! are callable shaders; raykit sorts callable groups by their OptiX prefix
//! (`__direct_callable__`, `__continuation_callable__`), and counts a callable
//! without one (a GLSL `callableEXT` shader) as both.
//!
//! [`vkGetRayTracingShaderGroupStackSizeKHR`]: https://registry.khronos.org/vulkan/specs/latest/man/html/vkGetRayTracingShaderGroupStackSizeKHR.html
//! [`vkCmdSetRayTracingPipelineStackSizeKHR`]: https://registry.khronos.org/vulkan/specs/latest/man/html/vkCmdSetRayTracingPipelineStackSizeKHR.html

use crate::error::LinkError;
use crate::error::{Error, Result};

mod call_graph;

pub use call_graph::{CallGraph, ProgramId, RayTypeId, MAX_GRAPH_DEPTH};

/// One program group's stack sizes in bytes, as the driver reports them
/// (`vkGetRayTracingShaderGroupStackSizeKHR`). Shaders the group lacks read 0.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct GroupStackSizes {
    /// The general shader: raygen, miss or callable.
    pub general: u64,
    /// The closest-hit shader of a hit group.
    pub closest_hit: u64,
    /// The any-hit shader of a hit group.
    pub any_hit: u64,
    /// The intersection shader of a procedural hit group.
    pub intersection: u64,
}

/// What a program group is, for stack accounting.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum GroupRole {
    /// A raygen group.
    Raygen,
    /// A miss group.
    Miss,
    /// A hit group (closest-hit, any-hit, intersection).
    Hit,
    /// A `__direct_callable__` program.
    DirectCallable,
    /// A `__continuation_callable__` program.
    ContinuationCallable,
    /// A callable without an OptiX prefix (a GLSL `callableEXT` shader): counted
    /// as both direct and continuation callable.
    Callable,
}

/// The maxima over a pipeline's groups, by program kind: OptiX's `OptixStackSizes`
/// (`css_*` continuation stacks, `dss_dc` the direct stack of direct callables).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
#[doc(alias("OptixStackSizes"))]
pub struct StackSizes {
    /// Largest raygen stack.
    pub css_rg: u64,
    /// Largest miss stack.
    pub css_ms: u64,
    /// Largest closest-hit stack.
    pub css_ch: u64,
    /// Largest any-hit stack.
    pub css_ah: u64,
    /// Largest intersection stack.
    pub css_is: u64,
    /// Largest continuation-callable stack.
    pub css_cc: u64,
    /// Largest direct-callable stack.
    pub dss_dc: u64,
}

impl StackSizes {
    /// Adds one group's sizes (OptiX's `optixUtilAccumulateStackSizes`).
    pub fn accumulate(&mut self, role: GroupRole, sizes: GroupStackSizes) {
        let max = |a: &mut u64, b: u64| *a = (*a).max(b);
        match role {
            GroupRole::Raygen => max(&mut self.css_rg, sizes.general),
            GroupRole::Miss => max(&mut self.css_ms, sizes.general),
            GroupRole::Hit => {
                max(&mut self.css_ch, sizes.closest_hit);
                max(&mut self.css_ah, sizes.any_hit);
                max(&mut self.css_is, sizes.intersection);
            }
            GroupRole::DirectCallable => max(&mut self.dss_dc, sizes.general),
            GroupRole::ContinuationCallable => max(&mut self.css_cc, sizes.general),
            GroupRole::Callable => {
                max(&mut self.dss_dc, sizes.general);
                max(&mut self.css_cc, sizes.general);
            }
        }
    }

    /// The maxima over `groups`.
    pub fn from_groups(groups: impl IntoIterator<Item = (GroupRole, GroupStackSizes)>) -> StackSizes {
        let mut sizes = StackSizes::default();
        for (role, group) in groups {
            sizes.accumulate(role, group);
        }
        sizes
    }
}

/// How deep programs call each other: the inputs of [`conservative`] and
/// [`refined`] besides the sizes.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct CallDepths {
    /// Maximum trace depth (`LinkOptions::max_trace_depth`): 1 when only raygen
    /// traces, 2 when closest-hit or miss trace once more, and so on.
    pub max_trace_depth: u32,
    /// Maximum depth of continuation-callable call trees.
    pub max_cc_depth: u32,
    /// Maximum depth of direct-callable call trees started from traversal
    /// (any-hit, intersection). Always 0 on Vulkan, where these stages cannot
    /// call callables.
    pub max_dc_depth_from_traversal: u32,
    /// Maximum depth of direct-callable call trees started from state (raygen,
    /// miss, closest-hit).
    pub max_dc_depth_from_state: u32,
}

impl CallDepths {
    /// Tracing to `max_trace_depth`, no callables.
    pub fn new(max_trace_depth: u32) -> CallDepths {
        CallDepths { max_trace_depth, ..CallDepths::default() }
    }

    /// Continuation-callable call trees up to `depth` deep.
    #[must_use]
    pub fn continuation_callables(mut self, depth: u32) -> Self {
        self.max_cc_depth = depth;
        self
    }

    /// Direct-callable call trees up to `depth` deep, called from raygen, miss or
    /// closest-hit.
    #[must_use]
    pub fn direct_callables(mut self, depth: u32) -> Self {
        self.max_dc_depth_from_state = depth;
        self
    }

    /// Direct-callable call trees up to `depth` deep, called from any-hit or
    /// intersection (OptiX only: Vulkan forbids it, so this stays 0 on Vulkan).
    #[must_use]
    pub fn direct_callables_from_traversal(mut self, depth: u32) -> Self {
        self.max_dc_depth_from_traversal = depth;
        self
    }
}

/// A stack estimate in OptiX's three parts; Vulkan gets [`StackEstimate::total`].
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct StackEstimate {
    /// Direct stack of direct callables called from any-hit or intersection.
    pub direct_from_traversal: u64,
    /// Direct stack of direct callables called from raygen, miss or closest-hit.
    pub direct_from_state: u64,
    /// Continuation stack: raygen, miss, closest-hit, any-hit, intersection and
    /// continuation callables.
    pub continuation: u64,
}

impl StackEstimate {
    /// The one number Vulkan takes: the sum of the three parts (saturating).
    pub fn total(&self) -> u64 {
        self.direct_from_traversal.saturating_add(self.direct_from_state).saturating_add(self.continuation)
    }
}

/// `css_cc_tree` and `css_ch_or_ms_plus_cc_tree`, shared by both formulas.
fn level_terms(s: &StackSizes, d: &CallDepths) -> (u64, u64) {
    // Upper bound on continuation stack used by call trees of continuation callables.
    let css_cc_tree = u64::from(d.max_cc_depth).saturating_mul(s.css_cc);
    // Upper bound on continuation stack used by closest-hit or miss programs,
    // including the call tree of continuation-callable programs.
    let css_ch_or_ms_plus_cc_tree = s.css_ch.max(s.css_ms).saturating_add(css_cc_tree);
    (css_cc_tree, css_ch_or_ms_plus_cc_tree)
}

/// OptiX's simple, conservative estimate (the guide's first formula):
///
/// ```text
/// direct_from_traversal = max_dc_depth * dss_dc
/// direct_from_state     = max_dc_depth * dss_dc
/// css_cc_tree           = max_cc_depth * css_cc
/// css_ch_or_ms_plus_cc_tree = max(css_ch, css_ms) + css_cc_tree
/// continuation = css_rg + css_cc_tree + max_trace_depth * css_ch_or_ms_plus_cc_tree
///              + css_is + css_ah
/// ```
///
/// Every trace level may run the largest closest-hit or miss program with the
/// deepest continuation-callable tree on top; intersection and any-hit are added
/// once more on top of all that; direct callables are not told apart by call site,
/// so `max_dc_depth` is the larger of the two depths in `d`.
#[doc(alias("optixUtilComputeStackSizes"))]
pub fn conservative(s: &StackSizes, d: &CallDepths) -> StackEstimate {
    let max_dc_depth = d.max_dc_depth_from_traversal.max(d.max_dc_depth_from_state);
    let dc = u64::from(max_dc_depth).saturating_mul(s.dss_dc);
    let (css_cc_tree, per_level) = level_terms(s, d);
    let continuation = s
        .css_rg
        .saturating_add(css_cc_tree)
        .saturating_add(u64::from(d.max_trace_depth).saturating_mul(per_level))
        .saturating_add(s.css_is)
        .saturating_add(s.css_ah);
    StackEstimate { direct_from_traversal: dc, direct_from_state: dc, continuation }
}

/// OptiX's better estimate (`optixUtilComputeStackSizes`):
///
/// ```text
/// direct_from_traversal = max_dc_depth_from_traversal * dss_dc
/// direct_from_state     = max_dc_depth_from_state * dss_dc
/// continuation = css_rg + css_cc_tree
///              + (max(max_trace_depth, 1) - 1) * css_ch_or_ms_plus_cc_tree
///              + min(max_trace_depth, 1) * max(css_ch_or_ms_plus_cc_tree, css_is + css_ah)
/// ```
///
/// Intersection and any-hit run during traversal, before the closest-hit or miss
/// of that level, and never during it, so `css_is + css_ah` is offset against one
/// level of `css_ch_or_ms_plus_cc_tree` instead of added to it. Direct callables
/// are counted by the semantic type of their call site: traversal (any-hit,
/// intersection) and state (raygen, miss, closest-hit), each with its own depth.
///
/// The OptiX Programming Guide writes the level count as `(max_trace_depth - 1).max(1)`, which for a
/// depth of 1 counts two levels and can exceed [`conservative`]; OptiX's header
/// (`optix_stack_size.h`) has `max(max_trace_depth, 1) - 1`, used here, which is
/// never worse than the conservative estimate.
pub fn refined(s: &StackSizes, d: &CallDepths) -> StackEstimate {
    let (css_cc_tree, per_level) = level_terms(s, d);
    let depth = u64::from(d.max_trace_depth);
    let continuation = s
        .css_rg
        .saturating_add(css_cc_tree)
        .saturating_add(depth.max(1).saturating_sub(1).saturating_mul(per_level))
        .saturating_add(depth.min(1).saturating_mul(per_level.max(s.css_is.saturating_add(s.css_ah))));
    StackEstimate {
        direct_from_traversal: u64::from(d.max_dc_depth_from_traversal).saturating_mul(s.dss_dc),
        direct_from_state: u64::from(d.max_dc_depth_from_state).saturating_mul(s.dss_dc),
        continuation,
    }
}

/// The stack size the Vulkan specification defines for a pipeline created
/// without `VK_DYNAMIC_STATE_RAY_TRACING_PIPELINE_STACK_SIZE_KHR` ("Ray Tracing
/// Pipeline Stack"):
///
/// ```text
/// rayGenStackMax
///   + min(1, maxPipelineRayRecursionDepth) * max(closestHitStackMax, missStackMax,
///                                                intersectionStackMax + anyHitStackMax)
///   + max(0, maxPipelineRayRecursionDepth - 1) * max(closestHitStackMax, missStackMax)
///   + 2 * callableStackMax
/// ```
///
/// It is [`refined`] with call trees of callables at most two deep, counting every
/// callable (direct or continuation) at the largest callable's size.
pub fn vulkan_default(s: &StackSizes, max_pipeline_ray_recursion_depth: u32) -> u64 {
    let depth = u64::from(max_pipeline_ray_recursion_depth);
    let ch_or_ms = s.css_ch.max(s.css_ms);
    let callable = s.css_cc.max(s.dss_dc);
    s.css_rg
        .saturating_add(depth.min(1).saturating_mul(ch_or_ms.max(s.css_is.saturating_add(s.css_ah))))
        .saturating_add(depth.saturating_sub(1).saturating_mul(ch_or_ms))
        .saturating_add(callable.saturating_mul(2))
}

/// How a pipeline's stack size is chosen; see [`Pipeline::set_stack_size`](crate::Pipeline::set_stack_size).
#[derive(Clone, Debug)]
pub enum StackSize<'g> {
    /// What the Vulkan specification defines for a pipeline without dynamic stack
    /// state ([`vulkan_default`]): the default, as if raykit set nothing.
    DriverDefault,
    /// [`conservative`] with these depths.
    Conservative(CallDepths),
    /// [`refined`] with these depths.
    Refined(CallDepths),
    /// [`CallGraph::estimate`] of this graph.
    CallGraph(&'g CallGraph),
    /// This many bytes.
    Explicit(u32),
}

/// A stack size as `vkCmdSetRayTracingPipelineStackSizeKHR` takes it.
pub(crate) fn stack_bytes(bytes: u64) -> Result<u32> {
    u32::try_from(bytes).map_err(|_| {
        Error::Link(LinkError::StackSize { reason: format!("{bytes} bytes do not fit the 32 bits Vulkan takes") })
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sizes() -> StackSizes {
        StackSizes { css_rg: 16, css_ms: 8, css_ch: 64, css_ah: 12, css_is: 20, css_cc: 24, dss_dc: 40 }
    }

    #[test]
    fn accumulate_takes_maxima_by_kind() {
        let s = StackSizes::from_groups([
            (GroupRole::Raygen, GroupStackSizes { general: 16, ..Default::default() }),
            (GroupRole::Miss, GroupStackSizes { general: 8, ..Default::default() }),
            (GroupRole::Miss, GroupStackSizes { general: 4, ..Default::default() }),
            (GroupRole::Hit, GroupStackSizes { closest_hit: 64, any_hit: 12, intersection: 20, general: 0 }),
            (GroupRole::Hit, GroupStackSizes { closest_hit: 32, any_hit: 0, intersection: 0, general: 0 }),
            (GroupRole::ContinuationCallable, GroupStackSizes { general: 24, ..Default::default() }),
            (GroupRole::DirectCallable, GroupStackSizes { general: 40, ..Default::default() }),
            (GroupRole::Callable, GroupStackSizes { general: 10, ..Default::default() }),
        ]);
        assert_eq!(s, sizes());
    }

    #[test]
    fn conservative_formula_by_hand() {
        let d = CallDepths::new(3).continuation_callables(2).direct_callables(1).direct_callables_from_traversal(0);
        let e = conservative(&sizes(), &d);
        // max_dc_depth = max(0, 1) = 1, both parts 1 * 40.
        assert_eq!((e.direct_from_traversal, e.direct_from_state), (40, 40));
        // css_cc_tree = 2 * 24 = 48; per level = max(64, 8) + 48 = 112;
        // 16 + 48 + 3 * 112 + 20 + 12 = 432.
        assert_eq!(e.continuation, 432);
        assert_eq!(e.total(), 512);
    }

    #[test]
    fn refined_formula_by_hand() {
        let d = CallDepths::new(3).continuation_callables(2).direct_callables(1);
        let e = refined(&sizes(), &d);
        // Traversal depth 0: no direct stack from traversal.
        assert_eq!((e.direct_from_traversal, e.direct_from_state), (0, 40));
        // 16 + 48 + 2 * 112 + 1 * max(112, 32) = 400.
        assert_eq!(e.continuation, 400);
        assert_eq!(e.total(), 440);
    }

    #[test]
    fn refined_offsets_traversal_against_one_level() {
        // Intersection and any-hit larger than closest-hit: they replace a level.
        let s = StackSizes { css_rg: 10, css_ms: 5, css_ch: 30, css_is: 50, css_ah: 20, ..Default::default() };
        let d = CallDepths::new(2);
        assert_eq!(conservative(&s, &d).continuation, 10 + 2 * 30 + 50 + 20);
        assert_eq!(refined(&s, &d).continuation, 10 + 30 + 70);
        // Depth 0 (only raygen runs): no level at all.
        assert_eq!(refined(&s, &CallDepths::new(0)).continuation, 10);
    }

    #[test]
    fn refined_is_never_worse_than_conservative() {
        // Including depth 1, where the guide's `(max_trace_depth - 1).max(1)` would
        // count two levels.
        for depth in 0..6 {
            for (ch, ms, is, ah) in [(64, 8, 0, 0), (0, 0, 30, 30), (10, 90, 5, 0), (7, 7, 7, 7)] {
                let s = StackSizes { css_rg: 3, css_ms: ms, css_ch: ch, css_is: is, css_ah: ah, css_cc: 5, dss_dc: 9 };
                let d = CallDepths::new(depth).continuation_callables(1).direct_callables(2);
                assert!(refined(&s, &d).total() <= conservative(&s, &d).total(), "depth {depth}, {s:?}");
            }
        }
    }

    #[test]
    fn vulkan_default_by_hand() {
        let s = sizes();
        // 16 + 1 * max(64, 8, 20 + 12) + 2 * max(64, 8) + 2 * max(24, 40) = 288.
        assert_eq!(vulkan_default(&s, 3), 16 + 64 + 128 + 80);
        assert_eq!(vulkan_default(&s, 0), 16 + 80);
        // Equal to `refined` with callables two deep at the largest callable's size.
        let as_refined = StackSizes { css_cc: 0, dss_dc: 40, ..s };
        assert_eq!(vulkan_default(&s, 3), refined(&as_refined, &CallDepths::new(3).direct_callables(2)).total());
    }

    /// The OptiX guide's path tracer: camera rays (ms1, ch1), shadow rays (ms2, ch2)
    /// traced from ch1.
    fn path_tracer(ms1: u64, ch1: u64, ms2: u64, ch2: u64) -> (CallGraph, StackSizes) {
        let mut g = CallGraph::new(2);
        let camera = g.ray_type();
        let shadow = g.ray_type();
        let rg = g.raygen(16);
        g.miss(camera, ms1);
        let h1 = g.hit(camera, GroupStackSizes { closest_hit: ch1, ..Default::default() });
        g.miss(shadow, ms2);
        g.hit(shadow, GroupStackSizes { closest_hit: ch2, ..Default::default() });
        g.traces(rg, camera).traces(h1, shadow);
        let s = StackSizes { css_rg: 16, css_ms: ms1.max(ms2), css_ch: ch1.max(ch2), ..Default::default() };
        (g, s)
    }

    #[test]
    fn path_tracer_call_graph_is_strictly_smaller() -> Result<()> {
        let (g, s) = path_tracer(8, 96, 4, 32);
        let depths = CallDepths::new(2);
        // css_rg + 2 * max(css_ch1, css_ch2, css_ms1, css_ms2)
        assert_eq!(conservative(&s, &depths).total(), 16 + 2 * 96);
        assert_eq!(refined(&s, &depths).total(), 16 + 2 * 96);
        assert_eq!(vulkan_default(&s, 2), 16 + 2 * 96);
        // css_rg + max(css_ms1, css_ch1 + max(css_ms2, css_ch2))
        assert_eq!(g.estimate()?, 16 + 96 + 32);
        assert!(g.estimate()? < conservative(&s, &depths).total());
        Ok(())
    }

    #[test]
    fn path_tracer_call_graph_picks_the_miss_when_it_dominates() -> Result<()> {
        let (g, _) = path_tracer(500, 96, 4, 32);
        assert_eq!(g.estimate()?, 16 + 500);
        Ok(())
    }

    #[test]
    fn recursion_counts_each_level_once() -> Result<()> {
        // A closest-hit that traces its own ray type, four levels deep; the
        // intersection + any-hit of the last level do not stack on closest-hit.
        let mut g = CallGraph::new(4);
        let ray = g.ray_type();
        let rg = g.raygen(10);
        g.miss(ray, 3);
        let h = g.hit(ray, GroupStackSizes { closest_hit: 100, any_hit: 30, intersection: 50, general: 0 });
        g.traces(rg, ray).traces(h, ray);
        assert_eq!(g.estimate()?, 10 + 4 * 100);
        let s = StackSizes { css_rg: 10, css_ms: 3, css_ch: 100, css_ah: 30, css_is: 50, ..Default::default() };
        assert_eq!(refined(&s, &CallDepths::new(4)).total(), 10 + 4 * 100);
        assert_eq!(conservative(&s, &CallDepths::new(4)).total(), 10 + 4 * 100 + 80);
        // Only raygen runs at depth 0.
        let mut g0 = g.clone();
        g0.max_trace_depth = 0;
        assert_eq!(g0.estimate()?, 10);
        Ok(())
    }

    #[test]
    fn callables_stack_on_their_caller() -> Result<()> {
        let mut g = CallGraph::new(1);
        let ray = g.ray_type();
        let rg = g.raygen(10);
        let h = g.hit(ray, GroupStackSizes { closest_hit: 20, ..Default::default() });
        let a = g.callable(7);
        let b = g.callable(5);
        let c = g.callable(50);
        g.traces(rg, ray).calls(h, a).calls(a, b).calls(rg, c);
        // max(raygen → c: 10 + 50, raygen → hit → a → b: 10 + 20 + 7 + 5)
        assert_eq!(g.estimate()?, 60);
        g.max_call_depth(1);
        assert_eq!(g.estimate()?, 60);
        let mut g2 = g.clone();
        g2.calls(b, a);
        g2.max_call_depth = None;
        assert!(matches!(g2.estimate(), Err(Error::Link(LinkError::CallGraph { .. }))));
        // A recursive pair bounded at 5 levels: hit → a → b → a → b → a.
        g2.max_call_depth(5);
        assert_eq!(g2.estimate()?, 10 + 20 + 7 + 5 + 7 + 5 + 7);
        Ok(())
    }

    #[test]
    fn graphs_refuse_foreign_ids_and_missing_raygen() {
        let mut g = CallGraph::new(1);
        let ray = g.ray_type();
        g.miss(ray, 3);
        assert!(matches!(g.estimate(), Err(Error::Link(LinkError::CallGraph { .. }))));
        let rg = g.raygen(1);
        g.traces(rg, RayTypeId(7));
        assert!(matches!(g.estimate(), Err(Error::Link(LinkError::CallGraph { .. }))));
        let mut g = CallGraph::new(1);
        g.raygen(1);
        g.hit(RayTypeId(3), GroupStackSizes::default());
        assert!(matches!(g.estimate(), Err(Error::Link(LinkError::CallGraph { .. }))));
        let mut g = CallGraph::new(1);
        let rg = g.raygen(1);
        let other = g.raygen(2);
        g.calls(rg, other);
        assert!(matches!(g.estimate(), Err(Error::Link(LinkError::CallGraph { .. }))));
        let mut g = CallGraph::new(MAX_GRAPH_DEPTH + 1);
        g.raygen(1);
        assert!(matches!(g.estimate(), Err(Error::Link(LinkError::CallGraph { .. }))));
    }
}
