//! The four regions of a shader binding table, as `vkCmdTraceRaysKHR` takes them.

use std::fmt;

use crate::types::context::DeviceLimits;
use crate::types::group::GroupKind;

/// An SBT region: where [`SbtBuilder`](crate::SbtBuilder) places records, and what
/// [`Sbt::update`](crate::Sbt::update) and errors name.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum SbtRegion {
    /// The raygen record.
    Raygen,
    /// The miss records.
    Miss,
    /// The hit records.
    Hit,
    /// The callable records.
    Callable,
}

impl SbtRegion {
    /// The regions in the order `vkCmdTraceRaysKHR` takes them (and
    /// [`Sbt::region_layouts`](crate::Sbt::region_layouts) returns them).
    pub const ALL: [SbtRegion; 4] = [SbtRegion::Raygen, SbtRegion::Miss, SbtRegion::Hit, SbtRegion::Callable];

    /// Its position in [`SbtRegion::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Its lower-case name, as errors print it: `"raygen"`, `"miss"`, `"hit"` or
    /// `"callable"` (also the name of the builder method that fills it).
    pub const fn name(self) -> &'static str {
        match self {
            SbtRegion::Raygen => "raygen",
            SbtRegion::Miss => "miss",
            SbtRegion::Hit => "hit",
            SbtRegion::Callable => "callable",
        }
    }

    /// The kind of group whose records the user places in it. (raykit places the
    /// exception group's record in the callable region itself.)
    pub const fn group_kind(self) -> GroupKind {
        match self {
            SbtRegion::Raygen => GroupKind::Raygen,
            SbtRegion::Miss => GroupKind::Miss,
            SbtRegion::Hit => GroupKind::Hit,
            SbtRegion::Callable => GroupKind::Callable,
        }
    }
}

impl fmt::Display for SbtRegion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::SbtRegion;

    #[test]
    fn regions_are_in_trace_rays_order_with_their_names() {
        let names: Vec<(usize, String)> = SbtRegion::ALL.iter().map(|r| (r.index(), r.to_string())).collect();
        assert_eq!(
            names,
            [(0, "raygen".to_owned()), (1, "miss".to_owned()), (2, "hit".to_owned()), (3, "callable".to_owned())]
        );
    }
}
/// Byte layout of one region.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct RegionLayout {
    /// Offset of the region from the start of the SBT buffer.
    pub offset: u64,
    /// Distance between consecutive records.
    pub stride: u64,
    /// Size of the region.
    pub size: u64,
}

/// Computes a region's layout for records with the largest data `max_data`,
/// starting at or after `start`. Pure, so it is unit-tested.
pub fn region_layout(limits: &DeviceLimits, start: u64, count: usize, max_data: usize) -> RegionLayout {
    if count == 0 {
        return RegionLayout { offset: start, stride: 0, size: 0 };
    }
    let stride =
        align_up(limits.shader_group_handle_size as u64 + max_data as u64, limits.shader_group_handle_alignment as u64);
    let offset = align_up(start, limits.shader_group_base_alignment as u64);
    RegionLayout { offset, stride, size: stride * count as u64 }
}

fn align_up(x: u64, a: u64) -> u64 {
    if a <= 1 {
        x
    } else {
        x.div_ceil(a) * a
    }
}

/// The hit record a trace selects, as Vulkan computes it: the instance's SBT
/// offset (its low 24 bits) + `geometry` × the trace's `sbtRecordStride` (its
/// low 4 bits) + the trace's `sbtRecordOffset` (its low 4 bits). Both backends
/// select records with it.
pub(crate) fn selected_hit_record(instance_offset: u32, geometry: u32, stride: u32, offset: u32) -> u64 {
    u64::from(instance_offset & 0xff_ffff) + u64::from(geometry) * u64::from(stride & 0xf) + u64::from(offset & 0xf)
}

/// The miss record a trace selects, as Vulkan computes it: the low 16 bits of
/// its `missIndex`.
pub(crate) fn selected_miss_record(miss_index: u32) -> u64 {
    u64::from(miss_index & 0xffff)
}

#[cfg(test)]
mod selection_tests {
    use super::{selected_hit_record, selected_miss_record};

    #[test]
    fn records_are_selected_from_the_bits_vulkan_reads() {
        // Offset 16 is offset 0, stride 18 is stride 2; the instance keeps 24 bits.
        assert_eq!(selected_hit_record(3, 2, 18, 16), 3 + 2 * 2);
        assert_eq!(selected_hit_record(1 << 24 | 5, 0, 1, 1), 6);
        assert_eq!(selected_hit_record(0, 1, 15, 15), 30);
        assert_eq!(selected_miss_record(0x1_0002), 2);
    }
}

/// A checked SBT record as a backend packs it: the index of its group in the
/// pipeline, and its data.
#[derive(Copy, Clone, Debug)]
pub(crate) struct PlainRecord<'a> {
    pub(crate) group: usize,
    pub(crate) data: &'a [u8],
}
