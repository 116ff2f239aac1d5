//! What a [`Buffer`](crate::Buffer) holds: values of a fixed number of 32-bit words.
//!
//! Buffers are tables of 32-bit words on the device (SPIR-V cannot reinterpret
//! bytes), so each element type says how its value is laid out in words; the host
//! writes and reads the same words through `bytemuck`. raykit implements
//! [`Element`] for `u32`, `i32`, `f32`, `u64`, `i64` (two words, low word first),
//! glam's `Vec2`–`Vec4`, `UVec2`–`UVec4` and `IVec2`–`IVec4`, and [`Buffer<T>`](crate::Buffer)
//! handles (which the host does not check inside buffers).
//!
//! Structs of these derive it, so a `DeviceBuffer<Sphere>` on the host is a
//! `Buffer<Sphere>` on the device:
//!
//! ```
//! use raykit_device::glam::Vec3;
//! use raykit_device::Element;
//!
//! /// A sphere as a buffer holds it: 5 words.
//! #[repr(C)]
//! #[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, Element)]
//! pub struct Sphere {
//!     pub centre: Vec3,
//!     pub radius: f32,
//!     pub material: u32,
//! }
//! assert_eq!(<Sphere as Element>::WORDS, 5);
//! ```
//!
//! ## The layout check
//!
//! An element's fields follow each other word by word, in declaration order: each
//! field starts at the word after the previous field's last. `#[derive(Element)]`
//! checks at compile time, on every target the struct is compiled for, that the
//! compiler laid the struct out the same way (a field after padding, or a glam
//! type with SIMD alignment, is a compile error naming the field), so the host's
//! bytes are the device's words. Across targets (a field behind `cfg`, a glam
//! feature on one side only, a stale build), the derive records the layout, and in
//! a device crate (`[package.metadata.raykit] device = true`) it also gives the
//! SPIR-V the struct's layout as the compiler for the device saw it. The two are
//! compared, as launch params are, right after `cargo xtask build-shaders` (a
//! host test the derive generates), and on demand by `raykit::Module::check_element`;
//! a difference is an error naming the field.

use crate::Shape;
use spirv_std::glam;

/// A value that a [`Buffer`](crate::Buffer) can hold: a fixed number of 32-bit words.
///
/// Derive it for `#[repr(C)]` structs of elements (see the [module docs](self));
/// the host side uses the same layout through `bytemuck`.
#[diagnostic::on_unimplemented(
    message = "`{Self}` cannot be held in a buffer",
    label = "not a buffer element",
    note = "buffer elements are u32, i32, f32, u64, i64, glam's Vec2-Vec4, UVec2-UVec4, IVec2-IVec4, Buffer<T>, and \
            structs of these with `#[repr(C)]` and `#[derive(Copy, Clone, bytemuck::Pod, bytemuck::Zeroable, Element)]`"
)]
pub trait Element: Copy + bytemuck::Pod {
    /// The number of 32-bit words one element takes.
    const WORDS: u32;
    /// What the words mean, for the layout check against the SPIR-V: a number
    /// or a vector, a handle, or a struct with its fields' byte offsets
    /// (4 × their first word).
    const SHAPE: Shape;
    /// Reads the element that starts at word `base`.
    fn read(words: &[u32], base: usize) -> Self;
    /// Writes the element at word `base`.
    fn write(self, words: &mut [u32], base: usize);
    /// Reads the element that starts at word `base` without checking the
    /// words against the slice's length (device buffers: an access past the
    /// end is defined by `robustBufferAccess2`, see [`Buffer`](crate::Buffer)).
    /// The default calls [`Element::read`].
    ///
    /// # Safety
    /// `base + WORDS` must not exceed `words.len()`.
    unsafe fn read_unchecked(words: &[u32], base: usize) -> Self {
        Self::read(words, base)
    }
    /// Writes the element at word `base` without checking the words against
    /// the slice's length. The default calls [`Element::write`].
    ///
    /// # Safety
    /// `base + WORDS` must not exceed `words.len()`.
    unsafe fn write_unchecked(self, words: &mut [u32], base: usize) {
        self.write(words, base)
    }
}

/// `words[i]` without a bounds check (`OpAccessChain` only; slices' own
/// `get_unchecked` does not compile to SPIR-V).
///
/// # Safety
/// `i < words.len()`.
#[inline(always)]
unsafe fn word(words: &[u32], i: usize) -> u32 {
    use spirv_std::arch::IndexUnchecked;
    // SAFETY: the caller's.
    unsafe { *words.index_unchecked(i) }
}

/// `words[i] = value` without a bounds check.
///
/// # Safety
/// `i < words.len()`.
#[inline(always)]
unsafe fn set_word(words: &mut [u32], i: usize, value: u32) {
    use spirv_std::arch::IndexUnchecked;
    // SAFETY: the caller's.
    unsafe { *words.index_unchecked_mut(i) = value }
}

/// Elements of one word, with the conversions from and to it.
macro_rules! word_element {
    ($($ty:ty: |$w:ident| $from:expr, |$v:ident| $to:expr, $shape:expr;)*) => {$(
        impl Element for $ty {
            const WORDS: u32 = 1;
            const SHAPE: Shape = $shape;
            fn read(words: &[u32], base: usize) -> Self {
                let $w = words[base];
                $from
            }
            fn write(self, words: &mut [u32], base: usize) {
                let $v = self;
                words[base] = $to;
            }
            unsafe fn read_unchecked(words: &[u32], base: usize) -> Self {
                // SAFETY: the caller's.
                let $w = unsafe { word(words, base) };
                $from
            }
            unsafe fn write_unchecked(self, words: &mut [u32], base: usize) {
                let $v = self;
                // SAFETY: the caller's.
                unsafe { set_word(words, base, $to) }
            }
        }
    )*};
}

const fn numeric(kind: crate::ScalarKind, bits: u32) -> Shape {
    Shape::Numeric(crate::Scalar { kind, bits })
}
const U32: Shape = numeric(crate::ScalarKind::Unsigned, 32);
const I32: Shape = numeric(crate::ScalarKind::Signed, 32);
const F32: Shape = numeric(crate::ScalarKind::Float, 32);

word_element! {
    u32: |w| w, |v| v, U32;
    i32: |w| w as i32, |v| v as u32, I32;
    f32: |w| f32::from_bits(w), |v| v.to_bits(), F32;
}

impl<T: 'static> Element for crate::Buffer<T> {
    const WORDS: u32 = 1;
    const SHAPE: Shape = Shape::Buffer;
    fn read(words: &[u32], base: usize) -> Self {
        crate::Buffer::from_table_index(words[base])
    }
    fn write(self, words: &mut [u32], base: usize) {
        words[base] = self.raw();
    }
    unsafe fn read_unchecked(words: &[u32], base: usize) -> Self {
        // SAFETY: the caller's.
        crate::Buffer::from_table_index(unsafe { word(words, base) })
    }
    unsafe fn write_unchecked(self, words: &mut [u32], base: usize) {
        // SAFETY: the caller's.
        unsafe { set_word(words, base, self.raw()) }
    }
}

/// 64-bit integers: two words, the low one first (little-endian, as the host stores them).
macro_rules! wide_element {
    ($($ty:ty, $shape:expr;)*) => {$(
        impl Element for $ty {
            const WORDS: u32 = 2;
            const SHAPE: Shape = $shape;
            fn read(words: &[u32], base: usize) -> Self {
                (u64::from(words[base]) | (u64::from(words[base + 1]) << 32)) as $ty
            }
            fn write(self, words: &mut [u32], base: usize) {
                let bits = self as u64;
                words[base] = bits as u32;
                words[base + 1] = (bits >> 32) as u32;
            }
            unsafe fn read_unchecked(words: &[u32], base: usize) -> Self {
                // SAFETY: the caller's: `base + 2 <= words.len()`.
                let (low, high) = unsafe { (word(words, base), word(words, base + 1)) };
                (u64::from(low) | (u64::from(high) << 32)) as $ty
            }
            unsafe fn write_unchecked(self, words: &mut [u32], base: usize) {
                let bits = self as u64;
                // SAFETY: the caller's: `base + 2 <= words.len()`.
                unsafe {
                    set_word(words, base, bits as u32);
                    set_word(words, base + 1, (bits >> 32) as u32);
                }
            }
        }
    )*};
}
wide_element! {
    u64, numeric(crate::ScalarKind::Unsigned, 64);
    i64, numeric(crate::ScalarKind::Signed, 64);
}

/// glam vectors: one word per component, `x` first.
macro_rules! vector_element {
    ($ty:ty, $n:literal, [$($c:ident),+], $scalar:ty, $shape:expr) => {
        impl Element for $ty {
            const WORDS: u32 = $n;
            const SHAPE: Shape = $shape;
            fn read(words: &[u32], base: usize) -> Self {
                let mut i = base;
                $(let $c = <$scalar as Element>::read(words, i); i += 1;)+
                let _ = i;
                <$ty>::new($($c),+)
            }
            fn write(self, words: &mut [u32], base: usize) {
                let mut i = base;
                $(self.$c.write(words, i); i += 1;)+
                let _ = i;
            }
            unsafe fn read_unchecked(words: &[u32], base: usize) -> Self {
                let mut i = base;
                // SAFETY: the caller's: `base + WORDS <= words.len()`.
                $(let $c = unsafe { <$scalar as Element>::read_unchecked(words, i) }; i += 1;)+
                let _ = i;
                <$ty>::new($($c),+)
            }
            unsafe fn write_unchecked(self, words: &mut [u32], base: usize) {
                let mut i = base;
                // SAFETY: the caller's: `base + WORDS <= words.len()`.
                $(unsafe { self.$c.write_unchecked(words, i) }; i += 1;)+
                let _ = i;
            }
        }
    };
}
vector_element!(glam::Vec2, 2, [x, y], f32, F32);
vector_element!(glam::Vec3, 3, [x, y, z], f32, F32);
vector_element!(glam::Vec4, 4, [x, y, z, w], f32, F32);
vector_element!(glam::UVec2, 2, [x, y], u32, U32);
vector_element!(glam::UVec3, 3, [x, y, z], u32, U32);
vector_element!(glam::UVec4, 4, [x, y, z, w], u32, U32);
vector_element!(glam::IVec2, 2, [x, y], i32, I32);
vector_element!(glam::IVec3, 3, [x, y, z], i32, I32);
vector_element!(glam::IVec4, 4, [x, y, z, w], i32, I32);
