// raykit's WGSL prelude: the declarations raykit expects from WGSL device
// programs. Copy what you need to the top of your .wgsl file (WGSL has no
// #include). Each declaration is explained in raykit-wgsl's crate docs.

// Ray-tracing stages (@ray_generation, @miss, @closest_hit, @any_hit), traceRay,
// and the ray_payload / incoming_ray_payload address spaces.
enable wgpu_ray_tracing_pipeline;
enable wgpu_binding_array;

// Built-ins of the ray-tracing stages (as entry-point arguments):
// ray_invocation_id, num_ray_invocations (launch index and size), world_ray_origin,
// world_ray_direction, object_ray_origin, object_ray_direction, ray_t_min,
// ray_t_current_max, object_to_world, world_to_object, hit_kind, geometry_index,
// instance_custom_data; primitive_index needs `enable primitive_index;`.

// ---- Buffers: the bindless table ------------------------------------------
// Every `Buffer<T>` handle in params or a record is an index into this table
// (descriptor set 0, binding 0). Read element i of a Buffer<u32> `b` with
// `buffers[b & 4095u].words[i]` (a handle is the table slot in its low 12 bits and
// a generation the host checks above them); for f32 use bitcast<f32>(…), for
// vectors several words.
struct Words { words: array<u32> }
@group(0) @binding(0) var<storage, read_write> buffers: binding_array<Words>;

// ---- Launch params ---------------------------------------------------------
// One struct, declared `var<immediate>` (Vulkan push constants) when the host
// struct is at most 128 bytes, else `var<storage, read>` at @group(1) @binding(0),
// which raykit turns into the uniform buffer it binds there (a `var<uniform>`
// would follow WGSL's uniform layout, which pads struct members to 16 bytes).
// raykit checks its layout against the host's #[derive(LaunchParams)] struct
// when the pipeline is linked. Field by field:
//   u32, i32, f32                           as in WGSL;
//   glam UVec2 / Vec2 (8 bytes, 4-aligned)  Vec2u / Vec2f below (WGSL's vec2 is 8-aligned;
//                                           vec2<u32> matches only at an 8-aligned offset);
//   glam Vec3 (12 bytes, 4-aligned)         Vec3f below (WGSL's vec3<f32> is 16-aligned);
//   glam Vec4 (16 bytes, 16-aligned)        vec4<f32>;
//   Buffer<T> (a u32 table index)           u32;
//   Traversable (a 64-bit device address)   vec2<u32> (8-aligned on both sides).
// A field declared otherwise is refused when the pipeline is linked, naming it.
struct Vec2u { x: u32, y: u32 }
struct Vec2f { x: f32, y: f32 }
struct Vec3f { x: f32, y: f32, z: f32 }
fn vec3f(v: Vec3f) -> vec3<f32> { return vec3<f32>(v.x, v.y, v.z); }

// struct Params { image: u32, size: Vec2u, eye: Vec3f, …, handle: vec2<u32> }
// var<immediate> params: Params;

// ---- The scene -------------------------------------------------------------
// WGSL cannot turn a 64-bit address into an acceleration structure; raykit does.
// An `acceleration_structure` at @group(2) @binding(K) stands for member K
// (counting from 0) of the params struct, a Traversable (vec2<u32>): every use
// reads that member and converts it (OpConvertUToAccelerationStructureKHR).
// @group(2) @binding(7) var scene: acceleration_structure;   // params member 7

// ---- Shader records and hit attributes -------------------------------------
// WGSL has no address space for these; raykit maps two storage bindings:
//   @group(3) @binding(0) var<storage, read> record: T;      -> the program's SBT record data (SbtRecord<T>)
//   @group(3) @binding(1) var<storage, read> attributes: A;  -> hit attributes (closest-hit / any-hit),
//                                                               vec2<f32> barycentrics for triangles
// @group(3) @binding(0) var<storage, read> record: MissData;
// @group(3) @binding(1) var<storage, read> barycentrics: vec2<f32>;

// ---- Ray types -------------------------------------------------------------
// naga's traceRay has no SBT offset, SBT stride or miss index. raykit reads them
// from the high bytes of RayDesc's cull mask: bits 0-7 are the cull mask,
// 8-15 the SBT offset, 16-23 the SBT stride, 24-31 the miss index. A plain
// mask (0xff) traces with offset 0, stride 0, miss 0.
fn ray_type_mask(cull_mask: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32) -> u32 {
    return (cull_mask & 0xffu) | ((sbt_offset & 0xffu) << 8u) | ((sbt_stride & 0xffu) << 16u) | ((miss_index & 0xffu) << 24u);
}
