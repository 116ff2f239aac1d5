//! The committed SPIR-V (the GLSL twins and the test fixtures) is built from the
//! committed sources. Each folder's `build.sh` rebuilds its `.spv` files and records
//! the SHA-256 of every source and output in `SHA256SUMS`:
//!
//! * always: every file listed there still has its recorded hash, and every `.spv`
//!   of the folder is listed (a source edited without rebuilding, or a `.spv`
//!   replaced by hand, fails here);
//! * when glslang and the SPIRV-Tools are installed (`apt-get install -y
//!   glslang-tools spirv-tools`; `cargo xtask test` installs them and sets
//!   `RAYKIT_REQUIRE_GLSLANG=1`, which turns their absence into a failure):
//!   `build.sh` runs into a temporary folder and its output must equal the
//!   committed files byte for byte.

use std::path::{Path, PathBuf};
use std::process::Command;

use sha2::{Digest, Sha256};

/// The folders with committed SPIR-V, each with a `build.sh` and a `SHA256SUMS`.
const FOLDERS: [&str; 4] = ["bench/glsl", "examples/triangle/glsl", "examples/path_tracer/glsl", "tests/data"];

/// The tools the `build.sh` scripts run.
const TOOLS: [&str; 4] = ["glslangValidator", "spirv-opt", "spirv-val", "spirv-as"];

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("the tests crate is inside the workspace").to_path_buf()
}

/// `(hex SHA-256, path relative to the folder)` per line of `folder/SHA256SUMS`.
fn manifest(folder: &str) -> Vec<(String, String)> {
    let path = root().join(folder).join("SHA256SUMS");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    text.lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| {
            let (hash, file) = l.split_once("  ").unwrap_or_else(|| panic!("{}: malformed line {l:?}", path.display()));
            (hash.to_owned(), file.to_owned())
        })
        .collect()
}

fn sha256(path: &Path) -> String {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    Sha256::digest(&bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// The `.spv` files directly in `folder`.
fn spirv_files(folder: &str) -> Vec<String> {
    let dir = root().join(folder);
    let mut files: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("listing {}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").file_name().to_string_lossy().into_owned())
        .filter(|name| name.ends_with(".spv"))
        .collect();
    files.sort();
    files
}

#[test]
fn committed_spirv_and_its_sources_have_their_recorded_hashes() {
    let mut problems = Vec::new();
    for folder in FOLDERS {
        let entries = manifest(folder);
        let listed: Vec<&str> = entries.iter().map(|(_, f)| f.as_str()).collect();
        assert!(listed.iter().any(|f| f.ends_with(".spv")), "{folder}/SHA256SUMS lists no .spv file");
        assert!(listed.iter().any(|f| !f.ends_with(".spv")), "{folder}/SHA256SUMS lists no source");
        for (hash, file) in &entries {
            let actual = sha256(&root().join(folder).join(file));
            if &actual != hash {
                let what = if file.ends_with(".spv") {
                    "is not the file build.sh wrote (SHA256SUMS)"
                } else {
                    "changed since the SPIR-V was built from it (SHA256SUMS)"
                };
                problems.push(format!("{folder}/{file} {what}: run {folder}/build.sh"));
            }
        }
        for spv in spirv_files(folder) {
            if !listed.contains(&spv.as_str()) {
                problems.push(format!("{folder}/{spv} is not built by {folder}/build.sh (not in SHA256SUMS)"));
            }
        }
    }
    assert!(problems.is_empty(), "committed SPIR-V out of date:\n{}", problems.join("\n"));
}

fn tool_present(tool: &str) -> bool {
    Command::new(tool).arg("--version").output().is_ok_and(|o| o.status.success())
}

#[test]
fn committed_spirv_rebuilds_byte_for_byte_from_its_sources() {
    let missing: Vec<&str> = TOOLS.into_iter().filter(|t| !tool_present(t)).collect();
    if !missing.is_empty() {
        let message = format!(
            "{} not installed, so the committed SPIR-V was not rebuilt and compared \
             (on Debian: apt-get install -y glslang-tools spirv-tools)",
            missing.join(", ")
        );
        assert!(std::env::var_os("RAYKIT_REQUIRE_GLSLANG").is_none_or(|v| v != "1"), "{message}");
        eprintln!("SKIPPED: {message}");
        return;
    }
    let mut problems = Vec::new();
    for folder in FOLDERS {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("committed_spirv").join(folder);
        let _ = std::fs::remove_dir_all(&out);
        let script = root().join(folder).join("build.sh");
        let result = Command::new("sh").arg(&script).arg(&out).output().expect("running sh");
        assert!(
            result.status.success(),
            "{} {} failed: {}",
            script.display(),
            out.display(),
            String::from_utf8_lossy(&result.stderr)
        );
        let spirv: Vec<String> = manifest(folder).into_iter().map(|(_, f)| f).filter(|f| f.ends_with(".spv")).collect();
        for file in spirv {
            let built =
                std::fs::read(out.join(&file)).unwrap_or_else(|e| panic!("{folder}/build.sh made no {file}: {e}"));
            let committed = std::fs::read(root().join(folder).join(&file)).expect("reading the committed file");
            if built != committed {
                problems.push(format!(
                    "{folder}/{file}: {} bytes committed, {} bytes rebuilt, different content; run {folder}/build.sh",
                    committed.len(),
                    built.len()
                ));
            }
        }
        let _ = std::fs::remove_dir_all(&out);
    }
    assert!(problems.is_empty(), "committed SPIR-V differs from its sources' build:\n{}", problems.join("\n"));
}
