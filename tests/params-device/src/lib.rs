//! Launch-params structs for raykit's layout tests, and one raygen program per
//! struct that copies every field, word by word, into the struct's `out` buffer.
//!
//! The host flattens the same values with the same [`Words`] code and compares
//! the two exactly. The `*Dependent` structs differ between the host and the
//! SPIR-V target on purpose (as a glam feature, a `cfg` or a stale build can make
//! a struct differ), so the host must refuse them.
#![cfg_attr(target_arch = "spirv", no_std)]

pub mod elements;

use raykit_device::glam::{Mat4, UVec2, Vec2, Vec3, Vec3A, Vec4};
use raykit_device::{raygen, Buffer, LaunchParams, Raygen};

/// Somewhere to put 32-bit words, one after the other.
pub trait Sink {
    /// Appends `word`.
    fn put(&mut self, word: u32);
}

#[cfg(not(target_arch = "spirv"))]
impl Sink for Vec<u32> {
    fn put(&mut self, word: u32) {
        self.push(word);
    }
}

/// Words collected on the device before they are stored. (A sink holding the
/// `&mut Raygen` itself would be simpler, but rust-gpu 0.11 cannot keep a
/// pointer in a local struct: it compiles such code to loads of an
/// uninitialised pointer, silently. Keep stage contexts out of structs.)
struct ArraySink {
    words: [u32; MAX_WORDS],
    len: u32,
}

/// The most words a test struct has.
pub const MAX_WORDS: usize = 64;

impl Sink for ArraySink {
    fn put(&mut self, word: u32) {
        if (self.len as usize) < MAX_WORDS {
            self.words[self.len as usize] = word;
        }
        self.len += 1;
    }
}

/// A value's meaningful words, in order, without padding.
pub trait Words {
    /// Writes them to `sink`.
    fn words<S: Sink>(&self, sink: &mut S);
}

impl Words for u32 {
    fn words<S: Sink>(&self, sink: &mut S) {
        sink.put(*self);
    }
}
impl Words for i32 {
    fn words<S: Sink>(&self, sink: &mut S) {
        sink.put(*self as u32);
    }
}
impl Words for f32 {
    fn words<S: Sink>(&self, sink: &mut S) {
        sink.put(self.to_bits());
    }
}
impl Words for u64 {
    fn words<S: Sink>(&self, sink: &mut S) {
        sink.put(*self as u32);
        sink.put((*self >> 32) as u32);
    }
}
impl Words for Vec2 {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.x.words(sink);
        self.y.words(sink);
    }
}
impl Words for UVec2 {
    fn words<S: Sink>(&self, sink: &mut S) {
        sink.put(self.x);
        sink.put(self.y);
    }
}
impl Words for Vec3 {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.x.words(sink);
        self.y.words(sink);
        self.z.words(sink);
    }
}
impl Words for Vec3A {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.x.words(sink);
        self.y.words(sink);
        self.z.words(sink);
    }
}
impl Words for Vec4 {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.x.words(sink);
        self.y.words(sink);
        self.z.words(sink);
        self.w.words(sink);
    }
}
impl Words for Mat4 {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.x_axis.words(sink);
        self.y_axis.words(sink);
        self.z_axis.words(sink);
        self.w_axis.words(sink);
    }
}
impl<T: Words, const N: usize> Words for [T; N] {
    fn words<S: Sink>(&self, sink: &mut S) {
        let mut i = 0;
        while i < N {
            self[i].words(sink);
            i += 1;
        }
    }
}

/// A small nested struct.
#[repr(C)]
#[derive(Copy, Clone, Debug, Default, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Inner {
    /// A float.
    pub x: f32,
    /// An integer.
    pub y: u32,
    /// A vector.
    pub z: Vec2,
}
impl Words for Inner {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.x.words(sink);
        self.y.words(sink);
        self.z.words(sink);
    }
}

/// Scalars, 64-bit integers, small vectors, an array and a nested struct:
/// 88 bytes, delivered as push constants.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Mixed {
    /// Where the program writes the words.
    pub out: Buffer<u32>,
    /// u32.
    pub a: u32,
    /// f32.
    pub b: f32,
    /// i32.
    pub d: i32,
    /// u64, on its 8-byte alignment.
    pub c: u64,
    /// Vec2.
    pub v2: Vec2,
    /// UVec2.
    pub uv2: UVec2,
    /// Vec3 (12 bytes, 4-byte aligned on both targets).
    pub v3: Vec3,
    /// f32 right after the Vec3.
    pub e: f32,
    /// An array.
    pub arr: [u32; 4],
    /// A nested struct.
    pub inner: Inner,
}
impl Words for Mixed {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.a.words(sink);
        self.b.words(sink);
        self.d.words(sink);
        self.c.words(sink);
        self.v2.words(sink);
        self.uv2.words(sink);
        self.v3.words(sink);
        self.e.words(sink);
        self.arr.words(sink);
        self.inner.words(sink);
    }
}

/// glam's 16-byte-aligned types: Vec4, Vec3A, Mat4 (112 bytes, push constants).
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Aligned {
    /// Where the program writes the words.
    pub out: Buffer<u32>,
    /// Padding up to the Vec4's 16-byte alignment.
    pub _pad: [u32; 3],
    /// Vec4.
    pub v4: Vec4,
    /// Vec3A (16 bytes on the host).
    pub v3a: Vec3A,
    /// Mat4.
    pub m4: Mat4,
}
impl Words for Aligned {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.v4.words(sink);
        self.v3a.words(sink);
        self.m4.words(sink);
    }
}

/// 192 bytes: over the push-constant budget, so delivered in a uniform buffer.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct Large {
    /// Where the program writes the words.
    pub out: Buffer<u32>,
    /// Padding up to the matrix's 16-byte alignment.
    pub _pad: [u32; 3],
    /// A matrix.
    pub m: Mat4,
    /// An array of vectors.
    pub v: [Vec4; 4],
    /// An array of floats.
    pub tail: [f32; 8],
    /// A 64-bit value.
    pub id: u64,
    /// Padding to the struct's 16-byte alignment.
    pub _pad2: u64,
}
impl Words for Large {
    fn words<S: Sink>(&self, sink: &mut S) {
        self.m.words(sink);
        self.v.words(sink);
        self.tail.words(sink);
        self.id.words(sink);
    }
}

/// A struct laid out differently on the host and on the SPIR-V target, as
/// glam's `scalar-math` feature enabled on one side only does to a `Vec4`:
/// `value` is 4-byte aligned at offset 4 on the host, 16-byte aligned at
/// offset 16 (after explicit padding) in the SPIR-V.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct TargetDependent {
    /// Where the program writes the words.
    pub out: Buffer<u32>,
    /// Padding, only on the device.
    #[cfg(target_arch = "spirv")]
    pub _pad: [u32; 3],
    /// The value the program reads: `[f32; 4]` on the host.
    #[cfg(not(target_arch = "spirv"))]
    pub value: [f32; 4],
    /// The value the program reads: `Vec4` on the device.
    #[cfg(target_arch = "spirv")]
    pub value: Vec4,
}

/// A nested struct laid out differently on the two targets: 4 bytes on the
/// host, 8 in the SPIR-V, where a field the host lacks comes first.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct InnerDependent {
    /// Only on the device.
    #[cfg(target_arch = "spirv")]
    pub device_only: u32,
    /// The value the program reads.
    pub b: f32,
}

/// Params whose nested struct differs between the targets.
#[repr(C)]
#[derive(Copy, Clone, Debug, bytemuck::Pod, bytemuck::Zeroable, LaunchParams)]
pub struct NestedDependent {
    /// Where the program writes the words.
    pub out: Buffer<u32>,
    /// The differing struct.
    pub inner: InnerDependent,
}

fn dump<T: Words>(ctx: &mut Raygen, out: Buffer<u32>, value: &T) {
    let mut sink = ArraySink { words: [0; MAX_WORDS], len: 0 };
    value.words(&mut sink);
    let mut i = 0;
    while i < sink.len && (i as usize) < MAX_WORDS {
        ctx.store(out, i, sink.words[i as usize]);
        i += 1;
    }
}

#[raygen]
fn rg_mixed(ctx: &mut Raygen, #[params] p: &Mixed) {
    dump(ctx, p.out, p);
}

#[raygen]
fn rg_aligned(ctx: &mut Raygen, #[params] p: &Aligned) {
    dump(ctx, p.out, p);
}

#[raygen]
fn rg_large(ctx: &mut Raygen, #[params] p: &Large) {
    dump(ctx, p.out, p);
}

// These two differ from the host on purpose: no build-time check, the host
// test expects the link-time error.
#[raygen(skip_params_check)]
fn rg_target_dependent(ctx: &mut Raygen, #[params] p: &TargetDependent) {
    // Not `p.value[0]`: rust-gpu 0.11 cannot index glam vectors in buffers
    // (Rust-GPU/rust-gpu#432, a pointer OpPhi).
    #[cfg(target_arch = "spirv")]
    let x = p.value.x;
    #[cfg(not(target_arch = "spirv"))]
    let x = p.value[0];
    ctx.store(p.out, 0, x.to_bits());
}

#[raygen(skip_params_check)]
fn rg_nested_dependent(ctx: &mut Raygen, #[params] p: &NestedDependent) {
    ctx.store(p.out, 0, p.inner.b.to_bits());
}

#[raygen]
fn rg_loop(ctx: &mut Raygen, #[params] p: &Mixed) {
    let mut i = 0;
    while i < 4 {
        ctx.store(p.out, i, p.arr[i as usize]);
        i += 1;
    }
}
