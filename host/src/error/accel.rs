//! Errors of acceleration-structure builds: GAS inputs, instances, updates and compaction.

/// Errors of acceleration-structure builds.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AccelError {
    /// A build has nothing to build: no geometry, no primitives, no instances.
    #[error("acceleration structure build: {what}; give at least one triangle, AABB or instance, or leave the empty part out")]
    Empty {
        /// What is empty.
        what: String,
    },

    /// A count is over one of the device's acceleration-structure limits.
    #[error("{count} {what} exceed this device's {limit_name} ({limit}); split the input into several GASes and instance them in an IAS")]
    Limit {
        /// What was counted.
        what: &'static str,
        /// How many there are.
        count: u64,
        /// The limit.
        limit: u64,
        /// The limit's Vulkan name.
        limit_name: &'static str,
    },

    /// A triangle index names a vertex that does not exist.
    #[error("geometry {geometry}: index {position} is {index}, but the geometry has {vertex_count} vertices (valid indices are 0..{vertex_count}); fix the index buffer or pass all the vertices")]
    IndexOutOfRange {
        /// Geometry (build input) number.
        geometry: usize,
        /// Position of the index in the index buffer.
        position: usize,
        /// Its value.
        index: u32,
        /// Number of vertices given.
        vertex_count: u64,
    },

    /// An index or vertex count that is not three per triangle.
    #[error("geometry {geometry}: {count} {what} is not a multiple of 3; each triangle takes three")]
    TriangleCount {
        /// Geometry number.
        geometry: usize,
        /// `indices` or `vertices without indices`.
        what: &'static str,
        /// The count.
        count: usize,
    },

    /// A vertex or AABB stride Vulkan does not accept.
    #[error("geometry {geometry}: {what} stride of {stride} bytes must be a multiple of {alignment} and at least {min} (one element); pad the struct or give the element's real stride")]
    MisalignedStride {
        /// Geometry number.
        geometry: usize,
        /// `vertex` or `AABB`.
        what: &'static str,
        /// The stride given.
        stride: u64,
        /// Required alignment (the component size).
        alignment: u64,
        /// Smallest stride (one element).
        min: u64,
    },

    /// The bytes given are fewer than count × stride needs.
    #[error("geometry {geometry}: {what} data of {len} bytes is too short: the count and stride need {needed}; give more data or a smaller count")]
    InputTooShort {
        /// Geometry number.
        geometry: usize,
        /// `vertex` or `AABB`.
        what: &'static str,
        /// Bytes needed.
        needed: u64,
        /// Bytes given.
        len: u64,
    },

    /// A vertex position is NaN or infinite.
    #[error("geometry {geometry}: vertex {vertex} is not finite: {position:?}; acceleration structures need finite positions")]
    NonFiniteVertex {
        /// Geometry number.
        geometry: usize,
        /// Vertex number.
        vertex: usize,
        /// Its position.
        position: [f32; 3],
    },

    /// A box is not finite or has min > max.
    #[error("geometry {geometry}: AABB {primitive} (min {min:?}, max {max:?}) is invalid: {reason}")]
    InvalidAabb {
        /// Geometry number.
        geometry: usize,
        /// Box number.
        primitive: usize,
        /// Minimum corner.
        min: [f32; 3],
        /// Maximum corner.
        max: [f32; 3],
        /// What is wrong.
        reason: &'static str,
    },

    /// Built-in spheres given a different number of centres and radii.
    #[error("built-in spheres: {centres} centres but {radii} radii; give one radius per centre")]
    SphereCount {
        /// Number of centres.
        centres: usize,
        /// Number of radii.
        radii: usize,
    },

    /// Moving spheres given a different number of start and end centres.
    #[error("moving spheres: {start} start centres but {end} end centres; give one end centre per start centre")]
    MovingSphereCount {
        /// Number of start centres.
        start: usize,
        /// Number of end centres.
        end: usize,
    },

    /// A built-in sphere whose centre is not finite or whose radius is not a
    /// finite number ≥ 0.
    #[error("built-in sphere {sphere} (centre {centre:?}, radius {radius}) is invalid: {reason}")]
    InvalidSphere {
        /// Sphere number.
        sphere: usize,
        /// Its centre.
        centre: [f32; 3],
        /// Its radius.
        radius: f32,
        /// What is wrong, and the fix.
        reason: &'static str,
    },

    /// A mesh attribute (normals, uvs) with another count than the positions,
    /// or a normal that is not finite.
    #[error("mesh {attribute}: {reason}")]
    MeshAttribute {
        /// `"normals"` or `"uvs"`.
        attribute: &'static str,
        /// What is wrong, and the fix.
        reason: String,
    },

    /// A geometry or instance transform is NaN or infinite.
    #[error("{what} is not finite; give a finite affine transform")]
    NonFiniteTransform {
        /// Which transform.
        what: String,
    },

    /// An instance field is over its bit width.
    #[error("instance {instance}: {field} is {value}, over its 24-bit maximum {max}")]
    InstanceField {
        /// Instance number.
        instance: usize,
        /// The field.
        field: &'static str,
        /// Its value.
        value: u32,
        /// Its maximum.
        max: u32,
    },

    /// Triangles and AABBs mixed in one GAS.
    #[error("a GAS holds either triangles or AABBs: geometry {first} and geometry {other} differ; build one GAS of each and instance both in an IAS")]
    MixedGeometryTypes {
        /// The first geometry.
        first: usize,
        /// The first geometry of the other kind.
        other: usize,
    },

    /// A refit (update) that Vulkan does not allow.
    #[error("cannot update (refit) this {what}: {reason}; use rebuild instead, or build with BuildOptions::allow_update and keep the topology")]
    UpdateRefused {
        /// `GAS` or `IAS`.
        what: &'static str,
        /// Why not.
        reason: String,
    },

    /// Compaction of a GAS built without allowing it.
    #[error(
        "this GAS was built without BuildOptions::allow_compaction; build it with allow_compaction(true) to compact it"
    )]
    CompactionNotAllowed,
}
