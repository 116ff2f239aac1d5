//! Entry points: the names and stages the macros give to device programs.
//!
//! Each `#[raygen] fn rg` emits, beside the SPIR-V entry point `__raygen__rg`, a
//! constant `RG: EntryPoint` that the host uses to refer to the program, so host
//! and device are never coupled by a hand-written string.

pub use raykit_abi::{ProgramKind, ProgramPrefix};

/// A device program as the host refers to it: its SPIR-V entry-point name and
/// kind, and, on the host, the program compiled for the CPU backend. Two entry
/// points are equal when their names, kinds and ray types are.
#[derive(Copy, Clone, Debug)]
pub struct EntryPoint {
    /// The SPIR-V entry-point name, e.g. `__raygen__rg`.
    pub name: &'static str,
    /// The program kind, matching the name's prefix.
    pub kind: ProgramKind,
    /// The ray type a miss, closest-hit or any-hit program was declared for
    /// (`#[miss(ray = R)]`), so the host can place its group where `trace::<R>`
    /// looks; `None` for other programs and when no ray type was named.
    pub ray: Option<RayTypeInfo>,
    /// The program compiled for the host, which raykit's CPU backend runs.
    #[cfg(not(target_arch = "spirv"))]
    pub cpu: &'static crate::cpu::CpuProgram,
}

impl PartialEq for EntryPoint {
    fn eq(&self, other: &Self) -> bool {
        (self.name, self.kind, self.ray) == (other.name, other.kind, other.ray)
    }
}
impl Eq for EntryPoint {}
impl core::hash::Hash for EntryPoint {
    fn hash<H: core::hash::Hasher>(&self, state: &mut H) {
        (self.name, self.kind, self.ray).hash(state)
    }
}

/// What the SBT needs to know of a ray type: its name and where `trace::<R>`
/// looks for its records.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct RayTypeInfo {
    /// The type's name, as written in the program's attribute.
    pub name: &'static str,
    /// [`RayType::SBT_OFFSET`](crate::RayType::SBT_OFFSET).
    pub sbt_offset: u32,
    /// [`RayType::SBT_STRIDE`](crate::RayType::SBT_STRIDE).
    pub sbt_stride: u32,
    /// [`RayType::MISS_INDEX`](crate::RayType::MISS_INDEX).
    pub miss_index: u32,
}

impl RayTypeInfo {
    /// The SBT placement of ray type `R`, named `name`.
    pub const fn of<R: crate::RayType>(name: &'static str) -> RayTypeInfo {
        RayTypeInfo { name, sbt_offset: R::SBT_OFFSET, sbt_stride: R::SBT_STRIDE, miss_index: R::MISS_INDEX }
    }

    /// Whether `R` selects the same records (its SBT offset, stride and miss index agree).
    pub const fn places_like<R: crate::RayType>(&self) -> bool {
        self.sbt_offset == R::SBT_OFFSET && self.sbt_stride == R::SBT_STRIDE && self.miss_index == R::MISS_INDEX
    }
}
