//! What the instances of an IAS can select in the SBT's hit region, as launches
//! check it (see `validate::scene`).

/// What an IAS's instances can select in the SBT's hit region: Vulkan's hit
/// record index is `instance SBT offset + geometry index × sbtRecordStride +
/// sbtRecordOffset`, with the stride and offset of the trace (4 bits each).
#[derive(Debug, Default)]
pub(crate) struct HitReach {
    /// Per instance: its SBT offset and geometry count.
    instances: Vec<(u32, u32)>,
    /// For each stride `s` in `0..16`: the instance (by index) with the largest
    /// `sbt_offset + (geometries − 1) × s`, and that value.
    by_stride: [Option<(usize, u64)>; 16],
}

impl HitReach {
    /// The reach of instances given as `(SBT offset, geometry count, mask)`.
    pub(crate) fn from_parts(instances: impl Iterator<Item = (u32, u32, u8)>) -> HitReach {
        let parts: Vec<(u32, u32, u8)> = instances.collect();
        let mut by_stride = [None; 16];
        for (stride, best) in by_stride.iter_mut().enumerate() {
            for (i, &(offset, geometries, mask)) in parts.iter().enumerate() {
                if mask == 0 {
                    continue;
                }
                let last = u64::from(offset) + u64::from(geometries.saturating_sub(1)) * stride as u64;
                if best.is_none_or(|(_, b)| last > b) {
                    *best = Some((i, last));
                }
            }
        }
        HitReach { instances: parts.iter().map(|&(o, g, _)| (o, g)).collect(), by_stride }
    }

    /// The instance reaching the highest hit record for traces with `stride` and
    /// `ray_offset` (their low 4 bits, as Vulkan reads them), and that record's index.
    pub(crate) fn furthest(&self, stride: u32, ray_offset: u32) -> Option<(usize, u64)> {
        let (instance, last) = self.by_stride[(stride & 0xf) as usize]?;
        Some((instance, last + u64::from(ray_offset & 0xf)))
    }

    /// Instance `index`'s SBT offset and geometry count.
    pub(crate) fn instance(&self, index: usize) -> (u32, u32) {
        self.instances.get(index).copied().unwrap_or((0, 0))
    }
}

#[cfg(test)]
mod tests {
    use super::HitReach;

    #[test]
    fn the_furthest_instance_depends_on_the_stride_and_masked_out_ones_reach_nothing() {
        // (offset, geometries, mask): a far offset with one geometry, a near one
        // with many, and a masked-out one further than both.
        let reach = HitReach::from_parts([(10, 1, 0xff), (2, 6, 0xff), (100, 1, 0)].into_iter());
        // Stride 1: 10 against 2 + 5 = 7.
        assert_eq!(reach.furthest(1, 0), Some((0, 10)));
        // Stride 2 with ray offset 1: 10 + 1 against 2 + 10 + 1.
        assert_eq!(reach.furthest(2, 1), Some((1, 13)));
        // Vulkan reads 4 bits of each: stride 18 is stride 2, offset 17 is 1.
        assert_eq!(reach.furthest(18, 17), Some((1, 13)));
        assert_eq!(reach.instance(1), (2, 6));
        assert_eq!(HitReach::from_parts([(5, 1, 0)].into_iter()).furthest(1, 0), None);
    }
}
