//! Attribute macros for raykit device programs.
//!
//! Each macro wraps a plain Rust function and emits the SPIR-V entry point with
//! OptiX's prefixed name (`__raygen__<name>`, `__miss__<name>`,
//! `__closesthit__<name>`), plus a constant `<NAME>: raykit_device::EntryPoint`
//! through which the host names the program. Use them through `raykit-device`
//! or `raykit` (as `raykit::device`), which re-export them: the generated code
//! names whichever of the two the calling crate depends on.
//!
//! The function's parameters are matched by role:
//! * one parameter without a raykit attribute: the stage context
//!   (`&mut Raygen`, `&mut Miss`, `&mut ClosestHit`, or by value);
//! * `#[params] p: &P`: the launch params (push constants);
//! * `#[record] r: &R`: the program's SBT record data;
//! * `#[payload] p: &mut T`: the ray payload (raygen may have several, one per
//!   ray type it traces; miss, closest-hit and any-hit have one incoming);
//! * `#[trace_payload] p: &mut T`: an outgoing payload, for `trace` in miss,
//!   closest-hit and continuation-callable programs;
//! * `#[call_data] d: &mut T`: outgoing data for `call` (callables);
//! * `#[callable_data] d: &mut T`: a callable program's incoming data;
//! * `#[attributes] a: &mut T` (intersection) / `a: &T` (any-hit, closest-hit):
//!   typed hit attributes;
//! * `#[spec_constant(id = N, default = D)] x: u32`: a specialization constant
//!   (OptiX's bound launch-params values), set per pipeline by the host.
//!
//! `#[miss(ray = R)]`, `#[closest_hit(ray = R)]` and `#[any_hit(ray = R)]` check at
//! compile time that the payload is `<R as RayType>::Payload`. A role a stage
//! cannot have (a payload in an intersection program, tracing from a direct
//! callable) is a compile error that says so.

#![forbid(unsafe_code)]

mod element;
mod launch_params;
mod manifest;
mod program;
mod root;

use proc_macro::TokenStream;
use raykit_abi::ProgramPrefix;

/// Marks a ray-generation program (`__raygen__<name>`): OptiX's `__raygen__`, run
/// once per launch index. It takes its context (`&mut Raygen`: launch index and
/// size, `trace`, `load` and `store`), and may take `#[params]`, `#[record]`, one
/// `#[payload]` per ray type it traces, `#[call_data]` and `#[spec_constant]`s.
///
/// ```
/// use raykit_device::glam::{UVec2, Vec3};
/// use raykit_device::{raygen, Buffer, LaunchParams, RayType, Raygen, Traversable};
///
/// #[repr(C)]
/// #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
/// pub struct Params { pub image: Buffer<Vec3>, pub size: UVec2, pub _pad: u32, pub scene: Traversable }
///
/// pub struct Radiance;
/// impl RayType for Radiance { type Payload = Vec3; }
///
/// /// One ray down -z through each pixel of the unit square; stores what came back.
/// #[raygen]
/// fn rg(ctx: &mut Raygen, #[params] p: &Params, #[payload] color: &mut Vec3) {
///     let pixel = ctx.launch_index().truncate().as_vec2() + 0.5;
///     let origin = (pixel / p.size.as_vec2()).extend(1.0);
///     ctx.trace_from::<Radiance>(p.scene, origin, Vec3::NEG_Z, color);
///     ctx.store(p.image, ctx.launch_linear_index(), *color);
/// }
/// // The host names the program by the constant the macro makes.
/// assert_eq!(RG.name, "__raygen__rg");
/// ```
#[proc_macro_attribute]
#[doc(alias("__raygen__"))]
pub fn raygen(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Raygen, attr.into(), item.into())).into()
}

/// Marks a miss program (`__miss__<name>`): run when a ray hits nothing. With
/// `ray = RayType` its `#[payload]` is checked to be the ray type's at compile
/// time. It may take `#[params]`, `#[record]` (its SBT record: a background
/// colour, an environment map) and, to trace further, `#[trace_payload]`.
///
/// ```
/// use raykit_device::glam::Vec3;
/// use raykit_device::{miss, Miss, RayType};
///
/// pub struct Radiance;
/// impl RayType for Radiance { type Payload = Vec3; }
///
/// /// The miss record: the sky's colour.
/// #[repr(C)]
/// #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
/// pub struct Sky { pub color: Vec3 }
///
/// /// A sky that brightens towards the zenith.
/// #[miss(ray = Radiance)]
/// fn sky(ctx: &mut Miss, #[record] record: &Sky, #[payload] color: &mut Vec3) {
///     let up = 0.5 * (ctx.world_ray_direction().y + 1.0);
///     *color = record.color * (0.5 + 0.5 * up);
/// }
/// assert_eq!(SKY.name, "__miss__sky");
/// ```
#[proc_macro_attribute]
#[doc(alias("__miss__", "optixGetPayload_0", "optixSetPayload_0"))]
pub fn miss(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Miss, attr.into(), item.into())).into()
}

/// Marks a closest-hit program (`__closesthit__<name>`): run for the nearest hit a
/// ray found. It reads the hit (`barycentrics`, `primitive_index`, `ray_tmax`,
/// the instance, its transforms), its `#[record]` (the material), the
/// `#[attributes]` an intersection program reported, and writes the
/// `#[payload]`; with `#[trace_payload]` it may trace further rays (shadows,
/// bounces). Optional `ray = RayType`, checked against the payload.
///
/// ```
/// use raykit_device::glam::Vec3;
/// use raykit_device::{closest_hit, ClosestHit, RayType};
///
/// pub struct Radiance;
/// impl RayType for Radiance { type Payload = Vec3; }
///
/// /// A triangle's hit record: the colour of each of its corners.
/// #[repr(C)]
/// #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable)]
/// pub struct Corners { pub colors: [Vec3; 3] }
///
/// /// The corners' colours, blended by the hit's barycentrics.
/// #[closest_hit(ray = Radiance)]
/// fn shade(ctx: &mut ClosestHit, #[record] corners: &Corners, #[payload] color: &mut Vec3) {
///     let b = ctx.barycentrics();
///     *color = (1.0 - b.x - b.y) * corners.colors[0] + b.x * corners.colors[1] + b.y * corners.colors[2];
/// }
/// assert_eq!(SHADE.name, "__closesthit__shade");
/// ```
#[proc_macro_attribute]
#[doc(alias("__closesthit__", "optixGetPayload_0", "optixSetPayload_0", "optixGetSbtDataPointer"))]
pub fn closest_hit(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::ClosestHit, attr.into(), item.into())).into()
}

/// Marks an any-hit program (`__anyhit__<name>`): run for each candidate hit
/// closer than the closest so far, before it is accepted. It may
/// `ignore_intersection()` (alpha cut-outs: traversal goes on as if nothing was
/// hit) or `terminate_ray()` (shadow rays: the first hit is enough), and read
/// and write the `#[payload]`. Optional `ray = RayType`.
///
/// ```
/// use raykit_device::glam::Vec3;
/// use raykit_device::{any_hit, AnyHit, RayType};
///
/// pub struct Radiance;
/// impl RayType for Radiance { type Payload = Vec3; }
///
/// /// A checkerboard of holes in the object's xy plane: solid where the checker is even.
/// #[any_hit(ray = Radiance)]
/// fn cutout(ctx: &mut AnyHit, #[payload] _color: &mut Vec3) {
///     let p = (ctx.object_ray_origin() + ctx.ray_tmax() * ctx.object_ray_direction()) * 8.0;
///     if ((p.x + 64.0) as u32 + (p.y + 64.0) as u32) % 2 == 1 {
///         ctx.ignore_intersection();
///     }
/// }
/// assert_eq!(CUTOUT.name, "__anyhit__cutout");
/// ```
#[proc_macro_attribute]
#[doc(alias("__anyhit__", "optixGetPayload_0", "optixSetPayload_0"))]
pub fn any_hit(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::AnyHit, attr.into(), item.into())).into()
}

/// Marks an intersection program (`__intersection__<name>`): the ray test of
/// custom primitives (AABB geometry, `Gas::aabbs`), run for each primitive whose
/// box the ray enters. It computes the hit from the object-space ray
/// (`object_ray_origin`, `object_ray_direction`, `ray_tmin`, `ray_tmax`,
/// `primitive_index`), writes the `#[attributes]` the hit's closest-hit and
/// any-hit programs read, and calls `report_intersection(t, hit_kind)` for each
/// hit in the ray's interval; the closest reported hit wins. It may read
/// `#[params]` (and buffers through them) and its `#[record]`; it has no payload.
///
/// ```
/// use raykit_device::glam::{Vec3, Vec4};
/// use raykit_device::math::sqrt;
/// use raykit_device::{intersection, Buffer, Intersection, LaunchParams};
///
/// #[repr(C)]
/// #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
/// pub struct Params { pub spheres: Buffer<Vec4> }
///
/// /// What the closest-hit program reads: the normal at the hit.
/// #[derive(Copy, Clone, Default)]
/// pub struct SphereHit { pub normal: Vec3 }
///
/// /// Spheres `(centre, radius)`, one per AABB primitive.
/// #[intersection]
/// fn sphere(ctx: &mut Intersection, #[params] p: &Params, #[attributes] hit: &mut SphereHit) {
///     let s = ctx.load(p.spheres, ctx.primitive_index());
///     let (o, d) = (ctx.object_ray_origin() - s.truncate(), ctx.object_ray_direction());
///     // |o + t d|² = r²: the nearer root first, then the farther (a ray from inside).
///     let (a, half_b, c) = (d.dot(d), o.dot(d), o.dot(o) - s.w * s.w);
///     let discriminant = half_b * half_b - a * c;
///     if discriminant < 0.0 {
///         return;
///     }
///     for t in [(-half_b - sqrt(discriminant)) / a, (-half_b + sqrt(discriminant)) / a] {
///         if t >= ctx.ray_tmin() && t <= ctx.ray_tmax() {
///             hit.normal = (o + t * d) / s.w;
///             ctx.report_intersection(t, 0);
///             return;
///         }
///     }
/// }
/// assert_eq!(SPHERE.name, "__intersection__sphere");
/// ```
#[proc_macro_attribute]
#[doc(alias("__intersection__", "optixGetAttribute_0"))]
pub fn intersection(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Intersection, attr.into(), item.into())).into()
}

/// Marks a direct callable (`__direct_callable__<name>`): a function in the SBT's
/// callable region that raygen, miss, closest-hit, any-hit and intersection
/// programs call by index (`ctx.call(index, &mut data)`), as OptiX's
/// `optixDirectCall`: materials or lights chosen at run time. It takes
/// `#[callable_data]` (in and out), may take `#[params]` and `#[record]`, and
/// may not trace.
///
/// ```
/// use raykit_device::glam::Vec3;
/// use raykit_device::{closest_hit, direct_callable, ClosestHit, DirectCallable, RayType};
///
/// pub struct Radiance;
/// impl RayType for Radiance { type Payload = Vec3; }
///
/// /// A material's inputs and output.
/// #[derive(Copy, Clone, Default)]
/// pub struct Shading { pub normal: Vec3, pub color: Vec3 }
///
/// /// Material 0: shades by the normal.
/// #[direct_callable]
/// fn normals(_ctx: &mut DirectCallable, #[callable_data] s: &mut Shading) {
///     s.color = 0.5 * (s.normal + Vec3::ONE);
/// }
///
/// /// Calls the material its instance names (the callable's SBT index).
/// #[closest_hit(ray = Radiance)]
/// fn shade(ctx: &mut ClosestHit, #[call_data] s: &mut Shading, #[payload] color: &mut Vec3) {
///     s.normal = -ctx.world_ray_direction();
///     ctx.call(ctx.instance_custom_index(), s);
///     *color = s.color;
/// }
/// assert_eq!(NORMALS.name, "__direct_callable__normals");
/// ```
#[proc_macro_attribute]
#[doc(alias("__direct_callable__"))]
pub fn direct_callable(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::DirectCallable, attr.into(), item.into())).into()
}

/// Marks a continuation callable (`__continuation_callable__<name>`): a callable
/// (called by index like a direct callable, from raygen, miss and closest-hit
/// programs) that may trace rays, with a `#[trace_payload]`; OptiX's
/// `optixContinuationCall`.
///
/// ```
/// use raykit_device::glam::Vec3;
/// use raykit_device::{continuation_callable, ContinuationCallable, LaunchParams, Ray, RayType, Traversable};
///
/// #[repr(C)]
/// #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
/// pub struct Params { pub scene: Traversable }
///
/// /// Shadow rays: 1 when the light is visible.
/// pub struct Shadow;
/// impl RayType for Shadow { type Payload = u32; }
///
/// /// A light's query: from where, and how visible the light is.
/// #[derive(Copy, Clone, Default)]
/// pub struct LightQuery { pub point: Vec3, pub visible: f32 }
///
/// /// A light straight above: traces a shadow ray to it.
/// #[continuation_callable]
/// fn sun(
///     ctx: &mut ContinuationCallable,
///     #[params] p: &Params,
///     #[callable_data] q: &mut LightQuery,
///     #[trace_payload] visible: &mut u32,
/// ) {
///     *visible = 0;
///     ctx.trace::<Shadow>(p.scene, Ray::new(q.point, Vec3::Y).with_interval(1e-3, 1e30), visible);
///     q.visible = *visible as f32;
/// }
/// assert_eq!(SUN.name, "__continuation_callable__sun");
/// ```
#[proc_macro_attribute]
#[doc(alias("__continuation_callable__"))]
pub fn continuation_callable(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::ContinuationCallable, attr.into(), item.into())).into()
}

/// Marks an exception program (`__exception__<name>`), run after a user
/// exception is thrown (`ctx.throw_exception(code)`, see
/// `raykit_device::exception`): it reads `exception_code()` and the launch index,
/// and may take `#[params]` and `#[record]`, to mark the pixel, say. The launch
/// also returns the exceptions to the host as errors.
///
/// ```
/// use raykit_device::{exception, raygen, Buffer, Exception, LaunchParams, Raygen};
///
/// #[repr(C)]
/// #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
/// pub struct Params { pub image: Buffer<u32>, pub limit: u32 }
///
/// /// Throws code 7 past the limit.
/// #[raygen]
/// fn rg(ctx: &mut Raygen, #[params] p: &Params) {
///     let pixel = ctx.launch_linear_index();
///     if pixel >= p.limit {
///         ctx.throw_exception(7);
///         return;
///     }
///     ctx.store(p.image, pixel, 0xff00_ff00);
/// }
///
/// /// Marks the pixel of an invocation that threw with its code.
/// #[exception]
/// fn on_exception(ctx: &mut Exception, #[params] p: &Params) {
///     let pixel = ctx.launch_linear_index();
///     ctx.store(p.image, pixel, 0xe000_0000 | ctx.exception_code());
/// }
/// assert_eq!(ON_EXCEPTION.name, "__exception__on_exception");
/// ```
#[proc_macro_attribute]
#[doc(alias("__exception__"))]
pub fn exception(attr: TokenStream, item: TokenStream) -> TokenStream {
    root::resolve(program::expand(ProgramPrefix::Exception, attr.into(), item.into())).into()
}

/// Records the layout of a launch-params struct (`#[repr(C)]`, `Copy`,
/// `bytemuck::Pod`) so the host can check it against the SPIR-V. Fields that
/// cannot cross to the device (references, pointers, `bool`, `usize`) are
/// compile errors.
#[proc_macro_derive(LaunchParams)]
pub fn derive_launch_params(item: TokenStream) -> TokenStream {
    root::resolve(launch_params::derive(item.into())).into()
}

/// Records the layout of an SBT record data struct (`#[repr(C)]`, `Copy`, every
/// field a device type, no padding) and makes it `raykit_device::SbtRecordData`:
/// every launch then checks the `Buffer<T>` and `Traversable` fields of records of
/// this type against the context's live objects. Derive it *instead of*
/// `bytemuck::Pod` (every `Pod` type is record data already, unchecked).
#[proc_macro_derive(SbtRecordData)]
pub fn derive_sbt_record_data(item: TokenStream) -> TokenStream {
    root::resolve(launch_params::derive_record(item.into())).into()
}

/// Makes a `#[repr(C)]` struct of buffer elements a `raykit_device::Element`, so a
/// `Buffer<T>` (and the host's `DeviceBuffer<T>`) can hold it: its fields follow
/// each other word by word, in declaration order. The compiler's layout is checked
/// against that at compile time on every target, naming the field; in a device
/// crate the SPIR-V also records the device's layout, which the host compares
/// with its own (see `raykit_device::element`). Fields are `u32`, `i32`, `f32`,
/// `u64`, `i64`, glam's 4-byte-aligned vectors, `Buffer<T>`, or other elements.
/// `#[element(skip_layout_test)]` keeps the SPIR-V's record but generates no
/// build-time test (for structs that differ between host and device on purpose,
/// which `raykit::Module::check_element` then refuses).
#[proc_macro_derive(Element, attributes(element))]
pub fn derive_element(item: TokenStream) -> TokenStream {
    root::resolve(element::derive(item.into())).into()
}
