//! The call graph of a pipeline's programs, for [`refined`](super::refined)
//! stack sizes: which programs trace which ray types and call which callables,
//! and the deepest stack a launch can need through them.

use super::GroupStackSizes;
use crate::error::{Error, LinkError, Result};

/// A ray type in a [`CallGraph`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct RayTypeId(pub(super) usize);

/// A program (group) in a [`CallGraph`].
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct ProgramId(pub(super) usize);

#[derive(Clone, Debug)]
enum Node {
    Raygen { css: u64 },
    Miss { css: u64 },
    Hit { sizes: GroupStackSizes },
    Callable { size: u64 },
}

#[derive(Clone, Debug, Default)]
struct RayTypeNode {
    miss: Vec<usize>,
    hits: Vec<usize>,
}

/// Which ray types each program traces and which callables it calls: the input
/// of the tightest estimate, [`CallGraph::estimate`].
///
/// Programs are added with their own stack sizes (from
/// [`Pipeline::group_stack_sizes`](crate::Pipeline::group_stack_sizes) or by
/// hand); miss and hit programs belong to the ray type that invokes them. The
/// estimate is the heaviest chain of calls from a raygen program, where
///
/// * a program needs its own size plus the largest need among the ray types it
///   traces and the callables it calls;
/// * tracing a ray type needs the largest of its miss programs and of its hit
///   groups, a hit group needing `max(css_is + css_ah, css_ch + what the closest-hit
///   traces and calls)` (traversal programs are done before closest-hit runs);
/// * tracing stops at the trace depth: a program invoked at depth
///   `max_trace_depth` traces nothing (it would exceed the pipeline's recursion
///   depth), so recursive programs (a closest-hit tracing its own ray type) are
///   counted exactly `max_trace_depth` times; callable recursion likewise stops at
///   [`CallGraph::max_call_depth`].
///
/// ```
/// use raykit::stack::{CallGraph, GroupStackSizes};
/// // The OptiX guide's path tracer: camera rays (ms1, ch1), shadow rays (ms2, ch2) traced by ch1.
/// let mut graph = CallGraph::new(2);
/// let (camera, shadow) = (graph.ray_type(), graph.ray_type());
/// let rg = graph.raygen(16);
/// graph.miss(camera, 8);
/// let ch1 = graph.hit(camera, GroupStackSizes { closest_hit: 64, ..Default::default() });
/// graph.miss(shadow, 4);
/// graph.hit(shadow, GroupStackSizes { closest_hit: 32, ..Default::default() });
/// graph.traces(rg, camera).traces(ch1, shadow);
/// // css_rg + max(css_ms1, css_ch1 + max(css_ms2, css_ch2)) = 16 + max(8, 64 + 32)
/// assert_eq!(graph.estimate()?, 112);
/// # Ok::<(), raykit::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct CallGraph {
    pub(super) max_trace_depth: u32,
    pub(super) max_call_depth: Option<u32>,
    nodes: Vec<Node>,
    ray_types: Vec<RayTypeNode>,
    /// (caller, ray type) edges.
    traces: Vec<(ProgramId, RayTypeId)>,
    /// (caller, callee) edges.
    calls: Vec<(ProgramId, ProgramId)>,
    /// A ray type of another graph given to `miss` or `hit`, refused by `estimate`.
    foreign_ray_type: Option<RayTypeId>,
}

/// The largest trace or call depth a [`CallGraph`] evaluates.
pub const MAX_GRAPH_DEPTH: u32 = 1024;

impl CallGraph {
    /// An empty graph for a pipeline tracing to `max_trace_depth`.
    pub fn new(max_trace_depth: u32) -> CallGraph {
        CallGraph {
            max_trace_depth,
            max_call_depth: None,
            nodes: Vec::new(),
            ray_types: Vec::new(),
            traces: Vec::new(),
            calls: Vec::new(),
            foreign_ray_type: None,
        }
    }

    /// Bounds nested callable calls to `depth` levels. Without it the depth is the
    /// longest chain of calls, and a cycle of callables is refused.
    pub fn max_call_depth(&mut self, depth: u32) -> &mut Self {
        self.max_call_depth = Some(depth);
        self
    }

    /// The trace depth this graph is evaluated at.
    pub fn max_trace_depth(&self) -> u32 {
        self.max_trace_depth
    }

    fn add(&mut self, node: Node) -> ProgramId {
        self.nodes.push(node);
        ProgramId(self.nodes.len() - 1)
    }

    /// A new ray type.
    pub fn ray_type(&mut self) -> RayTypeId {
        self.ray_types.push(RayTypeNode::default());
        RayTypeId(self.ray_types.len() - 1)
    }

    /// A raygen program needing `css` bytes.
    pub fn raygen(&mut self, css: u64) -> ProgramId {
        self.add(Node::Raygen { css })
    }

    /// A miss program of `ray` needing `css` bytes.
    pub fn miss(&mut self, ray: RayTypeId, css: u64) -> ProgramId {
        let id = self.add(Node::Miss { css });
        match self.ray_types.get_mut(ray.0) {
            Some(r) => r.miss.push(id.0),
            None => self.foreign_ray_type = Some(ray),
        }
        id
    }

    /// A hit group of `ray` with its closest-hit, any-hit and intersection sizes.
    pub fn hit(&mut self, ray: RayTypeId, sizes: GroupStackSizes) -> ProgramId {
        let id = self.add(Node::Hit { sizes });
        match self.ray_types.get_mut(ray.0) {
            Some(r) => r.hits.push(id.0),
            None => self.foreign_ray_type = Some(ray),
        }
        id
    }

    /// A callable program (direct or continuation: both run on Vulkan's one
    /// stack) needing `size` bytes.
    pub fn callable(&mut self, size: u64) -> ProgramId {
        self.add(Node::Callable { size })
    }

    /// `program` traces rays of type `ray`.
    pub fn traces(&mut self, program: ProgramId, ray: RayTypeId) -> &mut Self {
        self.traces.push((program, ray));
        self
    }

    /// `program` calls `callable`.
    pub fn calls(&mut self, program: ProgramId, callable: ProgramId) -> &mut Self {
        self.calls.push((program, callable));
        self
    }

    fn check(&self) -> Result<()> {
        let bad = |reason: String| Err(Error::Link(LinkError::CallGraph { reason }));
        if let Some(r) = self.foreign_ray_type {
            return bad(format!("a miss or hit program was added to {r:?}, which is not of this graph"));
        }
        for &(p, r) in &self.traces {
            if p.0 >= self.nodes.len() || r.0 >= self.ray_types.len() {
                return bad(format!("{p:?} or {r:?} is not of this graph"));
            }
            if matches!(self.nodes[p.0], Node::Callable { .. }) {
                // Allowed by OptiX for continuation callables, not by Vulkan.
                return bad(format!(
                    "callable {p:?} traces rays: Vulkan allows OpTraceRayKHR only in raygen, miss and closest-hit"
                ));
            }
        }
        for &(p, c) in &self.calls {
            if p.0 >= self.nodes.len() || c.0 >= self.nodes.len() {
                return bad(format!("{p:?} or {c:?} is not of this graph"));
            }
            if !matches!(self.nodes[c.0], Node::Callable { .. }) {
                return bad(format!("{p:?} calls {c:?}, which is not a callable"));
            }
        }
        if !self.nodes.iter().any(|n| matches!(n, Node::Raygen { .. })) {
            return bad("the graph has no raygen program".to_owned());
        }
        if self.max_trace_depth > MAX_GRAPH_DEPTH || self.max_call_depth.is_some_and(|d| d > MAX_GRAPH_DEPTH) {
            return bad(format!("depths above {MAX_GRAPH_DEPTH} are not evaluated"));
        }
        Ok(())
    }

    /// The longest chain of callable calls, or an error naming a cycle.
    fn call_chain_depth(&self) -> Result<u32> {
        // Longest path in the callee graph by depth-first search with colours.
        fn visit(graph: &CallGraph, node: usize, state: &mut [u8], depth: &mut [u32]) -> Result<u32> {
            match state[node] {
                2 => return Ok(depth[node]),
                1 => {
                    return Err(Error::Link(LinkError::CallGraph {
                        reason: format!("callables call each other in a cycle (through ProgramId({node})); bound it with CallGraph::max_call_depth"),
                    }))
                }
                _ => {}
            }
            state[node] = 1;
            let mut deepest = 0;
            for &(_, callee) in graph.calls.iter().filter(|(p, _)| p.0 == node) {
                deepest = deepest.max(1 + visit(graph, callee.0, state, depth)?);
            }
            state[node] = 2;
            depth[node] = deepest;
            Ok(deepest)
        }
        let mut state = vec![0u8; self.nodes.len()];
        let mut depth = vec![0u32; self.nodes.len()];
        let mut deepest = 0;
        for node in 0..self.nodes.len() {
            deepest = deepest.max(visit(self, node, &mut state, &mut depth)?);
        }
        Ok(deepest)
    }

    /// The stack the graph needs, in bytes: the heaviest chain from a raygen
    /// program (see the type's docs).
    pub fn estimate(&self) -> Result<u64> {
        self.check()?;
        let max_call = match self.max_call_depth {
            Some(d) => d,
            None => self.call_chain_depth()?,
        };
        let (levels_t, levels_c) = (self.max_trace_depth as usize + 1, max_call as usize + 1);
        let n = self.nodes.len();
        // need[(t, c, node)]: the stack of `node` and everything below it, when it
        // may still trace `t` levels and nest `c` calls. Tracing uses (t - 1, c),
        // calling (t, c - 1), so filling t then c in increasing order is enough.
        let cells = levels_t.saturating_mul(levels_c).saturating_mul(n);
        if cells > 1 << 24 {
            return Err(Error::Link(LinkError::CallGraph {
                reason: format!("{n} programs at depths {}×{max_call} are too many to evaluate", self.max_trace_depth),
            }));
        }
        let index = |t: usize, c: usize, node: usize| (t * levels_c + c) * n + node;
        let mut need = vec![0u64; cells];
        for t in 0..levels_t {
            for c in 0..levels_c {
                for node in 0..n {
                    let mut below = 0u64;
                    if t > 0 {
                        for &(_, ray) in self.traces.iter().filter(|(p, _)| p.0 == node) {
                            below = below.max(self.trace_need(ray.0, |m| need[index(t - 1, c, m)]));
                        }
                    }
                    if c > 0 {
                        for &(_, callee) in self.calls.iter().filter(|(p, _)| p.0 == node) {
                            below = below.max(need[index(t, c - 1, callee.0)]);
                        }
                    }
                    let own = match &self.nodes[node] {
                        Node::Raygen { css } | Node::Miss { css } => *css,
                        Node::Callable { size } => *size,
                        Node::Hit { sizes } => sizes.closest_hit,
                    };
                    need[index(t, c, node)] = own.saturating_add(below);
                }
            }
        }
        let top = index(levels_t - 1, levels_c - 1, 0);
        Ok((0..n)
            .filter(|&node| matches!(self.nodes[node], Node::Raygen { .. }))
            .map(|node| need[top + node])
            .max()
            .unwrap_or(0))
    }

    /// What tracing `ray` needs, given each program's need one level down.
    fn trace_need(&self, ray: usize, program_need: impl Fn(usize) -> u64) -> u64 {
        let r = &self.ray_types[ray];
        let miss = r.miss.iter().map(|&m| program_need(m)).max().unwrap_or(0);
        let hit = r
            .hits
            .iter()
            .map(|&h| {
                let traversal = match &self.nodes[h] {
                    Node::Hit { sizes } => sizes.intersection.saturating_add(sizes.any_hit),
                    _ => 0,
                };
                traversal.max(program_need(h))
            })
            .max()
            .unwrap_or(0);
        miss.max(hit)
    }
}
