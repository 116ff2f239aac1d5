use raykit_device::Element;

// `id` is 8-byte aligned: 4 bytes of padding before it, where a buffer's words
// have none.
#[repr(C)]
#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, Element)]
struct Sphere {
    radius: f32,
    id: u64,
}

fn main() {}
