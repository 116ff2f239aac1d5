//! Modules: SPIR-V loaded onto the device and reflected, like OptiX's
//! `OptixModule` made from PTX.
//!
//! A [`Module`] is made from SPIR-V bytes or a `.spv` file (what
//! `cargo xtask build-shaders` writes). raykit reads the module with rspirv (naga's
//! SPIR-V reader rejects the ray-tracing stages) and lists its entry points with
//! their stages, so program groups can be checked before Vulkan sees them. WGSL
//! source becomes a module through naga with `Module::from_wgsl` (feature `wgsl`, see `raykit::wgsl`). See
//! [`vkCreateShaderModule`](https://registry.khronos.org/vulkan/specs/latest/man/html/vkCreateShaderModule.html).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use raykit_abi::ProgramPrefix;
use raykit_device::ProgramKind;
use rspirv::spirv::{Op, MAGIC_NUMBER as SPIRV_MAGIC};

use crate::context::{Context, ContextRepr};
use crate::error::ModuleError;
use crate::error::{Error, Result};
use crate::types::program::kind_of;
pub use crate::types::program::EntryPointInfo;
use crate::vulkan::module::ModuleInner;

/// A SPIR-V module on the device, with its entry points; on the CPU backend,
/// the device crate linked into the program, whose programs the
/// [`EntryPoint`](raykit_device::EntryPoint) constants carry.
#[derive(Clone)]
#[doc(alias("OptixModule"))]
pub struct Module {
    pub(crate) repr: ModuleRepr,
}

/// What a [`Module`] is underneath.
#[derive(Clone)]
pub(crate) enum ModuleRepr {
    /// SPIR-V on a Vulkan device.
    Vulkan(Arc<ModuleInner>),
    /// A device crate linked into the program (the CPU backend).
    Cpu(LinkedCrate),
}

/// A device crate linked into the program, for the CPU backend.
#[derive(Clone)]
pub(crate) struct LinkedCrate {
    pub(crate) ctx: Arc<crate::cpu::CpuContext>,
    /// Its package name (`CARGO_PKG_NAME`), which its programs carry.
    pub(crate) crate_name: String,
    /// The entry points of the crate's SPIR-V, when it was at hand (embedded,
    /// or where [`spirv_path`] finds it): what the checks read of each program's
    /// traces and calls, as on Vulkan. Empty when there was none.
    pub(crate) reflected: Vec<Arc<EntryPointInfo>>,
}

impl LinkedCrate {
    /// What reflection found of entry point `name` in the crate's SPIR-V.
    pub(crate) fn reflected(&self, name: &str) -> Option<Arc<EntryPointInfo>> {
        self.reflected.iter().find(|e| e.name == name).cloned()
    }
}

impl Module {
    /// The SPIR-V module, when this is one.
    pub(crate) fn spirv(&self) -> Option<&Arc<ModuleInner>> {
        match &self.repr {
            ModuleRepr::Vulkan(inner) => Some(inner),
            ModuleRepr::Cpu(_) => None,
        }
    }

    /// The context the module was made on.
    pub(crate) fn context(&self) -> Context {
        match &self.repr {
            ModuleRepr::Vulkan(inner) => Context::from_vulkan(inner.ctx.clone()),
            ModuleRepr::Cpu(linked) => Context::from_cpu(linked.ctx.clone()),
        }
    }

    /// A module of the device crate `crate_name` linked into the program, with
    /// the entry points of its SPIR-V `spirv` when there is some.
    fn linked(ctx: &Arc<crate::cpu::CpuContext>, crate_name: &str, spirv: Option<&[u8]>) -> Result<Module> {
        let reflected = match spirv {
            Some(bytes) => reflect_entry_points(bytes)?.into_iter().map(Arc::new).collect(),
            None => Vec::new(),
        };
        let linked = LinkedCrate { ctx: ctx.clone(), crate_name: crate_name.to_owned(), reflected };
        Ok(Module { repr: ModuleRepr::Cpu(linked) })
    }
}

/// The error for SPIR-V given to the CPU backend.
fn spirv_on_cpu() -> Error {
    crate::backend::refused_on_cpu(crate::backend::CpuRefusal::SpirvModule)
}

/// The opcode of an instruction, from its first word (`None` for opcodes rspirv does not know).
fn opcode(first_word: u32) -> Option<Op> {
    Op::from_u32(first_word & 0xffff)
}

/// The largest ID bound Vulkan drivers accept (SPIR-V's universal limit, as SPIRV-Tools checks it).
pub const MAX_ID_BOUND: u32 = (1 << 22) - 1;

/// Turns bytes into SPIR-V words, checking size and magic number.
pub(crate) fn words_of(bytes: &[u8]) -> Result<Vec<u32>> {
    if bytes.len() < 20 {
        return Err(Error::Module(ModuleError::InvalidSpirv {
            reason: format!("{} bytes is shorter than a SPIR-V header (20 bytes)", bytes.len()),
        }));
    }
    if !bytes.len().is_multiple_of(4) {
        return Err(Error::Module(ModuleError::InvalidSpirv {
            reason: format!("{} bytes is not a whole number of 32-bit words", bytes.len()),
        }));
    }
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    if words[0] != SPIRV_MAGIC {
        return Err(Error::Module(ModuleError::InvalidSpirv {
            reason: format!("magic number {:#010x}, expected {SPIRV_MAGIC:#010x}", words[0]),
        }));
    }
    Ok(words)
}

/// Checks the module's structure before anything else reads it: instructions that
/// fit in the module, the ID bound, functions that are closed, and entry points
/// that name defined functions. This catches truncated and many corrupted modules,
/// which a driver must never see. (It is not a full validator: that is spirv-val.)
fn check_structure(words: &[u32]) -> Result<()> {
    let invalid = |reason: String| Err(Error::Module(ModuleError::InvalidSpirv { reason }));
    let version = words[1];
    if !(0x0001_0000..=0x0001_0600).contains(&version) || version & 0xff != 0 {
        return invalid(format!("unknown SPIR-V version word {version:#010x}"));
    }
    let bound = words[3];
    if bound == 0 || bound > MAX_ID_BOUND {
        return invalid(format!("ID bound {bound} is out of range 1..={MAX_ID_BOUND} (SPIR-V's universal limit)"));
    }
    let mut functions = std::collections::HashSet::new();
    let mut entry_functions = Vec::new();
    let mut open_function: Option<usize> = None;
    let mut at = 5;
    while at < words.len() {
        let word_count = (words[at] >> 16) as usize;
        let raw_opcode = words[at] & 0xffff;
        if word_count == 0 || at + word_count > words.len() {
            return invalid(format!(
                "instruction at word {at} (opcode {raw_opcode}) claims {word_count} words but the module ends at word {} — truncated?",
                words.len()
            ));
        }
        let operand = |i: usize| if i < word_count { Some(words[at + i]) } else { None };
        match opcode(words[at]) {
            Some(Op::EntryPoint) => match operand(2) {
                Some(id) => entry_functions.push(id),
                None => return invalid(format!("OpEntryPoint at word {at} is too short")),
            },
            Some(Op::Function) => {
                if open_function.is_some() {
                    return invalid(format!("OpFunction at word {at} inside another function"));
                }
                match operand(2) {
                    Some(id) if id < bound => {
                        functions.insert(id);
                    }
                    _ => return invalid(format!("OpFunction at word {at} has no valid result id")),
                }
                open_function = Some(at);
            }
            Some(Op::FunctionEnd) if open_function.take().is_none() => {
                return invalid(format!("OpFunctionEnd at word {at} without OpFunction"));
            }
            _ => {}
        }
        at += word_count;
    }
    if let Some(start) = open_function {
        return invalid(format!("the function starting at word {start} is never closed — truncated module?"));
    }
    if let Some(id) = entry_functions.iter().find(|id| !functions.contains(id)) {
        return invalid(format!(
            "an entry point names function %{id}, which the module does not define — truncated module?"
        ));
    }
    Ok(())
}

/// Parses a structurally checked module with rspirv (whose panics on malformed
/// operands become errors).
fn parse(words: &[u32]) -> Result<rspirv::dr::Module> {
    check_structure(words)?;
    let module = raykit_spirv::parse(&reflection_words(words)?)?;
    check_ids(&module, words[3])?;
    Ok(module)
}

/// Whether a structurally checked module declares `OpExtension name`.
fn declares_extension(words: &[u32], name: &str) -> bool {
    let mut at = 5;
    while let Some(&first) = words.get(at) {
        let word_count = (first >> 16) as usize;
        if opcode(first) == Some(Op::Extension) {
            let bytes: Vec<u8> =
                words.get(at + 1..at + word_count).unwrap_or(&[]).iter().flat_map(|w| w.to_le_bytes()).collect();
            if bytes.split(|&b| b == 0).next() == Some(name.as_bytes()) {
                return true;
            }
        }
        at += word_count.max(1);
    }
    false
}

/// Whether a structurally checked module decorates a specialization constant with
/// `OpDecorate %id SpecId spec_id`.
fn declares_spec_id(words: &[u32], spec_id: u32) -> bool {
    const SPEC_ID: u32 = 1; // spv::Decoration::SpecId
    let mut at = 5;
    while let Some(&first) = words.get(at) {
        let word_count = (first >> 16) as usize;
        if opcode(first) == Some(Op::Decorate)
            && word_count == 4
            && words.get(at + 2..at + 4) == Some(&[SPEC_ID, spec_id])
        {
            return true;
        }
        at += word_count.max(1);
    }
    false
}

/// The words of a structurally checked module that rspirv reads, and the checks
/// that keep its parser from panicking (found by fuzzing):
/// * debug-info instructions (`OpExtInst` of the `NonSemantic.*`, `DebugInfo` and
///   `OpenCL.DebugInfo.100` sets, as `glslangValidator -gVS` emits) are left out:
///   reflection does not need them, and rspirv rejects them outside functions or
///   panics on some of their operands. Vulkan still gets the module as given.
/// * an `OpSpecConstantOp` must compute an opcode whose operands it can hold
///   (rspirv panics on, e.g., an `OpSpecConstantOp` of an `OpSpecConstantOp`).
fn reflection_words(words: &[u32]) -> Result<Vec<u32>> {
    use rspirv::grammar::OperandKind as K;
    let instructions = || {
        let mut at = 5;
        std::iter::from_fn(move || {
            // `check_structure` made sure every instruction fits.
            let word_count = (*words.get(at)? >> 16) as usize;
            let inst = words.get(at..at + word_count)?;
            at += word_count.max(1);
            Some((at - word_count.max(1), inst))
        })
    };
    let mut debug_sets = std::collections::HashSet::new();
    for (_, inst) in instructions() {
        if opcode(inst[0]) == Some(Op::ExtInstImport) && inst.len() >= 3 {
            let name: Vec<u8> = inst[2..].iter().flat_map(|w| w.to_le_bytes()).take_while(|&b| b != 0).collect();
            let name = String::from_utf8_lossy(&name);
            if name.starts_with("NonSemantic.") || name == "DebugInfo" || name == "OpenCL.DebugInfo.100" {
                debug_sets.insert(inst[1]);
            }
        }
    }
    let mut kept = words[..5].to_vec();
    for (at, inst) in instructions() {
        match opcode(inst[0]) {
            Some(Op::ExtInst) if inst.len() >= 4 && debug_sets.contains(&inst[3]) => continue,
            Some(Op::SpecConstantOp) if inst.len() >= 4 => {
                let computed = rspirv::grammar::INSTRUCTION_TABLE.lookup_opcode(inst[3]);
                let holdable = computed.is_none_or(|g| {
                    !g.operands.iter().any(|o| {
                        matches!(
                            o.kind,
                            K::LiteralContextDependentNumber
                                | K::LiteralSpecConstantOpInteger
                                | K::PairLiteralIntegerIdRef
                        )
                    })
                });
                if !holdable {
                    return Err(Error::Module(ModuleError::InvalidSpirv {
                        reason: format!("OpSpecConstantOp at word {at} computes opcode {}, which it cannot", inst[3]),
                    }));
                }
            }
            _ => {}
        }
        kept.extend_from_slice(inst);
    }
    Ok(kept)
}

/// Checks what rspirv's parser leaves alone: every result id is below the
/// module's ID bound and defined once, and every id an instruction uses is
/// defined somewhere in the module. A flipped bit in an id is the most common
/// corruption that keeps a module well formed; without this check it reaches the
/// driver as invalid SPIR-V. (Still not a full validator: that is spirv-val.)
fn check_ids(module: &rspirv::dr::Module, bound: u32) -> Result<()> {
    let invalid = |reason: String| Err(Error::Module(ModuleError::InvalidSpirv { reason }));
    let mut defined = std::collections::HashSet::new();
    for inst in module.all_inst_iter() {
        if let Some(id) = inst.result_id {
            if id == 0 || id >= bound {
                return invalid(format!(
                    "{:?} defines %{id}, outside the module's ID bound {bound}",
                    inst.class.opcode
                ));
            }
            if !defined.insert(id) {
                return invalid(format!("%{id} is defined twice (again by {:?})", inst.class.opcode));
            }
        }
    }
    for inst in module.all_inst_iter() {
        let used = inst.result_type.into_iter().chain(inst.operands.iter().filter_map(|op| match op {
            rspirv::dr::Operand::IdRef(id)
            | rspirv::dr::Operand::IdScope(id)
            | rspirv::dr::Operand::IdMemorySemantics(id) => Some(*id),
            _ => None,
        }));
        for id in used {
            if !defined.contains(&id) {
                return invalid(format!("{:?} uses %{id}, which the module never defines", inst.class.opcode));
            }
        }
    }
    Ok(())
}

/// Lists the entry points of a SPIR-V module, with their stages and params blocks.
pub fn reflect_entry_points(bytes: &[u8]) -> Result<Vec<EntryPointInfo>> {
    let words = words_of(bytes)?;
    let module = parse(&words)?;
    let mut params = raykit_spirv::reflect_params(&module)?;
    let mut interfaces = raykit_spirv::reflect_interface_sizes(&module)?;
    let mut records = raykit_spirv::reflect_record_sizes(&module)?;
    let mut traces = raykit_spirv::reflect_traces(&module);
    let mut bindings = raykit_spirv::reflect_bindings(&module);
    let mut entries = Vec::new();
    for inst in &module.entry_points {
        let (Some(rspirv::dr::Operand::ExecutionModel(model)), Some(rspirv::dr::Operand::LiteralString(name))) =
            (inst.operands.first(), inst.operands.get(2))
        else {
            return Err(Error::Module(ModuleError::InvalidSpirv { reason: "malformed OpEntryPoint".to_owned() }));
        };
        entries.push(EntryPointInfo {
            name: name.clone(),
            // A callable named `__exception__…` is an exception program.
            kind: match kind_of(*model) {
                Some(ProgramKind::Callable) if ProgramPrefix::of(name) == Some(ProgramPrefix::Exception) => {
                    Some(ProgramKind::Exception)
                }
                other => other,
            },
            execution_model: format!("{model:?}"),
            params: params.remove(name).unwrap_or_default(),
            interface: interfaces.remove(name).unwrap_or_default(),
            record: records.remove(name).unwrap_or_default(),
            traces: traces.remove(name).unwrap_or_default(),
            bindings: bindings.remove(name).unwrap_or_default(),
        });
    }
    Ok(entries)
}

impl Module {
    /// Loads a module from SPIR-V bytes.
    #[doc(alias("optixModuleCreate", "optixModuleCreateFromPTX", "vkCreateShaderModule"))]
    pub fn new(ctx: &Context, spirv: &[u8]) -> Result<Module> {
        Module::named(ctx, spirv, "from bytes")
    }

    pub(crate) fn named(ctx: &Context, spirv: &[u8], name: &str) -> Result<Module> {
        // The bytes are checked first, on either backend: malformed SPIR-V is
        // refused alike; only a valid module meets the backend's own refusal.
        let entry_points = reflect_entry_points(spirv)?;
        if !entry_points.iter().any(|e| e.kind.is_some()) {
            return Err(Error::Module(ModuleError::NoRayTracingEntryPoints {
                available: entry_points.iter().map(|e| (e.name.clone(), e.kind)).collect(),
            }));
        }
        let words = words_of(spirv)?;
        crate::validate::spirv::validate(&words)?;
        let vulkan = match ctx.repr() {
            ContextRepr::Vulkan(vulkan) => vulkan,
            ContextRepr::Cpu(_) => return Err(spirv_on_cpu()),
        };
        vulkan.check_device("a module creation")?;
        if !vulkan.non_semantic_info && declares_extension(&words, "SPV_KHR_non_semantic_info") {
            return Err(Error::Module(ModuleError::SpirvExtensionUnsupported {
                spirv_extension: "SPV_KHR_non_semantic_info".to_owned(),
                device_extension: "VK_KHR_shader_non_semantic_info",
                fix: "Compile the module without debug info (no -gVS)",
            }));
        }
        let records_exceptions = declares_spec_id(&words, raykit_abi::EXCEPTION_SLOT_SPEC_ID);
        let inner = crate::vulkan::module::create(vulkan, entry_points, words, records_exceptions, name)?;
        Ok(Module { repr: ModuleRepr::Vulkan(Arc::new(inner)) })
    }

    /// Loads the SPIR-V that `cargo xtask build-shaders` built for the device crate
    /// `crate_name` (e.g. `"triangle-device"`), found by [`spirv_path`].
    /// When there is none, the error lists every path looked at.
    ///
    /// On the CPU backend the module is the crate linked into the program, and
    /// its programs are named by their `EntryPoint` constants; its SPIR-V, where
    /// [`spirv_path`] finds it, is read only for what the checks learn of each
    /// program's traces and calls (without it, a program is taken to trace the
    /// ray types it was declared for, and its callable calls go unchecked).
    #[doc(alias("optixModuleCreate", "optixModuleCreateFromPTX"))]
    pub fn from_device_crate(ctx: &Context, crate_name: &str) -> Result<Module> {
        let tried = spirv_candidates(crate_name);
        let found = tried.iter().find(|p| p.is_file());
        match (ctx.repr(), found) {
            (ContextRepr::Cpu(cpu), None) => Module::linked(cpu, crate_name, None),
            (ContextRepr::Cpu(cpu), Some(path)) => {
                let bytes = std::fs::read(path)
                    .map_err(|source| Error::Module(ModuleError::SpirvFile { path: path.clone(), source }))?;
                Module::linked(cpu, crate_name, Some(&bytes))
            }
            (ContextRepr::Vulkan(_), Some(path)) => Module::from_file(ctx, path),
            (ContextRepr::Vulkan(_), None) => Err(Error::Module(ModuleError::SpirvNotFound {
                crate_name: crate_name.to_owned(),
                tried,
                spirv_dir: std::env::var_os("RAYKIT_SPIRV_DIR").map(PathBuf::from),
            })),
        }
    }

    /// Loads SPIR-V embedded in the executable at compile time (see
    /// [`include_spirv!`](crate::include_spirv)): no file is needed at run time,
    /// and the bytes come from the same build as the crate's entry-point constants.
    /// On the CPU backend, the crate linked into the program (as
    /// [`Module::from_device_crate`]).
    #[doc(alias("optixModuleCreate", "optixModuleCreateFromPTX"))]
    pub fn from_embedded(ctx: &Context, spirv: &EmbeddedSpirv) -> Result<Module> {
        match ctx.repr() {
            ContextRepr::Cpu(cpu) => Module::linked(cpu, spirv.crate_name, Some(spirv.bytes)),
            ContextRepr::Vulkan(_) => Module::named(ctx, spirv.bytes, spirv.crate_name),
        }
    }

    /// Loads a module from a `.spv` file.
    #[doc(alias("optixModuleCreate", "optixModuleCreateFromPTX"))]
    pub fn from_file(ctx: &Context, path: impl AsRef<Path>) -> Result<Module> {
        let path = path.as_ref();
        let bytes = std::fs::read(path)
            .map_err(|source| Error::Module(ModuleError::SpirvFile { path: path.to_owned(), source }))?;
        Module::named(ctx, &bytes, &path.display().to_string())
    }

    /// Checks that buffer element `T` (a `#[derive(Element)]` struct of this
    /// module's device crate) has the layout in the SPIR-V that it has on the host,
    /// so device programs read the words the host writes. A field placed
    /// differently is [`ModuleError::ElementLayout`] naming it; so is a module
    /// that does not record `T` (one built from another crate). `cargo xtask
    /// build-shaders` runs the same check when it builds the crate; this one
    /// checks the SPIR-V a program actually loads. On the CPU backend the
    /// programs are the host's own code, but the check reads the crate's SPIR-V
    /// where it was at hand, so an element the GPU would read differently is
    /// refused there too; without that SPIR-V there is nothing to compare (`Ok`).
    pub fn check_element<T: raykit_device::Element>(&self) -> Result<()> {
        let blocks: std::collections::HashMap<String, Vec<raykit_spirv::ParamsBlock>> = match &self.repr {
            ModuleRepr::Vulkan(inner) => {
                inner.entry_points.iter().map(|e| (e.name.clone(), e.params.clone())).collect()
            }
            ModuleRepr::Cpu(linked) if !linked.reflected.is_empty() => {
                linked.reflected.iter().map(|e| (e.name.clone(), e.params.clone())).collect()
            }
            ModuleRepr::Cpu(_) => return Ok(()),
        };
        raykit_spirv::check_element(&T::SHAPE, &blocks).map_err(|e| match e {
            raykit_spirv::LayoutError::InvalidSpirv(reason) => Error::Module(ModuleError::InvalidSpirv { reason }),
            other => Error::Module(ModuleError::ElementLayout(Box::new(other))),
        })
    }

    /// What the validation layer reported while the module was created (OptiX's
    /// log string of `optixModuleCreate`); see [`crate::log`].
    pub fn creation_log(&self) -> &[crate::log::ValidationMessage] {
        self.spirv().map_or(&[], |inner| &inner.log)
    }

    /// The module's entry points and their stages, from its SPIR-V (none for a
    /// linked crate of the CPU backend, which is not reflected).
    pub fn entry_points(&self) -> &[EntryPointInfo] {
        self.spirv().map_or(&[], |inner| &inner.entry_points)
    }

    pub(crate) fn entry_list(&self) -> Vec<(String, Option<ProgramKind>)> {
        self.entry_points().iter().map(|e| (e.name.clone(), e.kind)).collect()
    }
}

impl std::fmt::Debug for Module {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let ModuleRepr::Cpu(linked) = &self.repr {
            return f.debug_struct("Module").field("linked_crate", &linked.crate_name).finish_non_exhaustive();
        }
        let entries: std::collections::BTreeMap<&str, &str> =
            self.entry_points().iter().map(|e| (e.name.as_str(), e.execution_model.as_str())).collect();
        f.debug_struct("Module").field("entry_points", &entries).finish_non_exhaustive()
    }
}

/// A device crate's SPIR-V, embedded in the executable by
/// [`include_spirv!`](crate::include_spirv).
#[derive(Copy, Clone, Debug)]
pub struct EmbeddedSpirv {
    /// The device crate's package name.
    pub crate_name: &'static str,
    /// Its SPIR-V module.
    pub bytes: &'static [u8],
}

/// Embeds the SPIR-V of a device crate in the executable: an
/// [`EmbeddedSpirv`] for [`Module::from_embedded`]. The crate must be built by
/// the including crate's `build.rs` with `raykit_builder::DeviceBuild::build_script`,
/// which sets `<crate>.spv` (spirv-builder's convention) to the file.
///
/// ```ignore
/// static SPIRV: raykit::EmbeddedSpirv = raykit::include_spirv!("my-device");
/// let module = raykit::Module::from_embedded(&ctx, &SPIRV)?;
/// ```
#[macro_export]
macro_rules! include_spirv {
    ($crate_name:literal) => {
        $crate::EmbeddedSpirv {
            crate_name: $crate_name,
            bytes: ::core::include_bytes!(::core::env!(::core::concat!($crate_name, ".spv"))),
        }
    };
}

/// Where `cargo xtask build-shaders` puts the SPIR-V of device crate
/// `crate_name`: `$RAYKIT_SPIRV_DIR/<crate_name>.spv` when that variable is set,
/// else `spirv/<crate_name>.spv` in the nearest ancestor directory of the running
/// executable that has one (so `target/debug/app` finds `target/spirv/`), else
/// `target/spirv/<crate_name>.spv` under the current directory.
pub fn spirv_path(crate_name: &str) -> PathBuf {
    let file = format!("{}.spv", crate_name.replace('-', "_"));
    if let Some(dir) = std::env::var_os("RAYKIT_SPIRV_DIR") {
        return PathBuf::from(dir).join(file);
    }
    if let Ok(exe) = std::env::current_exe() {
        for dir in exe.ancestors().skip(1) {
            let candidate = dir.join("spirv").join(&file);
            if candidate.is_file() {
                return candidate;
            }
        }
    }
    PathBuf::from("target").join("spirv").join(file)
}

/// Every path [`spirv_path`] may answer for `crate_name`, in its order of preference.
pub fn spirv_candidates(crate_name: &str) -> Vec<PathBuf> {
    let file = format!("{}.spv", crate_name.replace('-', "_"));
    if let Some(dir) = std::env::var_os("RAYKIT_SPIRV_DIR") {
        return vec![PathBuf::from(dir).join(file)];
    }
    let mut paths = Vec::new();
    if let Ok(exe) = std::env::current_exe() {
        paths.extend(exe.ancestors().skip(1).map(|dir| dir.join("spirv").join(&file)));
    }
    paths.push(PathBuf::from("target").join("spirv").join(file));
    paths
}

#[cfg(test)]
mod tests {
    use super::*;
    use rspirv::spirv::ExecutionModel;

    const OP_ENTRY_POINT: u32 = Op::EntryPoint as u32;

    #[test]
    fn only_a_spec_id_decoration_of_the_exception_slot_marks_a_module_that_can_throw() {
        let header = [0x0723_0203, 0x0001_0500, 0, 10, 0];
        let decorate = |decoration: u32, value: u32| [(4 << 16) | Op::Decorate as u32, 3, decoration, value];
        let with = |words: [u32; 4]| [header.as_slice(), &words].concat();
        let slot = raykit_abi::EXCEPTION_SLOT_SPEC_ID;
        assert!(declares_spec_id(&with(decorate(1, slot)), slot));
        // Another constant ID, another decoration with the same number (Location), or none at all.
        assert!(!declares_spec_id(&with(decorate(1, 7)), slot));
        assert!(!declares_spec_id(&with(decorate(30, slot)), slot));
        assert!(!declares_spec_id(&header, slot));
    }
    const OP_FUNCTION: u32 = Op::Function as u32;
    const OP_FUNCTION_END: u32 = Op::FunctionEnd as u32;
    const OP_SPEC_CONSTANT_OP: u32 = Op::SpecConstantOp as u32;

    #[test]
    fn rejects_bytes_that_are_not_spirv() {
        assert!(matches!(reflect_entry_points(b"hello"), Err(Error::Module(ModuleError::InvalidSpirv { .. }))));
        assert!(matches!(reflect_entry_points(&[0u8; 21]), Err(Error::Module(ModuleError::InvalidSpirv { .. }))));
        let err = reflect_entry_points(&[0u8; 24]).unwrap_err().to_string();
        assert!(err.contains("magic number"), "{err}");
    }

    /// A minimal module: header, `OpEntryPoint RayGenerationKHR %1 "main"`,
    /// and (optionally) the function %1.
    fn tiny_module(with_function: bool) -> Vec<u32> {
        let mut w = vec![SPIRV_MAGIC, 0x0001_0400, 0, 10, 0];
        // OpEntryPoint: 4 words + "main\0" (2 words).
        w.extend([
            (5 << 16) | OP_ENTRY_POINT,
            ExecutionModel::RayGenerationKHR as u32,
            1,
            u32::from_le_bytes(*b"main"),
            0,
        ]);
        if with_function {
            w.extend([(5 << 16) | OP_FUNCTION, 2, 1, 0, 3, (1 << 16) | OP_FUNCTION_END]);
        }
        w
    }

    /// Header, `OpCapability Shader`, `OpMemoryModel Logical GLSL450`,
    /// `%1 = OpTypeInt 32 0`, then `extra`.
    fn module_with(extra: &[u32]) -> Vec<u8> {
        let mut w = vec![SPIRV_MAGIC, 0x0001_0400, 0, 10, 0];
        let (capability, memory_model, type_int) = (Op::Capability as u32, Op::MemoryModel as u32, Op::TypeInt as u32);
        w.extend([(2 << 16) | capability, 1, (3 << 16) | memory_model, 0, 1, (4 << 16) | type_int, 1, 32, 0]);
        w.extend(extra);
        w.iter().flat_map(|w| w.to_le_bytes()).collect()
    }

    /// Found by fuzzing: rspirv's parser panics (`explicit panic`) on an
    /// `OpSpecConstantOp` that computes an `OpSpecConstantOp`.
    #[test]
    fn spec_constant_op_of_a_spec_constant_op_is_refused_before_the_parser() {
        let bytes = module_with(&[(4 << 16) | OP_SPEC_CONSTANT_OP, 1, 2, OP_SPEC_CONSTANT_OP]);
        let err = reflect_entry_points(&bytes).map(|_| ()).unwrap_err().to_string();
        assert!(err.contains("OpSpecConstantOp at word 14 computes opcode 52"), "{err}");
        // A computable one parses.
        let (iadd, constant) = (Op::IAdd as u32, Op::Constant as u32);
        let ok = module_with(&[(4 << 16) | constant, 1, 3, 7, (6 << 16) | OP_SPEC_CONSTANT_OP, 1, 2, iadd, 3, 3]);
        assert!(reflect_entry_points(&ok).is_ok(), "{:?}", reflect_entry_points(&ok).err());
    }

    /// Debug info (`glslangValidator -gVS`) is left out of reflection: rspirv
    /// rejects it outside functions, which refused valid modules.
    #[test]
    fn debug_info_does_not_stop_reflection() -> Result<()> {
        let bytes = include_bytes!("../../tests/data/raygen_debug_info.rgen.spv");
        let entries = reflect_entry_points(bytes)?;
        assert_eq!(entries.len(), 1);
        assert_eq!(entries[0].kind, Some(ProgramKind::Raygen));
        Ok(())
    }

    #[test]
    fn truncated_modules_are_refused_without_reaching_the_parser() {
        let words = tiny_module(true);
        assert!(check_structure(&words).is_ok());
        // Cut inside the function: never closed.
        let err = check_structure(&words[..words.len() - 1]).unwrap_err().to_string();
        assert!(err.contains("never closed") || err.contains("claims"), "{err}");
        // Cut before the function: the entry point names nothing.
        let err = check_structure(&tiny_module(false)).unwrap_err().to_string();
        assert!(err.contains("does not define"), "{err}");
        // Cut mid-instruction.
        let err = check_structure(&words[..7]).unwrap_err().to_string();
        assert!(err.contains("truncated"), "{err}");
    }
}
