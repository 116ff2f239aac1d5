//! The `shaders` suite: SPIR-V size of the Rust device programs against their
//! GLSL and WGSL twins, the WGSL twins' compile time (naga and raykit's
//! conventions, in this binary), and shader build times when `cargo xtask bench`
//! measured them on the build machine (`shader_build.json` in the output
//! directory; the bench binary itself runs where no compiler is installed).

use std::path::Path;

use anyhow::Context as _;

/// One program set's sizes.
pub struct Row {
    /// Which programs.
    pub what: &'static str,
    /// Bytes of the Rust module (all its entry points).
    pub rust_bytes: u64,
    /// Bytes of the GLSL twin's modules together (after `spirv-opt -O`).
    pub glsl_bytes: u64,
    /// Bytes of the WGSL twin's module (naga's output with raykit's conventions).
    pub wgsl_bytes: u64,
    /// Milliseconds to compile the WGSL twin (median of 5).
    pub wgsl_ms: f64,
}

/// The WGSL source's SPIR-V size and compile time (median of 5, in ms).
fn wgsl(source: &str, path: &str) -> anyhow::Result<(u64, f64)> {
    let mut times = Vec::new();
    let mut bytes = 0;
    for _ in 0..5 {
        let start = std::time::Instant::now();
        bytes = raykit::wgsl::compile_to_bytes(source, path)?.len() as u64;
        times.push(start.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    Ok((bytes, times[times.len() / 2]))
}

/// Sizes of the primary-ray and path-tracer programs.
pub fn sizes() -> anyhow::Result<Vec<Row>> {
    let file_size = |krate: &str| -> anyhow::Result<u64> {
        let path = raykit::spirv_path(krate);
        Ok(std::fs::metadata(&path).with_context(|| format!("reading {}", path.display()))?.len())
    };
    let primary_glsl = [
        include_bytes!("../glsl/primary.rgen.spv").len(),
        include_bytes!("../glsl/primary.rmiss.spv").len(),
        include_bytes!("../glsl/primary.rchit.spv").len(),
    ];
    let (primary_wgsl, primary_ms) =
        wgsl(include_str!("../../examples/triangle/wgsl/triangle.wgsl"), "examples/triangle/wgsl/triangle.wgsl")?;
    let (path_wgsl, path_ms) = wgsl(
        include_str!("../../examples/path_tracer/wgsl/path_tracer.wgsl"),
        "examples/path_tracer/wgsl/path_tracer.wgsl",
    )?;
    Ok(vec![
        Row {
            what: "primary rays (triangle)",
            rust_bytes: file_size("triangle-device")?,
            glsl_bytes: primary_glsl.iter().sum::<usize>() as u64,
            wgsl_bytes: primary_wgsl,
            wgsl_ms: primary_ms,
        },
        Row {
            what: "path tracer",
            rust_bytes: file_size("path-tracer-device")?,
            glsl_bytes: path_tracer::GLSL_SPIRV.iter().map(|(_, b)| b.len() as u64).sum(),
            wgsl_bytes: path_wgsl,
            wgsl_ms: path_ms,
        },
    ])
}

/// The Markdown section: sizes, and build times from `out/shader_build.json` if present.
pub fn markdown(rows: &[Row], out: &Path) -> (String, serde_json::Value) {
    let mut s = String::from(
        "| programs | Rust SPIR-V B | GLSL SPIR-V B (spirv-opt -O) | WGSL SPIR-V B (naga) | Rust/GLSL | WGSL/GLSL | WGSL compile ms (naga + raykit, this binary) |\n|---|---:|---:|---:|---:|---:|---:|\n",
    );
    let mut json = Vec::new();
    for r in rows {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {:.2} | {:.2} | {:.2} |\n",
            r.what,
            r.rust_bytes,
            r.glsl_bytes,
            r.wgsl_bytes,
            r.rust_bytes as f64 / r.glsl_bytes as f64,
            r.wgsl_bytes as f64 / r.glsl_bytes as f64,
            r.wgsl_ms
        ));
        json.push(serde_json::json!({"programs": r.what, "rust_bytes": r.rust_bytes, "glsl_bytes": r.glsl_bytes,
            "wgsl_bytes": r.wgsl_bytes, "wgsl_compile_ms": r.wgsl_ms}));
    }
    let build = std::fs::read_to_string(out.join("shader_build.json"))
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok());
    match &build {
        Some(b) => {
            s.push_str("\nShader build times on the build machine (`cargo xtask bench` measures them):\n\n| programs | Rust (rust-gpu, crate rebuilt, deps cached) s | GLSL (glslang + spirv-opt -O, all stages) s |\n|---|---:|---:|\n");
            for entry in b.as_array().into_iter().flatten() {
                s.push_str(&format!(
                    "| {} | {:.2} | {:.2} |\n",
                    entry["programs"].as_str().unwrap_or("?"),
                    entry["rust_s"].as_f64().unwrap_or(f64::NAN),
                    entry["glsl_s"].as_f64().unwrap_or(f64::NAN)
                ));
            }
        }
        None => s.push_str("\n(no shader build times: run through `cargo xtask bench` on a machine with the toolchain, glslang and spirv-opt)\n"),
    }
    (s, serde_json::json!({"sizes": json, "build_times": build}))
}
