//! The host crate's layering, checked: the public types of `host/src` sit above
//! the two backends (`vulkan/`, `cpu/`), which sit above the plain data, checks
//! and errors (`types/`, `validate/`, `error/`). Imports run downward only, so a
//! lower layer never names a module of a higher one.

use std::path::Path;

use anyhow::{bail, Context};

/// The public modules: only they may name a backend.
const PUBLIC: &[&str] = &[
    "context",
    "module",
    "program_group",
    "pipeline",
    "sbt",
    "accel",
    "texture",
    "memory",
    "device_group",
    "wgsl",
    "gate",
];
/// The backends.
const BACKENDS: &[&str] = &["vulkan", "cpu"];

/// Each layer below the public types, with the modules it may not name.
fn forbidden(layer: &str) -> Vec<&'static str> {
    match layer {
        "vulkan" | "cpu" => PUBLIC.to_vec(),
        _ => PUBLIC.iter().chain(BACKENDS).copied().collect(),
    }
}

/// Whether `line` holds `path` as a path of its own (not the tail of a longer name).
fn names(line: &str, path: &str) -> bool {
    line.match_indices(path).any(|(at, _)| !line[..at].ends_with(|c: char| c.is_alphanumeric() || c == '_'))
}

/// The paths of `text` that name a module of `forbidden` (`crate::MODULE::`), or,
/// in code, a public type through the crate root (`crate::Type`; the error type
/// and `Result` are the bottom layer's own), with their lines.
fn violations(text: &str, forbidden: &[&str]) -> Vec<(usize, String)> {
    let mut found = Vec::new();
    for (n, line) in text.lines().enumerate() {
        for module in forbidden {
            let path = format!("crate::{module}::");
            if names(line, &path) {
                found.push((n + 1, path));
            }
        }
        if line.trim_start().starts_with("//") {
            continue;
        }
        for (at, _) in line.match_indices("crate::") {
            let rest = &line[at + "crate::".len()..];
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            let own = ["Result", "Error"].contains(&name.as_str());
            if name.starts_with(char::is_uppercase) && !own && names(line, &format!("crate::{name}")) {
                found.push((n + 1, format!("crate::{name}")));
            }
        }
    }
    found
}

/// Fails naming every file of a lower layer of `host/src` that names a module
/// of a higher one.
pub fn check(root: &Path) -> anyhow::Result<()> {
    let src = root.join("host/src");
    let mut problems = Vec::new();
    for layer in ["vulkan", "cpu", "types", "validate", "error"] {
        let banned = forbidden(layer);
        for entry in walk(&src.join(layer))? {
            let text = std::fs::read_to_string(&entry).with_context(|| format!("reading {}", entry.display()))?;
            for (line, path) in violations(&text, &banned) {
                let shown = entry.strip_prefix(root).unwrap_or(&entry).display().to_string();
                problems.push(format!("{shown}:{line}: {path} (the {layer} layer sits below it)"));
            }
        }
    }
    if !problems.is_empty() {
        bail!(
            "lint gate `layers` failed: a lower layer of host/src names a higher one:\n  {}\n\
             Backends import only types/, validate/, error/ and their own modules; plain data a backend needs \
             belongs in types/, and the public type hands the backend its own half",
            problems.join("\n  ")
        );
    }
    Ok(())
}

/// Every `.rs` file under `dir`.
fn walk(dir: &Path) -> anyhow::Result<Vec<std::path::PathBuf>> {
    let mut files = Vec::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(dir) = pending.pop() {
        for entry in std::fs::read_dir(&dir).with_context(|| format!("listing {}", dir.display()))? {
            let path = entry?.path();
            if path.is_dir() {
                pending.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files.sort();
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_backend_naming_a_public_module_is_found_and_its_own_paths_are_not() {
        let text = "use crate::vulkan::context::ContextInner;\nuse crate::context::Context;\n// see crate::sbt::Sbt\n";
        assert_eq!(
            violations(text, &forbidden("vulkan")),
            [(2, "crate::context::".to_owned()), (3, "crate::sbt::".to_owned())]
        );
        assert!(violations("use crate::types::accel::BuildInput;", &forbidden("cpu")).is_empty());
        assert_eq!(violations("x: crate::cpu::CpuContext", &forbidden("types")), [(1, "crate::cpu::".to_owned())]);
        assert!(violations("raykit_crate::context::X", &forbidden("vulkan")).is_empty());
        assert_eq!(violations("-> crate::Result<crate::Gas>", &forbidden("cpu")), [(1, "crate::Gas".to_owned())]);
        assert!(violations("/// see [`Gas`](crate::Gas)", &forbidden("cpu")).is_empty());
    }

    #[test]
    fn the_host_crate_keeps_its_layers() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask lies in the workspace root");
        check(root).expect("host/src keeps its layers");
    }
}
