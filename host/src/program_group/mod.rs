//! Program groups: OptiX's raygen, miss and hit groups, checked against the module.
//!
//! A group names entry points of a [`Module`]. Each is checked when the group is
//! made: it must exist, its SPIR-V execution model must be the group's stage, and,
//! where the name has an OptiX prefix (`__raygen__`, `__miss__`, …), the prefix
//! must agree too — modules compiled from GLSL, whose entry is `main`, load as
//! well. A group becomes a
//! [`VkRayTracingShaderGroupCreateInfoKHR`](https://registry.khronos.org/vulkan/specs/latest/man/html/VkRayTracingShaderGroupCreateInfoKHR.html)
//! when a [`crate::Pipeline`] is linked.

use std::ffi::CString;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use raykit_device::{EntryPoint, ProgramKind};

use crate::error::{DeviceError, ModuleError};
use crate::error::{Error, Result};
use crate::module::Module;
use crate::types::group::Group;
pub use crate::types::group::GroupKind;
use crate::types::program::EntryPointInfo;
use crate::vulkan::module::ModuleInner;

/// A checked program of a group (its code a SPIR-V module's entry point or a CPU program).
pub(crate) type Program = crate::types::group::Program<Arc<ModuleInner>>;
/// What a group holds.
pub(crate) type GroupPrograms = crate::types::group::GroupPrograms<Arc<ModuleInner>>;
/// Where a program's code is.
pub(crate) type ProgramCode = crate::types::group::ProgramCode<Arc<ModuleInner>>;

/// Names an entry point: a macro-generated [`EntryPoint`] constant (preferred) or
/// a name such as `"main"`.
pub trait EntryName {
    /// The entry-point name.
    fn entry_name(&self) -> &str;
    /// The kind the caller claims, if it knows it.
    fn claimed_kind(&self) -> Option<ProgramKind> {
        None
    }
    /// The ray type the program was declared for, if known.
    fn ray(&self) -> Option<raykit_device::RayTypeInfo> {
        None
    }
    /// The program compiled for the host, which the CPU backend runs (only
    /// [`EntryPoint`] constants carry it).
    fn cpu_program(&self) -> Option<&'static raykit_device::cpu::CpuProgram> {
        None
    }
}

impl EntryName for EntryPoint {
    fn entry_name(&self) -> &str {
        self.name
    }
    fn claimed_kind(&self) -> Option<ProgramKind> {
        Some(self.kind)
    }
    fn ray(&self) -> Option<raykit_device::RayTypeInfo> {
        self.ray
    }
    fn cpu_program(&self) -> Option<&'static raykit_device::cpu::CpuProgram> {
        Some(self.cpu)
    }
}
impl EntryName for &str {
    fn entry_name(&self) -> &str {
        self
    }
}
impl EntryName for String {
    fn entry_name(&self) -> &str {
        self
    }
}

impl Program {
    /// A program of the device crate `linked` on the CPU backend: only an
    /// [`EntryPoint`] constant of that crate, of the kind expected, names one.
    fn resolve_linked(
        linked: &crate::module::LinkedCrate,
        entry: &dyn EntryName,
        expected: ProgramKind,
        context: &'static str,
    ) -> Result<Program> {
        let name = entry.entry_name();
        // With the crate's SPIR-V at hand, a name is checked as on Vulkan first:
        // a missing program or one of another kind is refused alike. (A program
        // of the host build only, `#[cfg(not(target_arch = "spirv"))]`, is in no
        // SPIR-V: its constant alone names it.)
        let host_only = entry.cpu_program().is_some() && linked.reflected(name).is_none();
        if !linked.reflected.is_empty() && !host_only {
            let entries: Vec<&EntryPointInfo> = linked.reflected.iter().map(|e| &**e).collect();
            check_entry(&entries, entry, expected, context)?;
        }
        let Some(cpu) = entry.cpu_program() else {
            return Err(crate::backend::refused_on_cpu(crate::backend::CpuRefusal::NamedProgram));
        };
        if cpu.crate_name.replace('-', "_") != linked.crate_name.replace('-', "_") {
            return Err(Error::Module(ModuleError::EntryPointNotFound {
                name: format!("{name} (a program of `{}`, not of `{}`)", cpu.crate_name, linked.crate_name),
                available: Vec::new(),
            }));
        }
        let kind = entry.claimed_kind();
        if kind != Some(expected) {
            return Err(Error::Module(ModuleError::ProgramKindMismatch {
                name: name.to_owned(),
                expected,
                actual: kind.map_or_else(|| "unknown".to_owned(), |k| format!("{k} (by its EntryPoint constant)")),
                context,
                available: Vec::new(),
            }));
        }
        let name = CString::new(name).map_err(|_| {
            Error::Module(ModuleError::EntryPointNotFound { name: name.to_owned(), available: Vec::new() })
        })?;
        let reflected = linked.reflected(cpu.name);
        Ok(Program { code: ProgramCode::Cpu { program: cpu, reflected }, name, kind: expected, ray: entry.ray() })
    }

    fn resolve(
        module: &Module,
        entry: &dyn EntryName,
        expected: ProgramKind,
        context: &'static str,
    ) -> Result<Program> {
        let spirv = match &module.repr {
            crate::module::ModuleRepr::Vulkan(spirv) => spirv,
            crate::module::ModuleRepr::Cpu(linked) => return Self::resolve_linked(linked, entry, expected, context),
        };
        let name = entry.entry_name();
        let entries: Vec<&EntryPointInfo> = module.entry_points().iter().collect();
        check_entry(&entries, entry, expected, context)?;
        let name = CString::new(name).map_err(|_| {
            Error::Module(ModuleError::EntryPointNotFound { name: name.to_owned(), available: module.entry_list() })
        })?;
        Ok(Program { code: ProgramCode::Spirv(spirv.clone()), name, kind: expected, ray: entry.ray() })
    }
}

/// Checks that `entry` names an entry point of `entries` (a module's, as
/// reflected from its SPIR-V) of the `expected` kind, by its stage, its OptiX
/// prefix and the kind its `EntryPoint` constant claims; `context` is the call
/// that asked, for the message.
fn check_entry(
    entries: &[&EntryPointInfo],
    entry: &dyn EntryName,
    expected: ProgramKind,
    context: &'static str,
) -> Result<()> {
    let name = entry.entry_name();
    let available: Vec<(String, Option<ProgramKind>)> = entries.iter().map(|e| (e.name.clone(), e.kind)).collect();
    let mismatch = |actual: String| {
        Error::Module(ModuleError::ProgramKindMismatch {
            name: name.to_owned(),
            expected,
            actual,
            context,
            available: available.clone(),
        })
    };
    let Some(info) = entries.iter().find(|e| e.name == name) else {
        return Err(Error::Module(ModuleError::EntryPointNotFound { name: name.to_owned(), available }));
    };
    match info.kind {
        Some(kind) if kind == expected => {}
        // Exception programs run as callables.
        Some(ProgramKind::Callable) if expected == ProgramKind::Exception => {}
        Some(kind) => return Err(mismatch(kind.to_string())),
        None => return Err(mismatch(format!("{} (not ray tracing)", info.execution_model))),
    }
    if let Some(kind) = ProgramKind::from_prefixed_name(name) {
        if kind != expected {
            return Err(mismatch(format!("{kind} (by its `{}` prefix)", kind.prefixes()[0])));
        }
    }
    if let Some(kind) = entry.claimed_kind() {
        if kind != expected {
            return Err(mismatch(format!("{kind} (by its EntryPoint constant)")));
        }
    }
    Ok(())
}

/// A program group: a raygen, a miss, or a hit group (closest-hit, any-hit,
/// intersection), ready to be linked into a [`crate::Pipeline`].
#[derive(Clone)]
#[doc(alias("OptixProgramGroup", "OptixProgramGroupDesc", "optixProgramGroupCreate"))]
pub struct ProgramGroup {
    pub(crate) ctx: crate::Context,
    /// Its programs, as the backends read them.
    pub(crate) group: Group<Arc<ModuleInner>>,
}

static NEXT_GROUP_ID: AtomicU64 = AtomicU64::new(1);

impl ProgramGroup {
    fn from_programs(module: &Module, programs: GroupPrograms) -> ProgramGroup {
        let group = Group { id: NEXT_GROUP_ID.fetch_add(1, Ordering::Relaxed), programs };
        ProgramGroup { ctx: module.context(), group }
    }

    /// A raygen group from `entry` of `module`.
    #[doc(alias("optixProgramGroupCreate", "OPTIX_PROGRAM_GROUP_KIND_RAYGEN"))]
    pub fn raygen(module: &Module, entry: impl EntryName) -> Result<ProgramGroup> {
        let program = Program::resolve(module, &entry, ProgramKind::Raygen, "ProgramGroup::raygen")?;
        Ok(Self::from_programs(module, GroupPrograms::Raygen(program)))
    }

    /// A miss group from `entry` of `module`.
    #[doc(alias("optixProgramGroupCreate", "OPTIX_PROGRAM_GROUP_KIND_MISS"))]
    pub fn miss(module: &Module, entry: impl EntryName) -> Result<ProgramGroup> {
        let program = Program::resolve(module, &entry, ProgramKind::Miss, "ProgramGroup::miss")?;
        Ok(Self::from_programs(module, GroupPrograms::Miss(program)))
    }

    /// A callable group from `entry` of `module` (a `__direct_callable__` or
    /// `__continuation_callable__` program, or a GLSL `callableEXT` shader).
    #[doc(alias("optixProgramGroupCreate", "OPTIX_PROGRAM_GROUP_KIND_CALLABLES"))]
    pub fn callable(module: &Module, entry: impl EntryName) -> Result<ProgramGroup> {
        let program = Program::resolve(module, &entry, ProgramKind::Callable, "ProgramGroup::callable")?;
        Ok(Self::from_programs(module, GroupPrograms::Callable(program)))
    }

    /// The pipeline's exception program (`__exception__`, OptiX's exception
    /// program group): run after a device program throws a user exception. raykit
    /// places its record at the end of the SBT's callable region.
    #[doc(alias("optixProgramGroupCreate", "OPTIX_PROGRAM_GROUP_KIND_EXCEPTION"))]
    pub fn exception(module: &Module, entry: impl EntryName) -> Result<ProgramGroup> {
        let program = Program::resolve(module, &entry, ProgramKind::Exception, "ProgramGroup::exception")?;
        Ok(Self::from_programs(module, GroupPrograms::Exception(program)))
    }

    /// Starts a hit group whose programs come from `module`. A hit group may have
    /// no program at all (as in Vulkan and OptiX): a ray type that only asks
    /// whether something was hit (a shadow ray that misses to report "visible")
    /// needs no closest-hit program, and its hits then run nothing.
    #[doc(alias("optixProgramGroupCreate", "OPTIX_PROGRAM_GROUP_KIND_HITGROUP"))]
    pub fn hit_group(module: &Module) -> HitGroupBuilder<'_> {
        HitGroupBuilder { module, closest_hit: None, any_hit: None, intersection: None, error: None }
    }

    /// The group's kind.
    pub fn kind(&self) -> GroupKind {
        self.group.programs.kind()
    }

    /// The programs of this group.
    pub(crate) fn programs(&self) -> Vec<&Program> {
        self.group.programs()
    }

    /// The backends' halves of `groups`, once each was checked to be of `ctx`.
    pub(crate) fn of_context<'g>(
        ctx: &crate::Context,
        groups: &[&'g ProgramGroup],
    ) -> Result<Vec<&'g Group<Arc<ModuleInner>>>> {
        if groups.iter().any(|g| !g.ctx.is_same(ctx)) {
            return Err(Error::Device(DeviceError::ContextMismatch));
        }
        Ok(groups.iter().map(|g| &g.group).collect())
    }
}

impl fmt::Debug for ProgramGroup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&self.group, f)
    }
}

/// Builds a hit group; each program is checked as it is added.
#[must_use]
#[derive(Debug)]
pub struct HitGroupBuilder<'m> {
    module: &'m Module,
    closest_hit: Option<Program>,
    any_hit: Option<Program>,
    intersection: Option<Program>,
    error: Option<Error>,
}

impl HitGroupBuilder<'_> {
    fn add(mut self, entry: &dyn EntryName, kind: ProgramKind, context: &'static str) -> Self {
        if self.error.is_some() {
            return self;
        }
        match Program::resolve(self.module, entry, kind, context) {
            Ok(p) => match kind {
                ProgramKind::ClosestHit => self.closest_hit = Some(p),
                ProgramKind::AnyHit => self.any_hit = Some(p),
                _ => self.intersection = Some(p),
            },
            Err(e) => self.error = Some(e),
        }
        self
    }

    /// The closest-hit program.
    pub fn closest_hit(self, entry: impl EntryName) -> Self {
        self.add(&entry, ProgramKind::ClosestHit, "HitGroupBuilder::closest_hit")
    }

    /// The any-hit program.
    pub fn any_hit(self, entry: impl EntryName) -> Self {
        self.add(&entry, ProgramKind::AnyHit, "HitGroupBuilder::any_hit")
    }

    /// The intersection program (makes this a procedural hit group).
    pub fn intersection(self, entry: impl EntryName) -> Self {
        self.add(&entry, ProgramKind::Intersection, "HitGroupBuilder::intersection")
    }

    /// Finishes the group.
    pub fn build(self) -> Result<ProgramGroup> {
        if let Some(e) = self.error {
            return Err(e);
        }
        Ok(ProgramGroup::from_programs(
            self.module,
            GroupPrograms::Hit {
                closest_hit: self.closest_hit,
                any_hit: self.any_hit,
                intersection: self.intersection,
            },
        ))
    }
}
