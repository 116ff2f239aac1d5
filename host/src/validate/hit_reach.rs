//! What the instances of an IAS can select in the SBT's hit region, as launches
//! check it (see `validate::scene`).

/// What an IAS's instances can select in the SBT's hit region: Vulkan's hit
/// record index is `instance SBT offset + geometry index × sbtRecordStride +
/// sbtRecordOffset`, with the stride and offset of the trace (4 bits each).
#[derive(Debug, Default)]
pub(crate) struct HitReach {
    /// Per instance: its SBT offset and geometry count.
    instances: Vec<(u32, u32)>,
    /// The instances that can be hit (mask not 0): index, and whether its GAS
    /// holds AABBs.
    hittable: Vec<(usize, bool)>,
    /// Whether some hittable instance holds triangles, and whether some holds AABBs.
    kinds: (bool, bool),
    /// For each stride `s` in `0..16`: the instance (by index) with the largest
    /// `sbt_offset + (geometries − 1) × s`, and that value.
    by_stride: [Option<(usize, u64)>; 16],
}

impl HitReach {
    /// The reach of instances given as `(SBT offset, geometry count, mask,
    /// procedural)`.
    pub(crate) fn from_parts(instances: impl Iterator<Item = (u32, u32, u8, bool)>) -> HitReach {
        let parts: Vec<(u32, u32, u8, bool)> = instances.collect();
        let mut by_stride = [None; 16];
        for (stride, best) in by_stride.iter_mut().enumerate() {
            for (i, &(offset, geometries, mask, _)) in parts.iter().enumerate() {
                if mask == 0 {
                    continue;
                }
                let last = u64::from(offset) + u64::from(geometries.saturating_sub(1)) * stride as u64;
                if best.is_none_or(|(_, b)| last > b) {
                    *best = Some((i, last));
                }
            }
        }
        let hittable: Vec<(usize, bool)> =
            parts.iter().enumerate().filter(|(_, p)| p.2 != 0).map(|(i, p)| (i, p.3)).collect();
        let kinds = (hittable.iter().any(|h| !h.1), hittable.iter().any(|h| h.1));
        HitReach { instances: parts.iter().map(|&(o, g, _, _)| (o, g)).collect(), hittable, kinds, by_stride }
    }

    /// The first geometry whose hit record, for traces with `stride` and
    /// `ray_offset` (low 4 bits), holds a group of the other kind than the
    /// geometry (`kinds`: the SBT's hit records): the instance, the geometry, the
    /// record, and whether the geometry is procedural. Records past the SBT's
    /// end are not looked at ([`HitReach::furthest`] is). Constant time when the
    /// SBT's hit groups are all of the kind of every instance; otherwise one look
    /// per geometry of the hittable instances.
    pub(crate) fn kind_mismatch(
        &self,
        kinds: &crate::validate::records::HitKinds,
        stride: u32,
        ray_offset: u32,
    ) -> Option<(usize, u32, u64, bool)> {
        match (kinds.uniform(), self.kinds) {
            (Some(false), (_, false)) | (Some(true), (false, _)) => return None,
            _ => {}
        }
        let (stride, ray_offset) = (u64::from(stride & 0xf), u64::from(ray_offset & 0xf));
        for &(instance, procedural) in &self.hittable {
            let (offset, geometries) = self.instances[instance];
            for geometry in 0..geometries {
                let slot = u64::from(offset) + u64::from(geometry) * stride + ray_offset;
                match kinds.is_procedural(slot) {
                    Some(group) if group != procedural => return Some((instance, geometry, slot, procedural)),
                    Some(_) => {}
                    // Every later geometry reaches further (or, with stride 0, as far).
                    None => break,
                }
            }
        }
        None
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
        let reach = HitReach::from_parts([(10, 1, 0xff, false), (2, 6, 0xff, false), (100, 1, 0, false)].into_iter());
        // Stride 1: 10 against 2 + 5 = 7.
        assert_eq!(reach.furthest(1, 0), Some((0, 10)));
        // Stride 2 with ray offset 1: 10 + 1 against 2 + 10 + 1.
        assert_eq!(reach.furthest(2, 1), Some((1, 13)));
        // Vulkan reads 4 bits of each: stride 18 is stride 2, offset 17 is 1.
        assert_eq!(reach.furthest(18, 17), Some((1, 13)));
        assert_eq!(reach.instance(1), (2, 6));
        assert_eq!(HitReach::from_parts([(5, 1, 0, false)].into_iter()).furthest(1, 0), None);
    }

    #[test]
    fn a_geometry_selecting_a_hit_group_of_the_other_kind_is_found() {
        use crate::validate::records::HitKinds;
        // Instance 0: two triangle geometries at offset 0; instance 1: AABBs at offset 2;
        // instance 2: AABBs, masked out, at offset 0.
        let reach = HitReach::from_parts([(0, 2, 0xff, false), (2, 1, 0xff, true), (0, 1, 0, true)].into_iter());
        let right = HitKinds::new(vec![false, false, true]);
        assert_eq!(reach.kind_mismatch(&right, 1, 0), None);
        // A procedural group at record 1, selected by instance 0's second geometry.
        let wrong = HitKinds::new(vec![false, true, true]);
        assert_eq!(reach.kind_mismatch(&wrong, 1, 0), Some((0, 1, 1, false)));
        // All triangle groups: instance 1's AABBs select record 2.
        assert_eq!(reach.kind_mismatch(&HitKinds::new(vec![false; 3]), 1, 0), Some((1, 0, 2, true)));
        // A triangles-only scene with triangle groups is answered without a look.
        let triangles = HitReach::from_parts([(0, 1 << 20, 0xff, false)].into_iter());
        assert_eq!(triangles.kind_mismatch(&HitKinds::new(vec![false]), 1, 0), None);
    }
}
