//! Triangle meshes with per-vertex attributes: what [`crate::Gas::mesh`] builds
//! and keeps in device memory for `raykit_device::triangle::surface`, and the
//! built-in shapes made of them (quads, boxes).

use glam::{Vec2, Vec3};

/// A triangle mesh: positions, three indices per triangle and, optionally, unit
/// normals and texture coordinates per vertex (one per position).
///
/// ```
/// use raykit::glam::Vec3;
/// use raykit::Mesh;
/// // A unit quad in the xy plane facing +z, and a box: two triangles and twelve.
/// let quad = Mesh::quad(Vec3::ZERO, Vec3::X, Vec3::Y);
/// let cube = Mesh::cuboid(Vec3::splat(-0.5), Vec3::splat(0.5));
/// assert_eq!((quad.triangle_count(), cube.triangle_count()), (2, 12));
/// let mut both = quad.clone();
/// both.append(&cube);
/// assert_eq!(both.triangle_count(), 14);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions (object space).
    pub positions: Vec<Vec3>,
    /// Three indices into `positions` per triangle; counter-clockwise seen from
    /// the side the geometric normal points to (the front face).
    pub indices: Vec<u32>,
    /// Unit normals per vertex (shading normals), if any.
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinates per vertex, if any.
    pub uvs: Option<Vec<Vec2>>,
}

impl Mesh {
    /// A mesh of `positions` and `indices` (three per triangle), without normals or uvs.
    pub fn new(positions: Vec<Vec3>, indices: Vec<u32>) -> Mesh {
        Mesh { positions, indices, normals: None, uvs: None }
    }

    /// The same mesh with per-vertex `normals`.
    pub fn with_normals(self, normals: Vec<Vec3>) -> Mesh {
        Mesh { normals: Some(normals), ..self }
    }

    /// The same mesh with per-vertex texture coordinates.
    pub fn with_uvs(self, uvs: Vec<Vec2>) -> Mesh {
        Mesh { uvs: Some(uvs), ..self }
    }

    /// Triangles in the mesh.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// The parallelogram `corner + s·u + t·v` for `s, t ∈ [0, 1]` (*Ray Tracing:
    /// The Next Week*'s quad): two triangles facing `u × v`, flat normals, and
    /// uv `(s, t)`.
    pub fn quad(corner: Vec3, u: Vec3, v: Vec3) -> Mesh {
        let normal = u.cross(v).normalize_or_zero();
        Mesh {
            positions: vec![corner, corner + u, corner + u + v, corner + v],
            indices: vec![0, 1, 2, 0, 2, 3],
            normals: Some(vec![normal; 4]),
            uvs: Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y]),
        }
    }

    /// The axis-aligned box between the corners `a` and `b` (either order; *The
    /// Next Week*'s `box`): six quads facing out, each with its own flat normals
    /// and uvs over `[0, 1]²`. Rotate and move it with an instance transform.
    pub fn cuboid(a: Vec3, b: Vec3) -> Mesh {
        let (min, max) = (a.min(b), a.max(b));
        let d = max - min;
        let (dx, dy, dz) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
        let faces = [
            Mesh::quad(Vec3::new(min.x, min.y, max.z), dx, dy),  // front (+z)
            Mesh::quad(Vec3::new(max.x, min.y, max.z), -dz, dy), // right (+x)
            Mesh::quad(Vec3::new(max.x, min.y, min.z), -dx, dy), // back (−z)
            Mesh::quad(Vec3::new(min.x, min.y, min.z), dz, dy),  // left (−x)
            Mesh::quad(Vec3::new(min.x, max.y, max.z), dx, -dz), // top (+y)
            Mesh::quad(Vec3::new(min.x, min.y, min.z), dx, dz),  // bottom (−y)
        ];
        let mut mesh = Mesh::default();
        for face in &faces {
            mesh.append(face);
        }
        mesh
    }

    /// Appends `other`'s triangles (its indices shifted past this mesh's
    /// vertices). The result has normals (or uvs) only if both meshes have them,
    /// or this one is empty and `other` has them.
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        let was_empty = self.positions.is_empty();
        merge_attribute(&mut self.normals, &other.normals, was_empty);
        merge_attribute(&mut self.uvs, &other.uvs, was_empty);
        self.positions.extend_from_slice(&other.positions);
        self.indices.extend(other.indices.iter().map(|i| i + base));
    }
}

/// [`Mesh::append`] for one attribute: `mine` followed by `theirs` when both
/// meshes have it (or `mine` belongs to an empty mesh), else none.
fn merge_attribute<T: Clone>(mine: &mut Option<Vec<T>>, theirs: &Option<Vec<T>>, mine_empty: bool) {
    if let (Some(mine), Some(theirs)) = (mine.as_mut(), theirs) {
        mine.extend_from_slice(theirs);
        return;
    }
    *mine = if mine_empty { theirs.clone() } else { None };
}
