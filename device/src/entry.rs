//! Entry points: the names and stages the macros give to device programs.
//!
//! Each `#[raygen] fn rg` emits, beside the SPIR-V entry point `__raygen__rg`, a
//! constant `RG: EntryPoint` that the host uses to refer to the program, so host
//! and device are never coupled by a hand-written string.

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
    pub const fn prefixes(self) -> &'static [&'static str] {
        match self {
            ProgramKind::Raygen => &["__raygen__"],
            ProgramKind::Miss => &["__miss__"],
            ProgramKind::ClosestHit => &["__closesthit__"],
            ProgramKind::AnyHit => &["__anyhit__"],
            ProgramKind::Intersection => &["__intersection__"],
            ProgramKind::Callable => &["__direct_callable__", "__continuation_callable__"],
            ProgramKind::Exception => &["__exception__"],
        }
    }

    /// The kind whose OptiX prefix `name` starts with, if any.
    pub fn from_prefixed_name(name: &str) -> Option<ProgramKind> {
        Self::ALL.into_iter().find(|kind| kind.prefixes().iter().any(|p| name.starts_with(p)))
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
}

impl core::fmt::Display for ProgramKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// A device program as the host refers to it: its SPIR-V entry-point name and kind.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub struct EntryPoint {
    /// The SPIR-V entry-point name, e.g. `__raygen__rg`.
    pub name: &'static str,
    /// The program kind, matching the name's prefix.
    pub kind: ProgramKind,
}
