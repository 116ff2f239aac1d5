//! The host crate's layering, checked: the public types of `host/src` sit above
//! the two backends (`vulkan/`, `cpu/`), which sit above the plain data, checks
//! and errors (`types/`, `validate/`, `error/`). Imports run downward only, so a
//! lower layer never names a module of a higher one. And each function of the
//! public modules dispatches on its backend once: at most one match arm on a
//! backend enum's Vulkan half (`ContextRepr::Vulkan(..) =>`; a tuple match over
//! two values, whose arms start with `(`, counts as one).

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

/// The functions of `text` with more than one Vulkan arm of a backend enum
/// (`…Repr::Vulkan… =>` starting its line), as `(line, name, arms)`.
fn repeated_dispatch(text: &str) -> Vec<(usize, String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut found = Vec::new();
    let mut at = 0;
    while at < lines.len() {
        let line = lines[at].trim_start();
        let Some(name) = fn_name(line) else {
            at += 1;
            continue;
        };
        // The body: from the line with the opening brace to where the braces balance.
        let (start, mut depth, mut arms) = (at, 0i64, 0);
        let mut opened = false;
        while at < lines.len() {
            let l = lines[at];
            let code = l.split("//").next().unwrap_or("");
            depth += code.matches('{').count() as i64 - code.matches('}').count() as i64;
            opened |= code.contains('{');
            let t = l.trim_start();
            if at > start && t.contains("Repr::Vulkan") && t.contains("=>") && !t.starts_with('(') {
                arms += 1;
            }
            if (opened && depth <= 0) || (!opened && code.contains(';')) {
                break;
            }
            at += 1;
        }
        if arms > 1 {
            found.push((start + 1, name, arms));
        }
        at += 1;
    }
    found
}

/// The name of the function `line` starts, if it starts one.
fn fn_name(line: &str) -> Option<String> {
    let rest = ["pub fn ", "pub(crate) fn ", "pub(super) fn ", "fn "].iter().find_map(|p| line.strip_prefix(p))?;
    Some(rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect())
}

/// Fails naming every function of the public modules that dispatches on its
/// backend more than once.
pub fn check_dispatch(root: &Path) -> anyhow::Result<()> {
    let src = root.join("host/src");
    let mut problems = Vec::new();
    for entry in walk(&src)? {
        let rel = entry.strip_prefix(&src).unwrap_or(&entry);
        if BACKENDS.iter().chain(["types", "validate", "error"].iter()).any(|l| rel.starts_with(l)) {
            continue;
        }
        let text = std::fs::read_to_string(&entry).with_context(|| format!("reading {}", entry.display()))?;
        for (line, name, arms) in repeated_dispatch(&text) {
            let shown = entry.strip_prefix(root).unwrap_or(&entry).display().to_string();
            problems.push(format!("{shown}:{line}: `{name}` has {arms} Vulkan arms"));
        }
    }
    if !problems.is_empty() {
        bail!(
            "lint gate `layers` failed: a public operation dispatches on its backend more than once:\n  {}\n\
             Match the backend once and hand that backend everything it needs; read a half through an accessor \
             (`vulkan_inner`)",
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
    fn a_function_matching_its_backend_twice_is_found() {
        let twice = "pub fn f(&self) {\n    match a {\n        ContextRepr::Vulkan(x) => 1,\n    }\n    match b {\n        PipelineRepr::Vulkan(y) => 2,\n    }\n}\n";
        assert_eq!(repeated_dispatch(twice), [(1, "f".to_owned(), 2)]);
        let once = "fn g() {\n    match (a, b) {\n        (ContextRepr::Vulkan(_), None) => 1,\n        (ContextRepr::Vulkan(_), Some(_)) => 2,\n        ContextRepr::Vulkan(x) => ModuleRepr::Vulkan(x),\n    }\n}\n";
        assert!(repeated_dispatch(once).is_empty(), "{:?}", repeated_dispatch(once));
    }

    #[test]
    fn the_host_crate_dispatches_once_per_operation() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask lies in the workspace root");
        check_dispatch(root).expect("each public operation matches its backend once");
    }

    #[test]
    fn the_host_crate_keeps_its_layers() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask lies in the workspace root");
        check(root).expect("host/src keeps its layers");
    }
}
