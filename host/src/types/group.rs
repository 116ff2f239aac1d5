//! The kinds of program group, as OptiX names them.

use std::fmt;

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
