//! Triangle surface hits: what a closest-hit program shades and where the next
//! ray starts, as [`crate::sphere`] gives for spheres.
//!
//! `raykit::Gas::mesh(ctx, &mesh)` builds a GAS over a `raykit::Mesh` (positions,
//! indices, and optionally per-vertex normals and texture coordinates; quads and
//! boxes are meshes too) and keeps the mesh in device memory; `gas.mesh_data()`
//! is its [`MeshData`], a plain struct of buffer handles for the hit group's
//! record or the launch params. One call in closest-hit gives the whole hit:
//!
//! ```
//! use raykit_device::glam::Vec3;
//! use raykit_device::triangle::{self, MeshData};
//! use raykit_device::{closest_hit, ClosestHit, RayType, SbtRecordData};
//!
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Zeroable, SbtRecordData)]
//! pub struct Material { pub mesh: MeshData, pub albedo: Vec3 } // the hit group's record
//!
//! pub struct Radiance;
//! impl RayType for Radiance { type Payload = Vec3; }
//!
//! #[closest_hit(ray = Radiance)]
//! fn shade(ctx: &mut ClosestHit, #[record] m: &Material, #[payload] c: &mut Vec3) {
//!     let hit = triangle::surface(ctx, &m.mesh); // world-space point, normals, uv, face
//!     *c = m.albedo * hit.facing_normal().dot(-ctx.world_ray_direction().normalize()).max(0.0);
//!     // A bounce ray starts at `hit.spawn_origin(direction)` with t_min = 0.
//! }
//! ```
//!
//! # The spawn origin and its error bound
//! The hit point is interpolated from the triangle's vertices with the hit's
//! barycentrics (`b₀ p₀ + b₁ p₁ + b₂ p₂`, `b₀ = 1 − b₁ − b₂`) in object space and
//! then transformed to world space, each step in `f32`. Its error is bounded per
//! axis as pbrt-v4 does (*Physically Based Rendering*, 4th ed., §6.8): the
//! interpolation by `γ₇ (|b₀ p₀| + |b₁ p₁| + |b₂ p₂|)` and the transform `M` by
//! `(1 + γ₃)(|M| e) + γ₃ (|M| |p| + |t|)`, with `γₙ = n u / (1 − n u)` and `u = 2⁻²⁴`.
//! [`TriangleSurface::spawn_origin`] moves the point along the geometric normal,
//! to the side the new ray goes, by the bound's extent along the normal
//! (`|n| · e`), and then one `f32` further away on each axis it moved: the origin
//! lies strictly on the ray's side of the triangle's plane, so a ray from it with
//! `t_min = 0` cannot hit the triangle again, however far from the world's origin
//! the mesh lies. No constant epsilon is involved: at 10⁵ the offset is a few
//! ulps of 10⁵, at 1 a few ulps of 1.

use spirv_std::glam::{Vec2, Vec3};

use crate::sampling::{transform_normal_to_world, transform_point};
use crate::sphere::SurfaceHit;
use crate::{Buffer, ClosestHit, Matrix4x3};

/// [`MeshData::attributes`] bit: the mesh has per-vertex normals.
pub const HAS_NORMALS: u32 = 1;
/// [`MeshData::attributes`] bit: the mesh has per-vertex texture coordinates.
pub const HAS_UVS: u32 = 2;

/// A triangle mesh in device memory, as `raykit::Gas::mesh` keeps it
/// (`gas.mesh_data()`): triangle `i` (the primitive index) has the vertices
/// `indices[3i..3i + 3]`.
#[repr(C)]
#[derive(Copy, Clone, Debug, PartialEq, Eq, bytemuck::Pod, bytemuck::Zeroable, crate::LaunchParams)]
pub struct MeshData {
    /// Object-space vertex positions, as the GAS was built from.
    pub positions: Buffer<Vec3>,
    /// Three vertex indices per triangle.
    pub indices: Buffer<u32>,
    /// Object-space unit normals per vertex (the null handle without [`HAS_NORMALS`]).
    pub normals: Buffer<Vec3>,
    /// Texture coordinates per vertex (the null handle without [`HAS_UVS`]).
    pub uvs: Buffer<Vec2>,
    /// [`HAS_NORMALS`] and [`HAS_UVS`] bits.
    pub attributes: u32,
}

/// One triangle's vertices and attributes, in object space.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TriangleVertices {
    /// Positions.
    pub positions: [Vec3; 3],
    /// Unit normals per vertex, when the mesh has them.
    pub normals: Option<[Vec3; 3]>,
    /// Texture coordinates per vertex, when the mesh has them.
    pub uvs: Option<[Vec2; 3]>,
}

impl MeshData {
    /// Triangle `primitive`'s vertices, read with `load` (a stage's `ctx.load`).
    pub fn triangle(
        &self,
        primitive: u32,
        load_index: impl Fn(Buffer<u32>, u32) -> u32,
        load_vec3: impl Fn(Buffer<Vec3>, u32) -> Vec3,
        load_vec2: impl Fn(Buffer<Vec2>, u32) -> Vec2,
    ) -> TriangleVertices {
        let i = [
            load_index(self.indices, 3 * primitive),
            load_index(self.indices, 3 * primitive + 1),
            load_index(self.indices, 3 * primitive + 2),
        ];
        let positions =
            [load_vec3(self.positions, i[0]), load_vec3(self.positions, i[1]), load_vec3(self.positions, i[2])];
        let normals = (self.attributes & HAS_NORMALS != 0)
            .then(|| [load_vec3(self.normals, i[0]), load_vec3(self.normals, i[1]), load_vec3(self.normals, i[2])]);
        let uvs = (self.attributes & HAS_UVS != 0)
            .then(|| [load_vec2(self.uvs, i[0]), load_vec2(self.uvs, i[1]), load_vec2(self.uvs, i[2])]);
        TriangleVertices { positions, normals, uvs }
    }
}

/// A triangle hit in world space, for shading and spawning rays.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct TriangleSurface {
    /// The hit point, in world space.
    pub position: Vec3,
    /// Per axis, a bound on `position`'s distance from the exact hit point on the
    /// triangle (world space).
    pub error: Vec3,
    /// The unit geometric normal, `(p₁ − p₀) × (p₂ − p₀)` in world space (not
    /// flipped towards the ray).
    pub geometric_normal: Vec3,
    /// The unit shading normal: the mesh's vertex normals interpolated (world
    /// space, on the geometric normal's side), or the geometric normal.
    pub shading_normal: Vec3,
    /// Texture coordinates interpolated from the mesh's, or the barycentrics
    /// `(b₁, b₂)` when it has none.
    pub uv: Vec2,
    /// Whether the ray came from the side the geometric normal points to.
    pub front_face: bool,
}

/// 2⁻²⁴, the unit roundoff of `f32`.
const UNIT_ROUNDOFF: f32 = 1.0 / 16_777_216.0;

/// pbrt's `γₙ`: a bound on the relative error of `n` roundings.
fn gamma(n: f32) -> f32 {
    n * UNIT_ROUNDOFF / (1.0 - n * UNIT_ROUNDOFF)
}

impl TriangleSurface {
    /// The hit on `triangle` at barycentrics `(b₁, b₂)` (closest-hit's
    /// `ctx.barycentrics()`), seen along `ray_direction` (world space), through
    /// the instance's transforms.
    pub fn new(
        triangle: &TriangleVertices,
        barycentrics: Vec2,
        object_to_world: &Matrix4x3,
        world_to_object: &Matrix4x3,
        ray_direction: Vec3,
    ) -> TriangleSurface {
        let [p0, p1, p2] = triangle.positions;
        let (b1, b2) = (barycentrics.x, barycentrics.y);
        let b0 = 1.0 - b1 - b2;
        let point = p0 * b0 + p1 * b1 + p2 * b2;
        let object_error = ((p0 * b0).abs() + (p1 * b1).abs() + (p2 * b2).abs()) * gamma(7.0);
        let position = transform_point(object_to_world, point);
        let error = transformed_error(object_to_world, point, object_error);
        let geometric_normal = transform_normal_to_world(world_to_object, (p1 - p0).cross(p2 - p0));
        let shading_normal = match triangle.normals {
            Some([n0, n1, n2]) => {
                let n = transform_normal_to_world(world_to_object, n0 * b0 + n1 * b1 + n2 * b2);
                let n = if n.is_finite() { n } else { geometric_normal };
                if n.dot(geometric_normal) < 0.0 {
                    -n
                } else {
                    n
                }
            }
            None => geometric_normal,
        };
        let uv = match triangle.uvs {
            Some([t0, t1, t2]) => t0 * b0 + t1 * b1 + t2 * b2,
            None => barycentrics,
        };
        let front_face = ray_direction.dot(geometric_normal) < 0.0;
        TriangleSurface { position, error, geometric_normal, shading_normal, uv, front_face }
    }

    /// The shading normal on the side the ray came from, as Lambertian and
    /// dielectric materials use it.
    pub fn facing_normal(&self) -> Vec3 {
        if self.front_face {
            self.shading_normal
        } else {
            -self.shading_normal
        }
    }

    /// The geometric normal on the side the ray came from.
    pub fn facing_geometric_normal(&self) -> Vec3 {
        if self.front_face {
            self.geometric_normal
        } else {
            -self.geometric_normal
        }
    }

    /// The hit as [`crate::scatter`]'s materials and
    /// [`Bounce::scatter_from`](crate::bounce::Bounce::scatter_from) take it: the
    /// position, the geometric normal and face, and the error bound's extent
    /// along that normal ([`TriangleSurface::plane_error`]), so that its
    /// `spawn_origin` starts past the triangle's plane. (The shading normal
    /// stays here, for a shader's own use.)
    pub fn surface_hit(&self) -> SurfaceHit {
        SurfaceHit {
            position: self.position,
            normal: self.geometric_normal,
            front_face: self.front_face,
            error: self.plane_error(),
        }
    }

    /// The error bound's extent along the geometric normal: how far the point
    /// may lie from the triangle's plane.
    pub fn plane_error(&self) -> f32 {
        self.geometric_normal.abs().dot(self.error)
    }

    /// The origin of a ray leaving the surface along `direction` (either side):
    /// the point moved along the geometric normal, to the side `direction` goes,
    /// past its error bound (see the [module docs](self)). Trace from it with `t_min = 0`.
    pub fn spawn_origin(&self, direction: Vec3) -> Vec3 {
        let n = self.geometric_normal;
        let mut offset = n * self.plane_error();
        if direction.dot(n) < 0.0 {
            offset = -offset;
        }
        let p = self.position + offset;
        Vec3::new(away(p.x, offset.x), away(p.y, offset.y), away(p.z, offset.z))
    }
}

/// `x` moved one `f32` further in the direction of `offset`'s sign (unchanged for 0).
fn away(x: f32, offset: f32) -> f32 {
    if offset > 0.0 {
        next_up(x)
    } else if offset < 0.0 {
        -next_up(-x)
    } else {
        x
    }
}

/// The next `f32` above a finite `x`.
fn next_up(x: f32) -> f32 {
    if x == 0.0 {
        return f32::from_bits(1);
    }
    let bits = x.to_bits();
    f32::from_bits(if x > 0.0 { bits + 1 } else { bits - 1 })
}

/// The error of `m · p` (a point with per-axis error `e`), per axis: the
/// transform's own rounding (three products and three sums) and the input's.
fn transformed_error(m: &Matrix4x3, p: Vec3, e: Vec3) -> Vec3 {
    let (x, y, z, t) = (m.x_axis.abs(), m.y_axis.abs(), m.z_axis.abs(), m.w_axis.abs());
    let input = x * e.x + y * e.y + z * e.z;
    let rounding = x * p.x.abs() + y * p.y.abs() + z * p.z.abs() + t;
    input * (1.0 + gamma(3.0)) + rounding * gamma(3.0)
}

/// The closest-hit's triangle hit on `mesh` (its record's or params'
/// [`MeshData`]): the primitive's vertices, the hit's barycentrics, the
/// instance's transforms and the ray's direction.
pub fn surface(ctx: &ClosestHit, mesh: &MeshData) -> TriangleSurface {
    let triangle =
        mesh.triangle(ctx.primitive_index(), |b, i| ctx.load(b, i), |b, i| ctx.load(b, i), |b, i| ctx.load(b, i));
    TriangleSurface::new(
        &triangle,
        ctx.barycentrics(),
        &ctx.object_to_world(),
        &ctx.world_to_object(),
        ctx.world_ray_direction(),
    )
}
