//! WGSL device programs, through naga: [`Module::from_wgsl`] compiles WGSL
//! source at run time; the compiler itself ([`compile`], [`compile_file`]) is the
//! `raykit-wgsl` crate, which has no Vulkan dependency so a `build.rs` can compile
//! `.wgsl` files at build time and embed the SPIR-V.
//!
//! naga parses and validates the WGSL ray-tracing stages (`@ray_generation`,
//! `@miss`, `@closest_hit`, `@any_hit`) and writes SPIR-V; raykit then gives a few
//! declarations their meaning (shader records, hit attributes, the scene from
//! params, ray types in `traceRay`), as its [`PRELUDE`] documents. The module that
//! results is checked like any other: its params block against the host struct
//! when a pipeline is linked, its stages against the program groups. naga has no
//! intersection or callable stages: such programs are refused with
//! [`WgslError::Unsupported`]; write them in Rust or GLSL and link them with WGSL
//! programs in one pipeline.

use std::path::Path;

pub use raykit_wgsl::{
    compile, compile_file, compile_to_bytes, WgslError, HIT_ATTRIBUTES_BINDING, PRELUDE, RECORD_AND_ATTRIBUTES_GROUP,
    SHADER_RECORD_BINDING, TRAVERSABLE_GROUP,
};

use crate::context::Context;
use crate::error::ModuleError;
use crate::error::{Error, Result};
use crate::module::Module;

impl Module {
    /// Compiles WGSL source (naga, then raykit's conventions) and loads it.
    /// Errors are [`ModuleError::Wgsl`], with naga's diagnostic (`file:line:col` and a
    /// caret under the span).
    pub fn from_wgsl(ctx: &Context, source: &str) -> Result<Module> {
        Module::from_wgsl_named(ctx, source, "wgsl")
    }

    /// [`Module::from_wgsl`], naming the source `path` in diagnostics.
    pub fn from_wgsl_named(ctx: &Context, source: &str, path: &str) -> Result<Module> {
        let spirv = compile_to_bytes(source, path)?;
        Module::named(ctx, &spirv, path)
    }

    /// Reads, compiles and loads a `.wgsl` file.
    pub fn from_wgsl_file(ctx: &Context, path: impl AsRef<Path>) -> Result<Module> {
        let path = path.as_ref();
        let spirv = compile_file(path)?;
        Module::named(ctx, &spirv, &path.display().to_string())
    }
}

impl From<WgslError> for Error {
    fn from(e: WgslError) -> Self {
        Error::Module(ModuleError::Wgsl(Box::new(e)))
    }
}
