//! raykit's plain descriptions as Vulkan values: texel formats, samplers, build,
//! geometry and instance flags, index types and shader stages. Pure mappings.

use ash::vk;
use raykit_device::ProgramKind;

use crate::types::accel::{BuildOptions, BuildPreference, GeometryFlags, IndexKind, InstanceFlags};
use crate::types::texture::{AddressMode, Filter, TextureFormat};

/// The Vulkan format of a texel format.
pub(crate) const fn format(format: TextureFormat) -> vk::Format {
    match format {
        TextureFormat::Rgba8Srgb => vk::Format::R8G8B8A8_SRGB,
        TextureFormat::Rgba8Unorm => vk::Format::R8G8B8A8_UNORM,
        TextureFormat::Rgba16Float => vk::Format::R16G16B16A16_SFLOAT,
        TextureFormat::Rgba32Float => vk::Format::R32G32B32A32_SFLOAT,
    }
}

/// The Vulkan texel filter.
pub(crate) fn filter(f: Filter) -> vk::Filter {
    match f {
        Filter::Nearest => vk::Filter::NEAREST,
        Filter::Linear => vk::Filter::LINEAR,
    }
}

/// The Vulkan address mode.
pub(crate) fn address_mode(a: AddressMode) -> vk::SamplerAddressMode {
    match a {
        AddressMode::Repeat => vk::SamplerAddressMode::REPEAT,
        AddressMode::ClampToEdge => vk::SamplerAddressMode::CLAMP_TO_EDGE,
        AddressMode::MirroredRepeat => vk::SamplerAddressMode::MIRRORED_REPEAT,
    }
}

/// The build flags of `options`.
pub(crate) fn build_flags(options: BuildOptions) -> vk::BuildAccelerationStructureFlagsKHR {
    type F = vk::BuildAccelerationStructureFlagsKHR;
    let mut flags = match options.preference {
        BuildPreference::FastTrace => F::PREFER_FAST_TRACE,
        BuildPreference::FastBuild => F::PREFER_FAST_BUILD,
        BuildPreference::Neither => F::empty(),
    };
    if options.allow_update {
        flags |= F::ALLOW_UPDATE;
    }
    if options.allow_compaction {
        flags |= F::ALLOW_COMPACTION;
    }
    flags
}

/// The Vulkan geometry flags.
pub(crate) fn geometry_flags(flags: GeometryFlags) -> vk::GeometryFlagsKHR {
    let mut vk_flags = vk::GeometryFlagsKHR::empty();
    if flags.contains(GeometryFlags::OPAQUE) {
        vk_flags |= vk::GeometryFlagsKHR::OPAQUE;
    }
    if flags.contains(GeometryFlags::NO_DUPLICATE_ANY_HIT) {
        vk_flags |= vk::GeometryFlagsKHR::NO_DUPLICATE_ANY_HIT_INVOCATION;
    }
    vk_flags
}

/// The Vulkan instance flags, as the 8 bits of `VkAccelerationStructureInstanceKHR` hold them.
pub(crate) fn instance_flags(flags: InstanceFlags) -> u8 {
    type F = vk::GeometryInstanceFlagsKHR;
    let pairs = [
        (InstanceFlags::DISABLE_TRIANGLE_CULLING, F::TRIANGLE_FACING_CULL_DISABLE),
        (InstanceFlags::FLIP_TRIANGLE_FACING, F::TRIANGLE_FLIP_FACING),
        (InstanceFlags::FORCE_OPAQUE, F::FORCE_OPAQUE),
        (InstanceFlags::FORCE_NON_OPAQUE, F::FORCE_NO_OPAQUE),
    ];
    let bits = pairs.iter().filter(|(ours, _)| flags.contains(*ours)).fold(0, |acc, (_, vk)| acc | vk.as_raw());
    bits as u8
}

/// The Vulkan index type.
pub(crate) fn index_type(kind: IndexKind) -> vk::IndexType {
    match kind {
        IndexKind::None => vk::IndexType::NONE_KHR,
        IndexKind::U16 => vk::IndexType::UINT16,
        IndexKind::U32 => vk::IndexType::UINT32,
    }
}

/// The shader stage of a program kind.
pub(crate) fn stage(kind: ProgramKind) -> vk::ShaderStageFlags {
    vk::ShaderStageFlags::from_raw(kind.vulkan_stage())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// raykit's flags keep bits of their own; these are the same values as Vulkan's,
    /// so a flag set maps bit for bit.
    #[test]
    fn flag_bits_equal_vulkans() {
        assert_eq!(GeometryFlags::OPAQUE.0, vk::GeometryFlagsKHR::OPAQUE.as_raw());
        assert_eq!(
            GeometryFlags::NO_DUPLICATE_ANY_HIT.0,
            vk::GeometryFlagsKHR::NO_DUPLICATE_ANY_HIT_INVOCATION.as_raw()
        );
        let all = GeometryFlags::OPAQUE | GeometryFlags::NO_DUPLICATE_ANY_HIT;
        assert_eq!(geometry_flags(all).as_raw(), all.0);
        assert_eq!(geometry_flags(GeometryFlags::NONE), vk::GeometryFlagsKHR::empty());
        type F = vk::GeometryInstanceFlagsKHR;
        for (ours, theirs) in [
            (InstanceFlags::DISABLE_TRIANGLE_CULLING, F::TRIANGLE_FACING_CULL_DISABLE),
            (InstanceFlags::FLIP_TRIANGLE_FACING, F::TRIANGLE_FLIP_FACING),
            (InstanceFlags::FORCE_OPAQUE, F::FORCE_OPAQUE),
            (InstanceFlags::FORCE_NON_OPAQUE, F::FORCE_NO_OPAQUE),
        ] {
            assert_eq!(u32::from(ours.0), theirs.as_raw());
            assert_eq!(u32::from(instance_flags(ours)), theirs.as_raw());
        }
        let every = InstanceFlags::DISABLE_TRIANGLE_CULLING
            | InstanceFlags::FLIP_TRIANGLE_FACING
            | InstanceFlags::FORCE_OPAQUE
            | InstanceFlags::FORCE_NON_OPAQUE;
        assert_eq!(instance_flags(every), every.0);
    }

    #[test]
    fn every_texture_format_has_its_vulkan_format() {
        for f in TextureFormat::ALL {
            assert_ne!(format(f), vk::Format::UNDEFINED);
        }
    }
}
