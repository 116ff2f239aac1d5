//! Colour transfer functions and pixel packing shared by device programs and
//! the host: sRGB encode and decode, RGBA8 packing.

use spirv_std::glam::Vec3;

use crate::math::powf;

/// Linear → sRGB transfer of one channel in `[0, 1]`.
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * powf(c, 1.0 / 2.4) - 0.055
    }
}

/// sRGB → linear transfer of one channel in `[0, 1]` (what a sampler does for an
/// sRGB texture format).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        powf((c + 0.055) / 1.055, 2.4)
    }
}

/// One linear channel clamped to `[0, 1]`, sRGB-encoded and quantised to 8
/// bits: `(linear_to_srgb(c.clamp(0.0, 1.0)) * 255.0 + 0.5) as u32` (NaN gives 0).
///
/// On the host the value comes from a table of where each 8-bit step starts,
/// built once from that formula, so it is the formula's value without its
/// `powf`; on the device the formula runs as written.
pub fn srgb8(c: f32) -> u32 {
    #[cfg(not(target_arch = "spirv"))]
    {
        srgb8_table::quantize(srgb8_table::get(), c)
    }
    #[cfg(target_arch = "spirv")]
    {
        srgb8_exact(c)
    }
}

/// [`srgb8`] by its formula.
fn srgb8_exact(c: f32) -> u32 {
    (linear_to_srgb(c.clamp(0.0, 1.0)) * 255.0 + 0.5) as u32
}

/// sutil's `make_color`: clamps a linear colour to `[0, 1]`, sRGB-encodes and
/// quantises it to 8 bits, packed as RGBA8 (red in the lowest byte, alpha 255).
pub fn pack_srgb8(c: Vec3) -> u32 {
    #[cfg(not(target_arch = "spirv"))]
    let [r, g, b] = srgb8_table::quantize3(srgb8_table::get(), c);
    #[cfg(target_arch = "spirv")]
    let [r, g, b] = [srgb8_exact(c.x), srgb8_exact(c.y), srgb8_exact(c.z)];
    r | (g << 8) | (b << 16) | (255 << 24)
}

/// Quantises a colour clamped to `[0, 1]` to RGBA8 without a transfer function
/// (red in the lowest byte, alpha 255): for pictures tests compare exactly.
pub fn pack_unorm8(c: Vec3) -> u32 {
    let q = |v: f32| -> u32 { (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u32 };
    q(c.x) | (q(c.y) << 8) | (q(c.z) << 16) | (255 << 24)
}

/// [`srgb8`] on the host by table: the formula is monotonic in `c`, so its
/// value is the number of 8-bit steps that start at or below `c`. A uniform
/// grid of [`BUCKETS`](srgb8_table::BUCKETS) cells over `[0, 1]` gives the value at
/// each cell's lowest `f32`; the formula's slope stays below one step per
/// cell, so one comparison with the next step's start finishes it.
#[cfg(not(target_arch = "spirv"))]
mod srgb8_table {
    use std::sync::OnceLock;

    use spirv_std::glam::{Vec3, Vec3A};

    /// Cells of the grid over `[0, 1]`.
    pub(super) const BUCKETS: usize = 4096;

    pub(super) struct Table {
        /// The value at the lowest `f32` of each cell (`1.0` has a cell of its own).
        at_cell: [u8; BUCKETS + 1],
        /// `step_start[k]`: the lowest `f32` of value `k` (`k` in `1..=255`);
        /// `step_start[256]` is infinite.
        step_start: [f32; 257],
    }

    /// The cell of `c`.
    ///
    /// # Safety
    /// `c` is within `[0, 1]`.
    #[inline(always)]
    unsafe fn cell(c: f32) -> usize {
        // SAFETY: the caller's: `c * BUCKETS` is within `0..=BUCKETS`, which `i32` holds.
        let cell: i32 = unsafe { (c * BUCKETS as f32).to_int_unchecked() };
        (cell as usize).min(BUCKETS)
    }

    /// The lowest `f32` in `[0, 1]` for which `reached` holds (`reached` is false
    /// below some point and true from it on; `1.0` when it never holds below).
    pub(super) fn lowest(reached: impl Fn(f32) -> bool) -> f32 {
        let (mut low, mut high) = (0u32, 1.0f32.to_bits());
        if reached(0.0) {
            return 0.0;
        }
        // `reached(low)` is false and `reached(high)` is true (or `high` is 1.0).
        while high - low > 1 {
            let mid = low + (high - low) / 2;
            if reached(f32::from_bits(mid)) {
                high = mid;
            } else {
                low = mid;
            }
        }
        f32::from_bits(high)
    }

    /// The table, or `None` where a cell would hold more than one step (the
    /// formula is then used as written).
    fn build() -> Option<Table> {
        let mut step_start = [f32::INFINITY; 257];
        for (k, start) in step_start.iter_mut().enumerate().take(256).skip(1) {
            *start = lowest(|c| super::srgb8_exact(c) >= k as u32);
        }
        step_start[0] = 0.0;
        let mut at_cell = [0u8; BUCKETS + 1];
        for (index, value) in at_cell.iter_mut().enumerate() {
            // `lowest` tries values within `[0, 1]` only.
            let cell_of = |c: f32| {
                // SAFETY: `c` comes from `lowest`, within `[0, 1]`.
                unsafe { cell(c) }
            };
            let first = lowest(|c| cell_of(c) >= index);
            let k = super::srgb8_exact(first);
            let last_of_cell =
                if index == BUCKETS { 1.0 } else { f32::from_bits(lowest(|c| cell_of(c) > index).to_bits() - 1) };
            // At most one step may start inside the cell.
            if super::srgb8_exact(last_of_cell) > k + 1 {
                return None;
            }
            *value = u8::try_from(k).ok()?;
        }
        Some(Table { at_cell, step_start })
    }

    impl Table {
        /// The value at `c`: its cell's, or the next step's if that starts at
        /// or below `c`.
        ///
        /// # Safety
        /// `c` is within `[0, 1]`.
        #[inline(always)]
        unsafe fn value(&self, c: f32) -> u32 {
            // SAFETY: the caller's.
            let k = self.at_cell[unsafe { cell(c) }];
            u32::from(k) + u32::from(c >= self.step_start[usize::from(k) + 1])
        }
    }

    static TABLE: OnceLock<Option<Table>> = OnceLock::new();

    /// Whether the table is in use (rather than the formula).
    #[cfg(test)]
    pub(super) fn built() -> bool {
        get().is_some()
    }

    /// The table (built on first use), or `None` where the formula is used.
    pub(super) fn get() -> Option<&'static Table> {
        TABLE.get_or_init(build).as_ref()
    }

    /// [`super::srgb8`] by `table`, or by the formula without one.
    #[inline(always)]
    pub(super) fn quantize(table: Option<&Table>, c: f32) -> u32 {
        let Some(table) = table else {
            return super::srgb8_exact(c);
        };
        // Clamped to `[0, 1]`, NaN to 0 (where the formula gives 0 too).
        let c = if c >= 0.0 { c.min(1.0) } else { 0.0 };
        // SAFETY: clamped just above.
        unsafe { table.value(c) }
    }

    /// [`quantize`] of three channels, clamped together.
    #[inline(always)]
    pub(super) fn quantize3(table: Option<&Table>, c: Vec3) -> [u32; 3] {
        let Some(table) = table else {
            return [c.x, c.y, c.z].map(super::srgb8_exact);
        };
        // Clamped to `[0, 1]`, NaN to 0 (where the formula gives 0 too).
        let c = Vec3A::from(c);
        let c = Vec3A::select(c.cmpge(Vec3A::ZERO), c.min(Vec3A::ONE), Vec3A::ZERO);
        // SAFETY: clamped just above.
        [0, 1, 2].map(|i| unsafe { table.value(c[i]) })
    }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_and_packs() {
        for i in 0..=255 {
            let c = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5, "{c}");
        }
        assert_eq!(pack_srgb8(Vec3::new(1.0, 0.0, 2.0)), 0xffff_00ff);
    }

    /// The table gives the formula's value: at every step's start and the
    /// `f32`s around it, at every cell's edges, at the ends, at NaN and the
    /// infinities, and at every 61st `f32` of `[0, 1]`.
    #[test]
    fn srgb8_by_table_is_the_formula() {
        let check = |c: f32| assert_eq!(srgb8(c), srgb8_exact(c), "{c:e} ({:#x})", c.to_bits());
        for c in [0.0, -0.0, 1.0, -1.0, 2.0, f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE] {
            check(c);
        }
        let around = |c: f32| {
            let bits = c.to_bits();
            for b in bits.saturating_sub(4)..=bits.saturating_add(4).min(1.0f32.to_bits()) {
                check(f32::from_bits(b));
            }
        };
        for k in 1..256 {
            let start = srgb8_table::lowest(|c| srgb8_exact(c) >= k);
            assert_eq!(srgb8_exact(start), k);
            around(start);
        }
        for index in 0..=srgb8_table::BUCKETS {
            around(index as f32 / srgb8_table::BUCKETS as f32);
        }
        for bits in (0..=1.0f32.to_bits()).step_by(61) {
            check(f32::from_bits(bits));
        }
        assert!(srgb8_table::built(), "the table was not built: a cell holds two steps");
        // Three channels at once give each one's value.
        let special = [0.0, -0.0, 1.0, -1.0, 2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.5, 0.0031308];
        for (i, &r) in special.iter().enumerate() {
            for bits in (0..=1.0f32.to_bits()).step_by(997_331) {
                let (g, b) = (f32::from_bits(bits), special[(i + 3) % special.len()]);
                let expected = srgb8_exact(r) | (srgb8_exact(g) << 8) | (srgb8_exact(b) << 16) | (255 << 24);
                assert_eq!(pack_srgb8(Vec3::new(r, g, b)), expected, "{r:e} {g:e} {b:e}");
            }
        }
        assert_eq!(pack_unorm8(Vec3::new(0.5, 0.0, 1.0)), 0xffff_0080);
    }
}
