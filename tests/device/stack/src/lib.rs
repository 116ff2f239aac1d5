//! Device programs that really use stack, for raykit's stack-size tests and the
//! `stack` benchmark suite.
//!
//! The scene is a pile of translucent square layers under an orthographic camera
//! looking down -z. The closest-hit program of a layer fills a local array, traces
//! the same ray type on downwards (recursion: one trace level per layer, up to
//! [`MAX_DEPTH`]), then blends its colour over what it got back with a weight picked
//! from the array by the result: the array is live across the trace, so it has to
//! be kept on the pipeline's stack. [`reference()`] computes the same picture on the
//! CPU from the same helpers.
#![cfg_attr(target_arch = "spirv", no_std)]

use raykit_device::glam::{UVec2, Vec3};
use raykit_device::{
    closest_hit, miss, raygen, Buffer, ClosestHit, LaunchParams, Miss, Ray, RayType, Raygen, Traversable,
};

/// Launch params.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Params {
    /// RGBA8 pixels, row-major, row 0 at the top.
    pub image: Buffer<u32>,
    /// Padding: `size` on 8 bytes on every target.
    pub _pad: u32,
    /// Image size.
    pub size: UVec2,
    /// The scene.
    pub scene: Traversable,
}

/// The payload of [`Layered`] rays.
#[derive(Copy, Clone, Default)]
pub struct LayerPayload {
    /// In: nothing; out: the colour seen along the ray.
    pub color: Vec3,
    /// In: the trace depth of this ray (1 for raygen's).
    pub depth: u32,
    /// Out: how many layers the ray went through.
    pub layers: u32,
}

/// The one ray type, traced by raygen and, recursively, by closest-hit.
pub struct Layered;
impl RayType for Layered {
    type Payload = LayerPayload;
}

/// The deepest trace: raygen's ray is depth 1, each layer's closest-hit traces
/// one deeper while the depth is below this. The pipeline's `max_trace_depth`.
pub const MAX_DEPTH: u32 = 6;
/// Number of layers.
pub const LAYERS: u32 = 5;
/// Background colour (miss).
pub const BACKGROUND: Vec3 = Vec3::new(0.05, 0.1, 0.2);
/// Entries of the closest-hit's local array.
pub const WEIGHTS: usize = 8;

/// Layer `l`'s square: centre x, centre y, half-size; it lies at `z = 5 - l`.
pub fn layer_square(l: u32) -> (f32, f32, f32) {
    match l {
        0 => (0.0, 0.0, 0.8),
        1 => (0.2, 0.1, 0.7),
        2 => (-0.2, 0.1, 0.6),
        3 => (0.0, -0.2, 0.6),
        _ => (0.1, 0.0, 0.5),
    }
}

/// Height of layer `l`.
pub fn layer_z(l: u32) -> f32 {
    5.0 - l as f32
}

/// Layer `l`'s own colour.
pub fn layer_color(l: u32) -> Vec3 {
    let f = l as f32;
    Vec3::new(0.2 * f, 1.0 - 0.15 * f, 0.5 + (l % 2) as f32 * 0.3)
}

/// The local array of layer `l`'s closest-hit: blend weights.
pub fn weights(l: u32) -> [f32; WEIGHTS] {
    let mut w = [0.0f32; WEIGHTS];
    let mut i = 0;
    while i < WEIGHTS {
        let fi = i as f32;
        w[i] = (fi + 1.0) / (fi + 2.0 + l as f32);
        i += 1;
    }
    w
}

/// Layer `l`'s colour over what lies below it (`below`, through `below_layers`
/// layers), with the weight the local array `w` gives for that.
pub fn blend(l: u32, w: &[f32; WEIGHTS], below: Vec3, below_layers: u32) -> Vec3 {
    let k = ((below_layers + l) % WEIGHTS as u32) as usize;
    let a = w[k];
    layer_color(l) * a + below * (1.0 - a)
}

/// An orthographic camera looking down -z from z = 10 over `[-1, 1]²`: the ray
/// of pixel `index`.
pub fn ortho_ray(index: UVec2, size: UVec2) -> (Vec3, Vec3) {
    let x = (index.x as f32 + 0.5) / size.x as f32 * 2.0 - 1.0;
    let y = 1.0 - (index.y as f32 + 0.5) / size.y as f32 * 2.0;
    (Vec3::new(x, y, 10.0), Vec3::new(0.0, 0.0, -1.0))
}

/// Quantises a colour to RGBA8.
pub fn pack(c: Vec3) -> u32 {
    let q = |v: f32| -> u32 { (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u32 };
    q(c.x) | (q(c.y) << 8) | (q(c.z) << 16) | (255 << 24)
}

/// The CPU reference of pixel `index`: the layers over `(x, y)` top down, each
/// closest-hit tracing on while its depth is below [`MAX_DEPTH`].
pub fn reference(index: UVec2, size: UVec2) -> Vec3 {
    let (origin, _) = ortho_ray(index, size);
    // Layers hit along the ray, top down, as far as the depth allows.
    let mut hit = [0u32; LAYERS as usize];
    let mut count = 0usize;
    let mut depth = 1;
    for l in 0..LAYERS {
        let (cx, cy, h) = layer_square(l);
        if (origin.x - cx).abs() <= h && (origin.y - cy).abs() <= h {
            if depth > MAX_DEPTH {
                break;
            }
            hit[count] = l;
            count += 1;
            depth += 1;
        }
    }
    // What the deepest closest-hit got back: the miss, unless it could not trace.
    let mut color = BACKGROUND;
    let mut layers = 0;
    for i in (0..count).rev() {
        let l = hit[i];
        let traced = (i as u32 + 1) < MAX_DEPTH;
        let (below, below_layers) = if traced { (color, layers) } else { (BACKGROUND, 0) };
        color = blend(l, &weights(l), below, below_layers);
        layers = below_layers + 1;
    }
    color
}

#[raygen]
fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] payload: &mut LayerPayload) {
    let index = ctx.launch_index().truncate();
    let (origin, dir) = ortho_ray(index, p.size);
    payload.color = Vec3::ZERO;
    payload.depth = 1;
    payload.layers = 0;
    ctx.trace_from::<Layered>(p.scene, origin, dir, payload);
    let pixel = ctx.launch_linear_index();
    ctx.store(p.image, pixel, pack(payload.color));
}

#[miss(ray = Layered)]
fn ms(_ctx: &mut Miss, #[payload] payload: &mut LayerPayload) {
    payload.color = BACKGROUND;
    payload.layers = 0;
}

#[closest_hit(ray = Layered)]
fn layer_hit(
    ctx: &mut ClosestHit,
    #[params] p: &Params,
    #[payload] payload: &mut LayerPayload,
    #[trace_payload] below: &mut LayerPayload,
) {
    // Two triangles per layer.
    let l = ctx.primitive_index() / 2;
    // Live across the trace below: kept on the stack.
    let w = weights(l);
    below.color = BACKGROUND;
    below.layers = 0;
    below.depth = payload.depth + 1;
    if payload.depth < MAX_DEPTH {
        let hit = ctx.world_ray_origin() + ctx.hit_t() * ctx.world_ray_direction();
        ctx.trace::<Layered>(p.scene, Ray::new(hit, ctx.world_ray_direction()).with_interval(0.01, 1e16), below);
    }
    payload.color = blend(l, &w, below.color, below.layers);
    payload.layers = below.layers + 1;
}

/// The same layered rays, with the trace depth kept by raykit
/// ([`RayType::CHECK_DEPTH`]) in [`LayerPayload::depth`]: `unbounded_hit` traces
/// on through every layer without looking at the depth, and the pipeline's
/// `max_trace_depth` is what stops it.
pub struct Unbounded;
impl RayType for Unbounded {
    type Payload = LayerPayload;
    const CHECK_DEPTH: bool = true;
    fn depth(payload: &LayerPayload) -> u32 {
        payload.depth
    }
    fn set_depth(payload: &mut LayerPayload, depth: u32) {
        payload.depth = depth;
    }
}

/// Raygen of [`Unbounded`] rays: as [`rg`], but the depth is left to raykit.
#[raygen]
fn rg_unbounded(ctx: &mut Raygen, #[params] p: &Params, #[payload] payload: &mut LayerPayload) {
    let index = ctx.launch_index().truncate();
    let (origin, dir) = ortho_ray(index, p.size);
    payload.color = Vec3::ZERO;
    payload.layers = 0;
    ctx.trace_from::<Unbounded>(p.scene, origin, dir, payload);
    let pixel = ctx.launch_linear_index();
    ctx.store(p.image, pixel, pack(payload.color));
}

#[miss(ray = Unbounded)]
fn ms_unbounded(_ctx: &mut Miss, #[payload] payload: &mut LayerPayload) {
    payload.color = BACKGROUND;
    payload.layers = 0;
}

/// A closest-hit whose recursion the SPIR-V cannot bound: it always traces on.
/// Where raykit refuses the trace (past `max_trace_depth`), `below` keeps the
/// background it was given, as [`reference_unbounded`] assumes.
#[closest_hit(ray = Unbounded)]
fn unbounded_hit(
    ctx: &mut ClosestHit,
    #[params] p: &Params,
    #[payload] payload: &mut LayerPayload,
    #[trace_payload] below: &mut LayerPayload,
) {
    let l = ctx.primitive_index() / 2;
    let w = weights(l);
    below.color = BACKGROUND;
    below.layers = 0;
    let hit = ctx.world_ray_origin() + ctx.hit_t() * ctx.world_ray_direction();
    ctx.trace::<Unbounded>(p.scene, Ray::new(hit, ctx.world_ray_direction()).with_interval(0.01, 1e16), below);
    payload.color = blend(l, &w, below.color, below.layers);
    payload.layers = below.layers + 1;
}

/// How many layers the ray of pixel `index` passes through.
pub fn layers_over(index: UVec2, size: UVec2) -> u32 {
    let (origin, _) = ortho_ray(index, size);
    let mut n = 0;
    for l in 0..LAYERS {
        let (cx, cy, h) = layer_square(l);
        if (origin.x - cx).abs() <= h && (origin.y - cy).abs() <= h {
            n += 1;
        }
    }
    n
}

/// The CPU reference of pixel `index` for `unbounded_hit` in a pipeline linked
/// with `max_trace_depth`: the closest-hit at depth `max_trace_depth` has its
/// trace refused and blends over the background.
pub fn reference_unbounded(index: UVec2, size: UVec2, max_trace_depth: u32) -> Vec3 {
    let (origin, _) = ortho_ray(index, size);
    let mut hit = [0u32; LAYERS as usize];
    let mut count = 0usize;
    for l in 0..LAYERS {
        let (cx, cy, h) = layer_square(l);
        if (origin.x - cx).abs() <= h && (origin.y - cy).abs() <= h && (count as u32) < max_trace_depth {
            hit[count] = l;
            count += 1;
        }
    }
    let (mut color, mut layers) = (BACKGROUND, 0);
    for i in (0..count).rev() {
        let l = hit[i];
        color = blend(l, &weights(l), color, layers);
        layers += 1;
    }
    color
}
