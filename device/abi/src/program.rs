//! Program kinds: one table from an OptiX program kind to its name prefix, its
//! Vulkan shader stage, its SPIR-V execution model and its role in a shader group.

/// An OptiX name prefix, as written before a program's name in its SPIR-V
/// entry point (`__raygen__rg`). Direct and continuation callables have
/// prefixes of their own and share the callable kind.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum ProgramPrefix {
    /// `__raygen__`.
    Raygen,
    /// `__miss__`.
    Miss,
    /// `__closesthit__`.
    ClosestHit,
    /// `__anyhit__`.
    AnyHit,
    /// `__intersection__`.
    Intersection,
    /// `__direct_callable__`.
    DirectCallable,
    /// `__continuation_callable__`.
    ContinuationCallable,
    /// `__exception__`.
    Exception,
}

impl ProgramPrefix {
    /// Every prefix, in a fixed order.
    pub const ALL: [ProgramPrefix; 8] = [
        ProgramPrefix::Raygen,
        ProgramPrefix::Miss,
        ProgramPrefix::ClosestHit,
        ProgramPrefix::AnyHit,
        ProgramPrefix::Intersection,
        ProgramPrefix::DirectCallable,
        ProgramPrefix::ContinuationCallable,
        ProgramPrefix::Exception,
    ];

    /// The prefix itself, e.g. `"__raygen__"`.
    pub const fn as_str(self) -> &'static str {
        match self {
            ProgramPrefix::Raygen => "__raygen__",
            ProgramPrefix::Miss => "__miss__",
            ProgramPrefix::ClosestHit => "__closesthit__",
            ProgramPrefix::AnyHit => "__anyhit__",
            ProgramPrefix::Intersection => "__intersection__",
            ProgramPrefix::DirectCallable => "__direct_callable__",
            ProgramPrefix::ContinuationCallable => "__continuation_callable__",
            ProgramPrefix::Exception => "__exception__",
        }
    }

    /// The kind of program the prefix names.
    pub const fn kind(self) -> ProgramKind {
        match self {
            ProgramPrefix::Raygen => ProgramKind::Raygen,
            ProgramPrefix::Miss => ProgramKind::Miss,
            ProgramPrefix::ClosestHit => ProgramKind::ClosestHit,
            ProgramPrefix::AnyHit => ProgramKind::AnyHit,
            ProgramPrefix::Intersection => ProgramKind::Intersection,
            ProgramPrefix::DirectCallable | ProgramPrefix::ContinuationCallable => ProgramKind::Callable,
            ProgramPrefix::Exception => ProgramKind::Exception,
        }
    }

    /// The prefix `name` starts with, if any.
    pub fn of(name: &str) -> Option<ProgramPrefix> {
        Self::ALL.into_iter().find(|p| name.starts_with(p.as_str()))
    }

    /// The prefix the bytes `name` start with, if any (for names read from SPIR-V words).
    pub fn of_bytes(name: &[u8]) -> Option<ProgramPrefix> {
        Self::ALL.into_iter().find(|p| name.starts_with(p.as_str().as_bytes()))
    }
}

impl core::fmt::Display for ProgramPrefix {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// The kind of an OptiX program, and so the Vulkan shader stage it runs in.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum ProgramKind {
    /// `__raygen__`: `RayGenerationKHR`.
    Raygen,
    /// `__miss__`: `MissKHR`.
    Miss,
    /// `__closesthit__`: `ClosestHitKHR`.
    ClosestHit,
    /// `__anyhit__`: `AnyHitKHR`.
    AnyHit,
    /// `__intersection__`: `IntersectionKHR`.
    Intersection,
    /// `__direct_callable__` and `__continuation_callable__`: `CallableKHR`.
    Callable,
    /// `__exception__`: run by raykit as a `CallableKHR` after a user exception.
    Exception,
}

impl ProgramKind {
    /// Every kind, in a fixed order.
    pub const ALL: [ProgramKind; 7] = [
        ProgramKind::Raygen,
        ProgramKind::Miss,
        ProgramKind::ClosestHit,
        ProgramKind::AnyHit,
        ProgramKind::Intersection,
        ProgramKind::Callable,
        ProgramKind::Exception,
    ];

    /// The OptiX name prefixes of this kind.
    pub const fn prefixes(self) -> &'static [ProgramPrefix] {
        match self {
            ProgramKind::Raygen => &[ProgramPrefix::Raygen],
            ProgramKind::Miss => &[ProgramPrefix::Miss],
            ProgramKind::ClosestHit => &[ProgramPrefix::ClosestHit],
            ProgramKind::AnyHit => &[ProgramPrefix::AnyHit],
            ProgramKind::Intersection => &[ProgramPrefix::Intersection],
            ProgramKind::Callable => &[ProgramPrefix::DirectCallable, ProgramPrefix::ContinuationCallable],
            ProgramKind::Exception => &[ProgramPrefix::Exception],
        }
    }

    /// The kind whose OptiX prefix `name` starts with, if any.
    pub fn from_prefixed_name(name: &str) -> Option<ProgramKind> {
        ProgramPrefix::of(name).map(ProgramPrefix::kind)
    }

    /// A short human name: "raygen", "miss", "closest-hit", …
    pub const fn name(self) -> &'static str {
        match self {
            ProgramKind::Raygen => "raygen",
            ProgramKind::Miss => "miss",
            ProgramKind::ClosestHit => "closest-hit",
            ProgramKind::AnyHit => "any-hit",
            ProgramKind::Intersection => "intersection",
            ProgramKind::Callable => "callable",
            ProgramKind::Exception => "exception",
        }
    }

    /// The SPIR-V execution model of its entry point (an exception program is a callable).
    pub const fn execution_model(self) -> ExecutionModel {
        match self {
            ProgramKind::Raygen => ExecutionModel::RayGeneration,
            ProgramKind::Miss => ExecutionModel::Miss,
            ProgramKind::ClosestHit => ExecutionModel::ClosestHit,
            ProgramKind::AnyHit => ExecutionModel::AnyHit,
            ProgramKind::Intersection => ExecutionModel::Intersection,
            ProgramKind::Callable | ProgramKind::Exception => ExecutionModel::Callable,
        }
    }

    /// The Vulkan shader stage it runs in, as a raw `VkShaderStageFlagBits` value.
    pub const fn vulkan_stage(self) -> u32 {
        self.execution_model().vulkan_stage()
    }

    /// Which shader of a `VkRayTracingShaderGroupCreateInfoKHR` it fills.
    pub const fn group_role(self) -> GroupRole {
        match self {
            ProgramKind::Raygen | ProgramKind::Miss | ProgramKind::Callable | ProgramKind::Exception => {
                GroupRole::General
            }
            ProgramKind::ClosestHit => GroupRole::ClosestHit,
            ProgramKind::AnyHit => GroupRole::AnyHit,
            ProgramKind::Intersection => GroupRole::Intersection,
        }
    }
}

impl core::fmt::Display for ProgramKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// The SPIR-V execution models of ray-tracing entry points (`SPV_KHR_ray_tracing`),
/// with their numbers in the SPIR-V specification.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum ExecutionModel {
    /// `RayGenerationKHR`.
    RayGeneration = 5313,
    /// `IntersectionKHR`.
    Intersection = 5314,
    /// `AnyHitKHR`.
    AnyHit = 5315,
    /// `ClosestHitKHR`.
    ClosestHit = 5316,
    /// `MissKHR`.
    Miss = 5317,
    /// `CallableKHR`.
    Callable = 5318,
}

impl ExecutionModel {
    /// Every ray-tracing execution model.
    pub const ALL: [ExecutionModel; 6] = [
        ExecutionModel::RayGeneration,
        ExecutionModel::Intersection,
        ExecutionModel::AnyHit,
        ExecutionModel::ClosestHit,
        ExecutionModel::Miss,
        ExecutionModel::Callable,
    ];

    /// Its number in SPIR-V.
    pub const fn to_u32(self) -> u32 {
        self as u32
    }

    /// The ray-tracing execution model numbered `word`, if it is one.
    pub fn from_u32(word: u32) -> Option<ExecutionModel> {
        Self::ALL.into_iter().find(|m| m.to_u32() == word)
    }

    /// The program kind of an entry point with this model (a callable, for
    /// `Callable`: whether it is an exception program is told by its name).
    pub const fn kind(self) -> ProgramKind {
        match self {
            ExecutionModel::RayGeneration => ProgramKind::Raygen,
            ExecutionModel::Intersection => ProgramKind::Intersection,
            ExecutionModel::AnyHit => ProgramKind::AnyHit,
            ExecutionModel::ClosestHit => ProgramKind::ClosestHit,
            ExecutionModel::Miss => ProgramKind::Miss,
            ExecutionModel::Callable => ProgramKind::Callable,
        }
    }

    /// The raw `VkShaderStageFlagBits` of the stage (`VK_SHADER_STAGE_RAYGEN_BIT_KHR` = 0x100, …).
    pub const fn vulkan_stage(self) -> u32 {
        match self {
            ExecutionModel::RayGeneration => 0x0000_0100,
            ExecutionModel::AnyHit => 0x0000_0200,
            ExecutionModel::ClosestHit => 0x0000_0400,
            ExecutionModel::Miss => 0x0000_0800,
            ExecutionModel::Intersection => 0x0000_1000,
            ExecutionModel::Callable => 0x0000_2000,
        }
    }

    /// rust-gpu's name for it in `#[spirv(...)]` (`ray_generation`, `closest_hit`, …).
    pub const fn rust_gpu_attribute(self) -> &'static str {
        match self {
            ExecutionModel::RayGeneration => "ray_generation",
            ExecutionModel::Intersection => "intersection",
            ExecutionModel::AnyHit => "any_hit",
            ExecutionModel::ClosestHit => "closest_hit",
            ExecutionModel::Miss => "miss",
            ExecutionModel::Callable => "callable",
        }
    }
}

/// Which shader of a `VkRayTracingShaderGroupCreateInfoKHR` a program fills.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum GroupRole {
    /// `generalShader`: raygen, miss, callable (and exception) groups.
    General,
    /// `closestHitShader` of a hit group.
    ClosestHit,
    /// `anyHitShader` of a hit group.
    AnyHit,
    /// `intersectionShader` of a procedural hit group.
    Intersection,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_prefix_names_its_kind_back() {
        for prefix in ProgramPrefix::ALL {
            assert!(prefix.kind().prefixes().contains(&prefix));
            assert_eq!(ProgramPrefix::of(prefix.as_str()), Some(prefix));
        }
        for kind in ProgramKind::ALL {
            for prefix in kind.prefixes() {
                assert_eq!(prefix.kind(), kind);
            }
        }
    }

    #[test]
    fn execution_models_round_trip() {
        for model in ExecutionModel::ALL {
            assert_eq!(ExecutionModel::from_u32(model.to_u32()), Some(model));
            assert_eq!(model.kind().execution_model(), model);
        }
        assert_eq!(ExecutionModel::from_u32(0), None);
    }
}
