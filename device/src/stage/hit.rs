//! What the three hit stages (closest-hit, any-hit, intersection) share: the
//! built-ins describing the ray and the candidate or committed hit.

use spirv_std::glam::{UVec3, Vec3};
use spirv_std::matrix::Matrix4x3;

/// `HitKindFrontFacingTriangleKHR`: the hit kind of a triangle hit from its front.
pub const HIT_KIND_FRONT_FACING_TRIANGLE: u32 = 0xFE;
/// `HitKindBackFacingTriangleKHR`: the hit kind of a triangle hit from its back.
pub const HIT_KIND_BACK_FACING_TRIANGLE: u32 = 0xFF;

/// The built-ins of a hit stage, read by the generated entry point.
#[doc(hidden)]
#[derive(Copy, Clone)]
pub struct HitBuiltins {
    pub launch_index: UVec3,
    pub launch_dimensions: UVec3,
    pub world_ray_origin: Vec3,
    pub world_ray_direction: Vec3,
    pub object_ray_origin: Vec3,
    pub object_ray_direction: Vec3,
    pub ray_tmin: f32,
    pub ray_tmax: f32,
    pub ray_flags: u32,
    /// 0 in intersection programs, where Vulkan has no hit kind yet.
    pub hit_kind: u32,
    pub primitive_index: u32,
    pub instance_id: u32,
    pub instance_custom_index: u32,
    pub geometry_index: u32,
    pub object_to_world: Matrix4x3,
    pub world_to_object: Matrix4x3,
}

/// The hit built-ins as a hit stage's context holds them: by value on the GPU
/// (read from the built-in variables at entry), borrowed from the invocation
/// on the CPU (not copied for each program call).
#[doc(hidden)]
#[cfg(target_arch = "spirv")]
pub type HitRef<'a> = HitBuiltins;
/// The hit built-ins as a hit stage's context holds them: by value on the GPU
/// (read from the built-in variables at entry), borrowed from the invocation
/// on the CPU (not copied for each program call).
#[doc(hidden)]
#[cfg(not(target_arch = "spirv"))]
pub type HitRef<'a> = &'a HitBuiltins;

impl HitBuiltins {
    /// All zeros: the built-ins of a stage that has no hit.
    pub const ZERO: HitBuiltins = HitBuiltins {
        launch_index: UVec3::ZERO,
        launch_dimensions: UVec3::ZERO,
        world_ray_origin: Vec3::ZERO,
        world_ray_direction: Vec3::ZERO,
        object_ray_origin: Vec3::ZERO,
        object_ray_direction: Vec3::ZERO,
        ray_tmin: 0.0,
        ray_tmax: 0.0,
        ray_flags: 0,
        hit_kind: 0,
        primitive_index: 0,
        instance_id: 0,
        instance_custom_index: 0,
        geometry_index: 0,
        object_to_world: Matrix4x3 { x_axis: Vec3::ZERO, y_axis: Vec3::ZERO, z_axis: Vec3::ZERO, w_axis: Vec3::ZERO },
        world_to_object: Matrix4x3 { x_axis: Vec3::ZERO, y_axis: Vec3::ZERO, z_axis: Vec3::ZERO, w_axis: Vec3::ZERO },
    };
}

/// The accessors every hit stage has, documented with OptiX's names.
macro_rules! hit_accessors {
    () => {
        /// This invocation's index in the launch grid (`optixGetLaunchIndex`).
        #[doc(alias("optixGetLaunchIndex", "gl_LaunchIDEXT"))]
        pub fn launch_index(&self) -> spirv_std::glam::UVec3 {
            self.hit.launch_index
        }

        /// The launch grid's size (`optixGetLaunchDimensions`).
        #[doc(alias("optixGetLaunchDimensions", "gl_LaunchSizeEXT"))]
        pub fn launch_dimensions(&self) -> spirv_std::glam::UVec3 {
            self.hit.launch_dimensions
        }

        /// The ray's origin in world space (`optixGetWorldRayOrigin`).
        #[doc(alias("optixGetWorldRayOrigin", "gl_WorldRayOriginEXT"))]
        pub fn world_ray_origin(&self) -> spirv_std::glam::Vec3 {
            self.hit.world_ray_origin
        }

        /// The ray's direction in world space (`optixGetWorldRayDirection`).
        #[doc(alias("optixGetWorldRayDirection", "gl_WorldRayDirectionEXT"))]
        pub fn world_ray_direction(&self) -> spirv_std::glam::Vec3 {
            self.hit.world_ray_direction
        }

        /// The ray's origin in the object space of the instance hit (`optixGetObjectRayOrigin`).
        #[doc(alias("optixGetObjectRayOrigin", "gl_ObjectRayOriginEXT"))]
        pub fn object_ray_origin(&self) -> spirv_std::glam::Vec3 {
            self.hit.object_ray_origin
        }

        /// The ray's direction in object space (`optixGetObjectRayDirection`).
        #[doc(alias("optixGetObjectRayDirection", "gl_ObjectRayDirectionEXT"))]
        pub fn object_ray_direction(&self) -> spirv_std::glam::Vec3 {
            self.hit.object_ray_direction
        }

        /// The ray's `t_min` (`optixGetRayTmin`).
        #[doc(alias("optixGetRayTmin", "gl_RayTminEXT"))]
        pub fn ray_tmin(&self) -> f32 {
            self.hit.ray_tmin
        }

        /// The ray's current `t_max`: the distance of the closest hit so far, or of
        /// this hit in closest-hit and any-hit programs (`optixGetRayTmax`).
        #[doc(alias("optixGetRayTmax", "gl_RayTmaxEXT"))]
        pub fn ray_tmax(&self) -> f32 {
            self.hit.ray_tmax
        }

        /// The flags the ray was traced with (`optixGetRayFlags`).
        #[doc(alias("optixGetRayFlags", "gl_IncomingRayFlagsEXT"))]
        pub fn ray_flags(&self) -> u32 {
            self.hit.ray_flags
        }

        /// Index of the primitive in its geometry (`optixGetPrimitiveIndex`).
        #[doc(alias("optixGetPrimitiveIndex", "gl_PrimitiveID"))]
        pub fn primitive_index(&self) -> u32 {
            self.hit.primitive_index
        }

        /// Index of the instance in the IAS (`optixGetInstanceIndex`).
        #[doc(alias("optixGetInstanceIndex", "gl_InstanceID"))]
        pub fn instance_index(&self) -> u32 {
            self.hit.instance_id
        }

        /// The instance's user-given custom index (`optixGetInstanceId`).
        #[doc(alias("optixGetInstanceId", "gl_InstanceCustomIndexEXT"))]
        pub fn instance_custom_index(&self) -> u32 {
            self.hit.instance_custom_index
        }

        /// Index of the geometry in its GAS (`optixGetSbtGASIndex`).
        #[doc(alias("optixGetSbtGASIndex", "gl_GeometryIndexEXT"))]
        pub fn geometry_index(&self) -> u32 {
            self.hit.geometry_index
        }

        /// The instance's object-to-world transform (`optixGetObjectToWorldTransformMatrix`).
        #[doc(alias("optixGetObjectToWorldTransformMatrix", "optixGetTransformListHandle", "gl_ObjectToWorldEXT"))]
        pub fn object_to_world(&self) -> spirv_std::matrix::Matrix4x3 {
            self.hit.object_to_world
        }

        /// The instance's world-to-object transform (`optixGetWorldToObjectTransformMatrix`).
        #[doc(alias("optixGetWorldToObjectTransformMatrix", "optixGetTransformListHandle", "gl_WorldToObjectEXT"))]
        pub fn world_to_object(&self) -> spirv_std::matrix::Matrix4x3 {
            self.hit.world_to_object
        }

        /// Reads element `index` of `buffer`.
        pub fn load<T: $crate::Element>(&self, buffer: $crate::Buffer<T>, index: u32) -> T {
            super::load(self.device, buffer, index)
        }

        /// Writes element `index` of `buffer`.
        pub fn store<T: $crate::Element>(&mut self, buffer: $crate::Buffer<T>, index: u32, value: T) {
            super::store(self.device, buffer, index, value)
        }
    };
}
pub(crate) use hit_accessors;

/// Accessors of the hit kind, for the stages that have one (closest-hit, any-hit).
macro_rules! hit_kind_accessors {
    () => {
        /// The hit kind: `0..=127` as reported by an intersection program, or
        /// [`HIT_KIND_FRONT_FACING_TRIANGLE`](crate::stage::HIT_KIND_FRONT_FACING_TRIANGLE) /
        /// [`HIT_KIND_BACK_FACING_TRIANGLE`](crate::stage::HIT_KIND_BACK_FACING_TRIANGLE)
        /// (`optixGetHitKind`).
        #[doc(alias("optixGetHitKind", "gl_HitKindEXT"))]
        pub fn hit_kind(&self) -> u32 {
            self.hit.hit_kind
        }

        /// Whether a triangle was hit from its front face (`optixIsFrontFaceHit`).
        #[doc(alias("optixIsFrontFaceHit"))]
        pub fn is_front_face_hit(&self) -> bool {
            self.hit.hit_kind == crate::stage::HIT_KIND_FRONT_FACING_TRIANGLE
        }
    };
}
pub(crate) use hit_kind_accessors;
