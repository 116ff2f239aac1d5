//! The kinds of program group, as OptiX names them.

use std::ffi::CString;
use std::fmt;

use raykit_device::{ProgramKind, RayTypeInfo};

use crate::types::program::EntryPointInfo;

/// What a [`ProgramGroup`](crate::ProgramGroup) is: OptiX's `OptixProgramGroupKind`.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum GroupKind {
    /// A raygen group ([`ProgramGroup::raygen`](crate::ProgramGroup::raygen)).
    Raygen,
    /// A miss group ([`ProgramGroup::miss`](crate::ProgramGroup::miss)).
    Miss,
    /// A hit group: closest-hit, any-hit and intersection programs
    /// ([`ProgramGroup::hit_group`](crate::ProgramGroup::hit_group)).
    Hit,
    /// A callable group ([`ProgramGroup::callable`](crate::ProgramGroup::callable)).
    Callable,
    /// The exception group ([`ProgramGroup::exception`](crate::ProgramGroup::exception)), a
    /// callable raykit places in the SBT itself.
    Exception,
}

impl GroupKind {
    /// Every kind, in a fixed order.
    pub const ALL: [GroupKind; 5] =
        [GroupKind::Raygen, GroupKind::Miss, GroupKind::Hit, GroupKind::Callable, GroupKind::Exception];

    /// Its lower-case name, as errors print it: `"raygen"`, `"miss"`, `"hit"`,
    /// `"callable"` or `"exception"`.
    pub const fn name(self) -> &'static str {
        match self {
            GroupKind::Raygen => "raygen",
            GroupKind::Miss => "miss",
            GroupKind::Hit => "hit",
            GroupKind::Callable => "callable",
            GroupKind::Exception => "exception",
        }
    }
}

impl fmt::Display for GroupKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::GroupKind;

    #[test]
    fn kinds_print_their_lower_case_names() {
        let names: Vec<String> = GroupKind::ALL.iter().map(|k| k.to_string()).collect();
        assert_eq!(names, ["raygen", "miss", "hit", "callable", "exception"]);
    }
}

/// A SPIR-V module as the checks of groups read it; the backend that made it says
/// what it holds.
pub(crate) trait SpirvCode: Clone {
    /// What reflection found of its entry points.
    fn entry_points(&self) -> &[EntryPointInfo];
    /// Its SPIR-V.
    fn words(&self) -> &[u32];
    /// The module's identity, for visiting each module once.
    fn identity(&self) -> *const ();
}

/// Where a program's code is: in a SPIR-V module `S` (Vulkan's), or in a device
/// crate linked into the program (the CPU backend).
#[derive(Clone)]
pub(crate) enum ProgramCode<S> {
    /// An entry point of a SPIR-V module.
    Spirv(S),
    /// A program of a device crate linked into the program (the CPU backend),
    /// with what reflection found of its entry point in the crate's SPIR-V, when
    /// that was at hand: the checks then know what it traces and calls, as they
    /// do on Vulkan.
    Cpu { program: &'static raykit_device::cpu::CpuProgram, reflected: Option<std::sync::Arc<EntryPointInfo>> },
}

/// One checked entry point inside a group.
#[derive(Clone)]
pub(crate) struct Program<S> {
    pub(crate) code: ProgramCode<S>,
    pub(crate) name: CString,
    pub(crate) kind: ProgramKind,
    /// The ray type it was declared for (from its `EntryPoint` constant).
    pub(crate) ray: Option<RayTypeInfo>,
}

impl<S: SpirvCode> Program<S> {
    /// What reflection found for this program's entry point: in its module, or
    /// for a CPU program in its crate's SPIR-V (`None` when there was none).
    pub(crate) fn entry_info(&self) -> Option<&EntryPointInfo> {
        match &self.code {
            ProgramCode::Spirv(module) => {
                let name = self.name.to_str().ok()?;
                module.entry_points().iter().find(|e| e.name == name)
            }
            ProgramCode::Cpu { reflected, .. } => reflected.as_deref(),
        }
    }

    /// Its SPIR-V module (`None` for a CPU program).
    pub(crate) fn module(&self) -> Option<&S> {
        match &self.code {
            ProgramCode::Spirv(module) => Some(module),
            ProgramCode::Cpu { .. } => None,
        }
    }
}

/// A program as `Debug` shows it: its entry-point name.
impl<S> fmt::Debug for Program<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.name, f)
    }
}

/// What a group holds.
#[derive(Clone)]
pub(crate) enum GroupPrograms<S> {
    Raygen(Program<S>),
    Miss(Program<S>),
    Callable(Program<S>),
    /// An `#[exception]` program: a callable raykit places in the SBT itself.
    Exception(Program<S>),
    Hit {
        closest_hit: Option<Program<S>>,
        any_hit: Option<Program<S>>,
        intersection: Option<Program<S>>,
    },
}

impl<S> GroupPrograms<S> {
    /// The kind of group holding these programs.
    pub(crate) fn kind(&self) -> GroupKind {
        match self {
            GroupPrograms::Raygen(_) => GroupKind::Raygen,
            GroupPrograms::Miss(_) => GroupKind::Miss,
            GroupPrograms::Callable(_) => GroupKind::Callable,
            GroupPrograms::Exception(_) => GroupKind::Exception,
            GroupPrograms::Hit { .. } => GroupKind::Hit,
        }
    }
}

/// A program group as a backend links it: its id (which the pipeline keeps to
/// find it again) and its programs.
#[derive(Clone)]
pub(crate) struct Group<S> {
    pub(crate) id: u64,
    pub(crate) programs: GroupPrograms<S>,
}

impl<S> Group<S> {
    /// Its kind.
    pub(crate) fn kind(&self) -> GroupKind {
        self.programs.kind()
    }

    /// Its programs.
    pub(crate) fn programs(&self) -> Vec<&Program<S>> {
        match &self.programs {
            GroupPrograms::Raygen(p)
            | GroupPrograms::Miss(p)
            | GroupPrograms::Callable(p)
            | GroupPrograms::Exception(p) => {
                vec![p]
            }
            GroupPrograms::Hit { closest_hit, any_hit, intersection } => {
                [closest_hit, any_hit, intersection].into_iter().flatten().collect()
            }
        }
    }
}

impl<S> fmt::Debug for Group<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut s = f.debug_struct("ProgramGroup");
        s.field("kind", &self.kind());
        match &self.programs {
            GroupPrograms::Raygen(p)
            | GroupPrograms::Miss(p)
            | GroupPrograms::Callable(p)
            | GroupPrograms::Exception(p) => s.field("program", p),
            GroupPrograms::Hit { closest_hit, any_hit, intersection } => {
                s.field("closest_hit", closest_hit).field("any_hit", any_hit).field("intersection", intersection)
            }
        };
        s.finish()
    }
}
