//! Errors of modules: SPIR-V given or found, its entry points, WGSL source.

use raykit_device::ProgramKind;

fn list_entry_points(entries: &[(String, Option<ProgramKind>)]) -> String {
    if entries.is_empty() {
        return "none".to_owned();
    }
    entries
        .iter()
        .map(|(name, kind)| match kind {
            Some(kind) => format!("`{name}` ({kind})"),
            None => format!("`{name}` (not a ray-tracing stage)"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Errors of modules.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModuleError {
    /// The bytes given as a module are not a SPIR-V module.
    #[error("not a SPIR-V module: {reason}. Give the `.spv` file that `cargo xtask build-shaders` writes under target/spirv/")]
    InvalidSpirv {
        /// What is wrong with them.
        reason: String,
    },

    /// A SPIR-V file could not be read.
    #[error("reading SPIR-V file {path}: {source}. Run `cargo xtask build-shaders` to build the device crates")]
    SpirvFile {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },

    /// The SPIR-V of a device crate was not found where `cargo xtask build-shaders` writes it.
    #[error("no SPIR-V for device crate `{crate_name}`; looked at: {}. {}", .tried.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "), match .spirv_dir {
        Some(dir) => format!("RAYKIT_SPIRV_DIR is set to {}: point it at the folder that holds the `.spv` files, or unset it; build them with `cargo xtask build-shaders`", dir.display()),
        None => "Build them with `cargo xtask build-shaders` (it writes target/spirv/), or set RAYKIT_SPIRV_DIR to the folder that holds them".to_owned(),
    })]
    SpirvNotFound {
        /// The device crate.
        crate_name: String,
        /// Every path looked at.
        tried: Vec<std::path::PathBuf>,
        /// `RAYKIT_SPIRV_DIR`, when set.
        spirv_dir: Option<std::path::PathBuf>,
    },

    /// The module declares a SPIR-V extension whose device extension this device
    /// lacks.
    #[error("the module uses SPIR-V extension {spirv_extension}, which needs {device_extension}; this device lacks it. {fix}")]
    SpirvExtensionUnsupported {
        /// The `OpExtension` name.
        spirv_extension: String,
        /// The Vulkan device extension it needs.
        device_extension: &'static str,
        /// What to do instead.
        fix: &'static str,
    },

    /// The module has no ray-tracing entry point at all.
    #[error("the SPIR-V module has no ray-tracing entry points (raygen, miss, closest-hit, any-hit, intersection, callable); it has: {}. Compile the programs as ray-tracing stages (`#[raygen]`, `#[miss]`, … in Rust; `.rgen`, `.rmiss`, … in GLSL)", list_entry_points(.available))]
    NoRayTracingEntryPoints {
        /// The entry points it has.
        available: Vec<(String, Option<ProgramKind>)>,
    },

    /// The module has no entry point of that name.
    #[error("module has no entry point `{name}`; it has: {}. Name one of these (Rust programs: use the entry-point constants the program macros generate)", list_entry_points(.available))]
    EntryPointNotFound {
        /// The name asked for.
        name: String,
        /// The entry points the module has, with their kinds.
        available: Vec<(String, Option<ProgramKind>)>,
    },

    /// An entry point was used as a program of the wrong kind.
    #[error("entry point `{name}` is a {actual} program, not a {expected} program (asked for by {context}); the module's entry points: {}", list_entry_points(.available))]
    ProgramKindMismatch {
        /// The entry point.
        name: String,
        /// The kind the group needs.
        expected: ProgramKind,
        /// The kind the module (or the name's OptiX prefix) says.
        actual: String,
        /// Which program-group slot asked for it.
        context: &'static str,
        /// The entry points the module has, with their kinds.
        available: Vec<(String, Option<ProgramKind>)>,
    },

    /// WGSL source could not be compiled: a syntax or validation error (with
    /// naga's diagnostic: `file:line:col` and a caret), a stage or intrinsic naga
    /// lacks, or a declaration against raykit's WGSL conventions.
    #[cfg(feature = "wgsl")]
    #[error(transparent)]
    Wgsl(Box<raykit_wgsl::WgslError>),

    /// A `#[derive(Element)]` struct is laid out differently in the module's SPIR-V
    /// than on the host, or the module does not record it (from
    /// [`Module::check_element`](crate::Module::check_element)).
    #[error(transparent)]
    ElementLayout(Box<raykit_spirv::LayoutError>),
}
