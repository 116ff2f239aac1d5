//! WGSL device programs for raykit, through naga.
//!
//! naga (the shader translator of wgpu) parses WGSL's ray-tracing pipeline stages
//! (`enable wgpu_ray_tracing_pipeline;`: `@ray_generation`, `@miss`, `@closest_hit`,
//! `@any_hit`, `traceRay`, the `ray_payload` and `incoming_ray_payload` address
//! spaces), validates the module and writes SPIR-V. WGSL has no way to say a few
//! things raykit's programs need, so raykit gives four declarations a meaning
//! (see `prelude.wgsl`, which users copy) and completes naga's SPIR-V with rspirv:
//!
//! | WGSL declaration | becomes in SPIR-V |
//! | --- | --- |
//! | `var<immediate> params: P;` | the push-constant params block, naga's one-member wrapper removed so the block's members are `P`'s fields (what raykit's layout check compares) |
//! | `@group(1) @binding(0) var<storage, read> params: P;` | the same as raykit's uniform params buffer (params over 128 bytes), with the storage layout |
//! | `@group(2) @binding(K) var s: acceleration_structure;` | each use reads member `K` of the params block (a `Traversable`, `vec2<u32>`) and converts it with `OpConvertUToAccelerationStructureKHR` |
//! | `@group(3) @binding(0) var<storage, read> record: T;` | a `ShaderRecordBufferKHR` variable: the program's SBT record data |
//! | `@group(3) @binding(1) var<storage, read> attributes: A;` | a `HitAttributeKHR` variable (`vec2<f32>` barycentrics for triangles) |
//! | `RayDesc(flags, ray_type_mask(cull, sbt_offset, sbt_stride, miss), …)` | `OpTraceRayKHR` with that SBT offset, stride and miss index (naga passes 0 for all three) |
//!
//! Besides, the `Geometry` capability naga declares for `@builtin(primitive_index)`
//! is dropped (ray-tracing stages read `PrimitiveId` under `RayTracingKHR`, and the
//! capability would need the `geometryShader` feature).
//!
//! The SPIR-V is version 1.5 (Vulkan 1.2), whose entry points list every global
//! they use: raykit's reflection finds the params block there and checks it
//! against the host's launch-params struct, as for Rust and GLSL programs.
//!
//! ## What naga 30 lacks
//!
//! Intersection and callable programs (so also exception programs), and the
//! intrinsics `reportIntersection`, `ignoreIntersection`, `terminateRay` and
//! `executeCallable`: a module using them is refused with
//! [`WgslError::Unsupported`]. Write those programs in Rust or GLSL and link them
//! with WGSL programs in one pipeline.
//!
//! ## Limits
//!
//! Source from anyone must not take the process down nor hand a driver a module
//! it takes minutes to compile, so [`compile`]:
//!
//! * runs naga (and everything else it does) on a thread of its own with a
//!   [`STACK_SIZE`] (64 MiB) stack, whatever the caller's stack; a panic there
//!   becomes [`WgslError::Internal`];
//! * first scans the source's tokens and refuses with [`WgslError::Limit`],
//!   naming the line, the limit and the fix:
//!   * an expression with more than [`MAX_EXPRESSION_DEPTH`] (1024) operators,
//!     calls, indexing and brackets on one path (`,` and `;` start afresh);
//!   * nesting of `(`, `[`, `{` and `else if` deeper than [`MAX_NESTING`] (64);
//!   * more than [`MAX_DECLARATIONS`] (4096) module-scope declarations;
//!   * a function (parameters and body) of more than [`MAX_FUNCTION_TOKENS`]
//!     (16,384) tokens, and a source of more than [`MAX_TOKENS`] (262,144).
//!
//!   naga recurses once per level of the first three (several KiB of stack per
//!   level of an expression in an unoptimised build), so they keep its stack well
//!   within its thread's; its front end takes time quadratic in a function's
//!   length (about 1.5 s, unoptimised, for the longest function allowed), which
//!   the last bounds. A 50,000-term chain is refused rather than compiled on a
//!   bigger stack: it would need hundreds of MiB, and the scan counts the same in
//!   every build. The limits are far above hand-written code, and the nesting
//!   limit keeps below naga's own (200 nested statements and expressions, which
//!   it reports without a position). The scan counts tokens, not naga's tree, so
//!   it may refuse what naga would take, never the reverse;
//! * after validation refuses with [`WgslError::Memory`], naming the variable,
//!   its size and the budget, an entry point needing more than [`MEMORY_BUDGET`]
//!   (64 KiB) per invocation: the `var<private>` and ray payload variables it
//!   uses plus the `var<function>` variables along its heaviest call path, sized
//!   by naga's layouter; and any constant or value (a `let`) over the budget
//!   alone. Drivers keep this memory per ray in registers or scratch (lavapipe
//!   takes minutes to compile a 16 MiB private array); large data belongs in a
//!   `Buffer<T>`. WGSL's own limits are 8 KiB each for private and function
//!   memory; raykit allows more, for ray-tracing programs' small stacks and
//!   tables.
//!
//! This crate has no Vulkan dependency, so a `build.rs` can compile `.wgsl` files
//! to SPIR-V at build time ([`compile_file`]); raykit's `Module::from_wgsl` compiles
//! at run time.

#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod fixup;
mod limits;

use std::path::Path;

pub use fixup::{HIT_ATTRIBUTES_BINDING, RECORD_AND_ATTRIBUTES_GROUP, SHADER_RECORD_BINDING, TRAVERSABLE_GROUP};
pub use limits::{
    MAX_DECLARATIONS, MAX_EXPRESSION_DEPTH, MAX_FUNCTION_TOKENS, MAX_NESTING, MAX_TOKENS, MEMORY_BUDGET, STACK_SIZE,
};

/// The prelude: the declarations raykit expects, to copy into WGSL programs.
pub const PRELUDE: &str = include_str!("../prelude.wgsl");

/// Why WGSL source could not become a raykit module.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum WgslError {
    /// naga could not parse the source; `rendered` is its diagnostic with
    /// `file:line:col` and a caret under the span.
    #[error("WGSL syntax error in {path} at {line}:{column}: {message}\n{rendered}")]
    Parse {
        /// The file name given (or `"wgsl"`).
        path: String,
        /// 1-based line of the error's span.
        line: u32,
        /// 1-based column of the error's span.
        column: u32,
        /// naga's one-line message.
        message: String,
        /// naga's full diagnostic.
        rendered: String,
    },

    /// naga parsed the source but its validator refused the module.
    #[error("WGSL validation error in {path}{}: {message}\n{rendered}", at(.line, .column))]
    Validation {
        /// The file name given.
        path: String,
        /// 1-based line of the span, when naga gives one.
        line: Option<u32>,
        /// 1-based column of the span, when naga gives one.
        column: Option<u32>,
        /// naga's message, with its causes.
        message: String,
        /// naga's full diagnostic.
        rendered: String,
    },

    /// The source uses a stage or intrinsic that naga cannot compile.
    #[error("{path}:{line}:{column}: `{feature}` is not supported in WGSL (naga 30 has no {what}); write this program in Rust (rust-gpu) or GLSL and link it with the WGSL programs in one pipeline")]
    Unsupported {
        /// The file name given.
        path: String,
        /// 1-based line.
        line: u32,
        /// 1-based column.
        column: u32,
        /// The attribute or function used.
        feature: String,
        /// What naga lacks.
        what: &'static str,
    },

    /// naga's SPIR-V writer failed.
    #[error("naga could not write SPIR-V for {path}: {reason}")]
    SpirvOut {
        /// The file name given.
        path: String,
        /// naga's message.
        reason: String,
    },

    /// A declaration does not follow raykit's WGSL conventions (see the prelude).
    #[error("{path}: {reason}")]
    Convention {
        /// The file name given.
        path: String,
        /// What is wrong and how to fix it.
        reason: String,
    },

    /// The source exceeds one of the limits that keep naga's recursion bounded
    /// and its time bounded ([`MAX_EXPRESSION_DEPTH`], [`MAX_NESTING`],
    /// [`MAX_DECLARATIONS`], [`MAX_FUNCTION_TOKENS`], [`MAX_TOKENS`]).
    #[error("{path}:{line}:{column}: {what} {limit}; {fix}")]
    Limit {
        /// The file name given.
        path: String,
        /// 1-based line where the limit is passed.
        line: u32,
        /// 1-based column where the limit is passed.
        column: u32,
        /// What is counted.
        what: &'static str,
        /// The limit.
        limit: usize,
        /// How to stay within it.
        fix: &'static str,
    },

    /// An entry point needs more per-invocation memory than [`MEMORY_BUDGET`], or
    /// a constant or value alone is larger.
    #[error("{path}: `{variable}` ({space}, {size} bytes){} is over the per-invocation memory budget of {budget} bytes; put large data in a Buffer<T> (a storage buffer in the bindless table) instead", in_entry(.entry_point, .total))]
    Memory {
        /// The file name given.
        path: String,
        /// The entry point over the budget, if the item belongs to one.
        entry_point: Option<String>,
        /// The largest variable or value (`function::name` for locals).
        variable: String,
        /// Its address space, or `const` or `value`.
        space: &'static str,
        /// Its size in bytes.
        size: u64,
        /// The entry point's total in bytes (`size` when the item alone is over).
        total: u64,
        /// The budget in bytes.
        budget: u64,
    },

    /// naga panicked, or its thread could not start.
    #[error("naga failed on {path}: {reason}")]
    Internal {
        /// The file name given.
        path: String,
        /// The panic's message or the thread's error.
        reason: String,
    },

    /// A `.wgsl` file could not be read.
    #[error("reading WGSL file {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
}

fn in_entry(entry_point: &Option<String>, total: &u64) -> String {
    match entry_point {
        Some(e) => format!(" takes entry point `{e}` to {total} bytes, which"),
        None => String::new(),
    }
}

fn at(line: &Option<u32>, column: &Option<u32>) -> String {
    match (line, column) {
        (Some(l), Some(c)) => format!(" at {l}:{c}"),
        _ => String::new(),
    }
}

/// Stages and intrinsics of Vulkan ray tracing that naga 30 does not parse, and
/// what each needs.
const UNSUPPORTED: &[(&str, &str)] = &[
    ("intersection", "intersection stage"),
    ("callable", "callable stage"),
    ("exception", "callable stage (raykit runs exception programs as callables)"),
    ("reportIntersection", "intersection stage"),
    ("ignoreIntersection", "ignoreIntersection intrinsic"),
    ("terminateRay", "terminateRay intrinsic"),
    ("executeCallable", "callable stage"),
    ("callable_data", "callable stage"),
    ("incoming_callable_data", "callable stage"),
    ("hit_attribute", "hit-attribute address space (raykit maps @group(3) @binding(1) instead)"),
];

/// Compiles WGSL source to SPIR-V words ready for raykit: check the limits,
/// parse, validate, check the memory budget, write SPIR-V 1.5, then apply
/// raykit's conventions (module docs). naga runs on a thread of its own with a
/// [`STACK_SIZE`] stack; a panic there becomes [`WgslError::Internal`]. `path`
/// names the source in diagnostics.
pub fn compile(source: &str, path: &str) -> Result<Vec<u32>, WgslError> {
    on_naga_thread(path, || compile_here(source, path))
}

/// Runs `work` on a thread with a [`STACK_SIZE`] stack; its panic becomes
/// [`WgslError::Internal`].
fn on_naga_thread<T: Send>(path: &str, work: impl FnOnce() -> Result<T, WgslError> + Send) -> Result<T, WgslError> {
    let internal = |reason: String| WgslError::Internal { path: path.to_owned(), reason };
    std::thread::scope(|scope| {
        let worker = std::thread::Builder::new()
            .name("raykit-wgsl".to_owned())
            .stack_size(STACK_SIZE)
            .spawn_scoped(scope, work)
            .map_err(|e| internal(format!("starting naga's thread: {e}")))?;
        worker.join().map_err(|panic| internal(panic_message(panic.as_ref())))?
    })
}

fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    let message = panic
        .downcast_ref::<&str>()
        .map(|s| (*s).to_owned())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_owned());
    format!("panicked: {message}")
}

/// [`compile`]'s work, on naga's thread.
fn compile_here(source: &str, path: &str) -> Result<Vec<u32>, WgslError> {
    limits::scan(source, path)?;
    let module = naga::front::wgsl::parse_str(source).map_err(|e| parse_error(&e, source, path))?;
    let capabilities = naga::valid::Capabilities::RAY_TRACING_PIPELINE
        | naga::valid::Capabilities::IMMEDIATES
        | naga::valid::Capabilities::BUFFER_BINDING_ARRAY
        | naga::valid::Capabilities::STORAGE_BUFFER_BINDING_ARRAY
        | naga::valid::Capabilities::SHADER_INT64;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
        .validate(&module)
        .map_err(|e| {
            let location = e.location(source);
            WgslError::Validation {
                path: path.to_owned(),
                line: location.map(|l| l.line_number),
                column: location.map(|l| l.line_position),
                message: error_chain(e.as_inner()),
                rendered: e.emit_to_string_with_path(source, path),
            }
        })?;
    limits::check_memory(&module, &info, path)?;
    let options = naga::back::spv::Options {
        lang_version: (1, 5),
        // Names for reflection's messages (params fields), no other debug info.
        flags: naga::back::spv::WriterFlags::DEBUG,
        // Bindings as written in the source (no binding map).
        fake_missing_bindings: true,
        // As in the Rust and GLSL programs: no extra checks around traceRay, no
        // counters added to loops (wgpu's guard against infinite loops). Indexing
        // is unchecked (naga's default) and integer division keeps WGSL's
        // defined result for a zero divisor.
        trace_ray_argument_validation: false,
        ray_query_initialization_tracking: false,
        force_loop_bounding: false,
        ..Default::default()
    };
    let words = naga::back::spv::write_vec(&module, &info, &options, None)
        .map_err(|e| WgslError::SpirvOut { path: path.to_owned(), reason: e.to_string() })?;
    fixup::apply(&words).map_err(|reason| WgslError::Convention { path: path.to_owned(), reason })
}

/// [`compile`], returning the SPIR-V as bytes (what `Module::new` and `.spv`
/// files hold).
pub fn compile_to_bytes(source: &str, path: &str) -> Result<Vec<u8>, WgslError> {
    Ok(compile(source, path)?.iter().flat_map(|w| w.to_le_bytes()).collect())
}

/// Reads and compiles a `.wgsl` file to SPIR-V bytes. In a `build.rs`:
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let out = std::path::PathBuf::from(std::env::var("OUT_DIR")?);
/// println!("cargo::rerun-if-changed=wgsl/programs.wgsl");
/// let spirv = raykit_wgsl::compile_file("wgsl/programs.wgsl")?;
/// std::fs::write(out.join("programs.spv"), spirv)?;
/// // and in the crate: Module::new(&ctx, include_bytes!(concat!(env!("OUT_DIR"), "/programs.spv")))
/// # Ok(()) }
/// ```
pub fn compile_file(path: impl AsRef<Path>) -> Result<Vec<u8>, WgslError> {
    let path = path.as_ref();
    let name = path.display().to_string();
    let source = std::fs::read_to_string(path).map_err(|source| WgslError::Io { path: name.clone(), source })?;
    compile_to_bytes(&source, &name)
}

fn error_chain(e: &dyn std::error::Error) -> String {
    let mut message = e.to_string();
    let mut source = e.source();
    while let Some(cause) = source {
        message.push_str(": ");
        message.push_str(&cause.to_string());
        source = cause.source();
    }
    message
}

/// A parse error, or [`WgslError::Unsupported`] when its span names a stage or
/// intrinsic naga lacks.
fn parse_error(e: &naga::front::wgsl::ParseError, source: &str, path: &str) -> WgslError {
    let location = e.location(source);
    let (line, column) = location.map_or((0, 0), |l| (l.line_number, l.line_position));
    for (span, _) in e.labels() {
        let Some(range) = span.to_range() else { continue };
        let Some(text) = source.get(range) else { continue };
        let word = text.trim_start_matches('@').trim();
        if let Some((feature, what)) = UNSUPPORTED.iter().find(|(name, _)| *name == word) {
            let l = span.location(source);
            return WgslError::Unsupported {
                path: path.to_owned(),
                line: l.line_number,
                column: l.line_position,
                feature: (*feature).to_owned(),
                what,
            };
        }
    }
    WgslError::Parse {
        path: path.to_owned(),
        line,
        column,
        message: e.message().to_owned(),
        rendered: e.emit_to_string_with_path(source, path),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rspirv::dr::Operand;
    use rspirv::spirv::{Capability, Op, StorageClass};

    const TRIANGLE: &str = include_str!("../../examples/triangle/wgsl/triangle.wgsl");
    const PATH_TRACER: &str = include_str!("../../examples/path_tracer/wgsl/path_tracer.wgsl");

    fn module(source: &str) -> rspirv::dr::Module {
        let words = compile(source, "test.wgsl").unwrap_or_else(|e| panic!("{e}"));
        rspirv::dr::load_words(words).unwrap_or_else(|e| panic!("{e}"))
    }

    fn name_of(m: &rspirv::dr::Module, id: u32) -> Option<&str> {
        m.debug_names.iter().find_map(|n| match (n.class.opcode, n.operands.as_slice()) {
            (Op::Name, [Operand::IdRef(t), Operand::LiteralString(s)]) if *t == id => Some(s.as_str()),
            _ => None,
        })
    }

    /// The storage class of each named global variable.
    fn classes(m: &rspirv::dr::Module) -> Vec<(String, StorageClass)> {
        m.types_global_values
            .iter()
            .filter(|i| i.class.opcode == Op::Variable)
            .filter_map(|v| match v.operands.first() {
                Some(Operand::StorageClass(c)) => Some((name_of(m, v.result_id?)?.to_owned(), *c)),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn the_prelude_compiles() {
        compile(PRELUDE, "prelude.wgsl").unwrap_or_else(|e| panic!("{e}"));
    }

    #[test]
    fn records_and_attributes_get_their_storage_classes_and_the_scene_comes_from_params() {
        let m = module(TRIANGLE);
        let classes = classes(&m);
        for (name, class) in [
            ("miss_data", StorageClass::ShaderRecordBufferKHR),
            ("barycentrics", StorageClass::HitAttributeKHR),
            ("params", StorageClass::PushConstant),
            ("buffers", StorageClass::StorageBuffer),
        ] {
            assert!(classes.contains(&(name.to_owned(), class)), "{name}: {classes:?}");
        }
        // No acceleration-structure variable is left: it is converted from params.
        assert!(!classes.iter().any(|(n, _)| n == "scene"), "{classes:?}");
        let converts = m.all_inst_iter().filter(|i| i.class.opcode == Op::ConvertUToAccelerationStructureKHR).count();
        assert_eq!(converts, 1);
        // The params block is the struct itself, so reflection sees its fields.
        let blocks = raykit_params_members(&m);
        assert_eq!(blocks.first().map(String::as_str), Some("image"), "{blocks:?}");
        assert_eq!(blocks.len(), 8, "{blocks:?}");
    }

    /// The member names of the push-constant block's struct.
    fn raykit_params_members(m: &rspirv::dr::Module) -> Vec<String> {
        let var = m.types_global_values.iter().find(|i| {
            i.class.opcode == Op::Variable
                && i.operands.first() == Some(&Operand::StorageClass(StorageClass::PushConstant))
        });
        let pointer =
            var.and_then(|v| v.result_type).and_then(|t| m.types_global_values.iter().find(|i| i.result_id == Some(t)));
        let Some(Operand::IdRef(block)) = pointer.and_then(|p| p.operands.get(1)) else { return Vec::new() };
        m.debug_names
            .iter()
            .filter_map(|n| match (n.class.opcode, n.operands.as_slice()) {
                (Op::MemberName, [Operand::IdRef(t), _, Operand::LiteralString(s)]) if t == block => Some(s.clone()),
                _ => None,
            })
            .collect()
    }

    #[test]
    fn trace_ray_takes_sbt_offset_stride_and_miss_from_the_cull_mask() {
        let m = module(PATH_TRACER);
        let traces: Vec<_> = m.all_inst_iter().filter(|i| i.class.opcode == Op::TraceRayKHR).collect();
        assert!(!traces.is_empty());
        let extracts = m.all_inst_iter().filter(|i| i.class.opcode == Op::BitFieldUExtract).count();
        assert_eq!(extracts, traces.len() * 2, "offset and stride per trace");
        for t in traces {
            // Cull mask, SBT offset, stride and miss are computed, not naga's constant 0.
            let ids: Vec<u32> = t.operands[2..6]
                .iter()
                .filter_map(|o| if let Operand::IdRef(id) = o { Some(*id) } else { None })
                .collect();
            let computed = ids.iter().all(|id| {
                m.functions
                    .iter()
                    .flat_map(|f| &f.blocks)
                    .flat_map(|b| &b.instructions)
                    .any(|i| i.result_id == Some(*id))
            });
            assert!(computed, "{t:?}");
        }
    }

    #[test]
    fn the_geometry_capability_of_primitive_index_is_dropped() {
        let m = module(PATH_TRACER);
        let capabilities: Vec<_> = m.capabilities.iter().map(|c| c.operands[0].clone()).collect();
        assert!(!capabilities.contains(&Operand::Capability(Capability::Geometry)), "{capabilities:?}");
        assert!(capabilities.contains(&Operand::Capability(Capability::RuntimeDescriptorArray)), "{capabilities:?}");
        assert!(m.all_inst_iter().any(|i| i.operands.contains(&Operand::BuiltIn(rspirv::spirv::BuiltIn::PrimitiveId))));
    }

    #[test]
    fn a_parse_error_names_file_line_and_column_with_a_caret() {
        let err =
            compile("enable wgpu_ray_tracing_pipeline;\n@ray_generation\nfn rg() {\n    let x = ;\n}\n", "bad.wgsl")
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
        assert!(err.contains("bad.wgsl:4:13") && err.contains('^'), "{err}");
    }

    #[test]
    fn a_panic_on_nagas_thread_becomes_an_internal_error() {
        let err = on_naga_thread("p.wgsl", || -> Result<(), WgslError> { panic!("naga gave up") }).err();
        assert!(matches!(&err, Some(WgslError::Internal { reason, .. }) if reason.contains("naga gave up")), "{err:?}");
    }

    #[test]
    fn a_record_binding_that_is_not_storage_is_refused() {
        let source = TRIANGLE.replace("var<storage, read> miss_data", "var<uniform> miss_data");
        let err = compile(&source, "t.wgsl").err().map(|e| e.to_string()).unwrap_or_default();
        assert!(err.contains("must be a `var<storage, read>`"), "{err}");
    }
}
