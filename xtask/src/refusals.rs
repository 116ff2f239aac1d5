//! `cargo xtask refusals`: the table of every refusal raykit makes (each
//! variant of its error enums) and the backends the bad-input catalogue
//! provokes it on, read from the catalogue's own record of what each case was
//! refused with (`RAYKIT_REFUSAL_LOG`, see `raykit_tests::note_refusal`).
//! Variants documented as `A fault, not a refusal: …` (the driver, the machine
//! or a running program failed; no input was wrong) are listed apart, with that
//! reason, and not counted among the refusals.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context as _;

/// A variant of one of raykit's error enums.
#[derive(Debug)]
pub struct Variant {
    /// `Enum::Variant`, e.g. `Sbt::Incomplete`.
    pub name: String,
    /// Why it is a fault rather than a refusal, when its docs say so.
    pub fault: Option<String>,
}

/// The doc line that marks a variant as a fault.
const FAULT_MARK: &str = "/// A fault, not a refusal: ";

/// The variants of the error enums in `host/src/error/`, as `Enum::Variant`
/// with the enum's name less its `Error` suffix (`Sbt::Incomplete`), in file
/// order. `Error` itself (which wraps the others) is left out.
pub fn error_variants(root: &Path) -> anyhow::Result<Vec<Variant>> {
    let dir = root.join("host/src/error");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .with_context(|| format!("reading {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .collect();
    files.sort();
    let mut variants = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file)?;
        let mut current: Option<String> = None;
        let mut fault: Option<String> = None;
        for line in text.lines() {
            if let Some(rest) = line.strip_prefix("pub enum ") {
                let name: String = rest.chars().take_while(|c| c.is_alphanumeric()).collect();
                current = (name != "Error").then(|| name.trim_end_matches("Error").to_owned());
                continue;
            }
            if line == "}" {
                current = None;
                continue;
            }
            let Some(enum_name) = &current else { continue };
            // Variants sit at four spaces, named in CamelCase.
            let Some(rest) = line.strip_prefix("    ") else { continue };
            if let Some(why) = rest.strip_prefix(FAULT_MARK) {
                fault = Some(why.trim_end_matches('.').to_owned());
                continue;
            }
            if !rest.starts_with(|c: char| c.is_ascii_uppercase()) {
                continue;
            }
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            let after = &rest[name.len()..];
            if after.is_empty() || after.starts_with([' ', '{', '(', ',']) {
                variants.push(Variant { name: format!("{enum_name}::{name}"), fault: fault.take() });
            }
        }
    }
    Ok(variants)
}

/// What the catalogue noted of one variant.
#[derive(Default)]
struct Seen {
    backends: BTreeSet<String>,
    cases: BTreeSet<String>,
    why: BTreeSet<String>,
}

/// Runs the bad-input catalogue with its record on, and writes and prints the table.
pub fn run(root: &Path, spirv_dir: &Path) -> anyhow::Result<()> {
    let out = root.join("target/refusals");
    std::fs::create_dir_all(&out)?;
    let log = out.join("log.tsv");
    let _ = std::fs::remove_file(&log);
    let mut cmd = crate::cargo();
    cmd.args(["test", "-p", "raykit-tests", "--test", "bad_input", "--", "--test-threads", "1"]);
    cmd.env("RAYKIT_REFUSAL_LOG", &log);
    cmd.env("RAYKIT_SPIRV_DIR", spirv_dir);
    crate::run(&mut cmd, "the bad-input catalogue")?;
    let noted = std::fs::read_to_string(&log).with_context(|| format!("reading {}", log.display()))?;
    let table = table(&error_variants(root)?, &noted);
    std::fs::write(out.join("refusals.md"), &table)?;
    println!("{table}");
    println!("xtask refusals: written to target/refusals/refusals.md");
    Ok(())
}

/// The markdown table of `variants` against the `noted` record.
fn table(variants: &[Variant], noted: &str) -> String {
    let mut seen: BTreeMap<&str, Seen> = BTreeMap::new();
    for line in noted.lines() {
        let mut fields = line.split('\t');
        let (Some(variant), Some(backend), Some(case)) = (fields.next(), fields.next(), fields.next()) else {
            continue;
        };
        let entry = seen.entry(variant).or_default();
        entry.backends.insert(backend.to_owned());
        entry.cases.insert(case.to_owned());
        if let Some(why) = fields.next().filter(|w| !w.is_empty()) {
            entry.why.insert(why.to_owned());
        }
    }
    let mut text = String::from("| refusal | Vulkan | CPU | cases | why one backend |\n|---|---|---|---|---|\n");
    let mut faults = String::from("\n| fault | why it is no refusal |\n|---|---|\n");
    let (mut both, mut one, mut none, mut fault_count) = (0, 0, 0, 0);
    for variant in variants {
        if let Some(why) = &variant.fault {
            fault_count += 1;
            let _ = writeln!(faults, "| `{}` | {why} |", variant.name);
            continue;
        }
        let found = seen.get(variant.name.as_str());
        let on = |b: &str| found.is_some_and(|s| s.backends.contains(b));
        let (vulkan, cpu) = (on("Vulkan"), on("Cpu"));
        match (vulkan, cpu) {
            (true, true) => both += 1,
            (false, false) => none += 1,
            _ => one += 1,
        }
        let mark = |b: bool| if b { "yes" } else { "–" };
        let cases = found.map_or(0, |s| s.cases.len());
        let why = found.map(|s| s.why.iter().cloned().collect::<Vec<_>>().join("; ")).unwrap_or_default();
        let _ = writeln!(text, "| `{}` | {} | {} | {cases} | {why} |", variant.name, mark(vulkan), mark(cpu));
    }
    let total = both + one + none;
    let share = if total == 0 { 0.0 } else { 100.0 * both as f64 / total as f64 };
    let _ = writeln!(
        text,
        "\n{both} of {total} refusals ({share:.0}%) are provoked on both backends, {one} on one, {none} by no bad-input case; {fault_count} variants are faults, below."
    );
    text + &faults
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_variants_are_read_from_the_error_enums() -> anyhow::Result<()> {
        let variants = error_variants(&crate::project_root())?;
        for expected in ["Sbt::Incomplete", "Launch::Dimensions", "Accel::InvalidSphere", "Module::EntryPointNotFound"]
        {
            anyhow::ensure!(
                variants.iter().any(|v| v.name == expected && v.fault.is_none()),
                "{expected} missing from {variants:?}"
            );
        }
        let lost = variants.iter().find(|v| v.name == "Device::DeviceLost");
        anyhow::ensure!(lost.is_some_and(|v| v.fault.is_some()), "DeviceLost is a fault: {lost:?}");
        anyhow::ensure!(
            !variants.iter().any(|v| v.name.starts_with("::") || v.name.contains("Error::")),
            "{variants:?}"
        );
        Ok(())
    }

    #[test]
    fn the_table_counts_each_backend() {
        let refusal = |name: &str| Variant { name: name.to_owned(), fault: None };
        let variants = vec![
            refusal("Sbt::Hole"),
            refusal("Sbt::Missing"),
            refusal("Module::Wgsl"),
            Variant { name: "Device::DeviceLost".to_owned(), fault: Some("the GPU stopped".to_owned()) },
        ];
        let noted = "Sbt::Hole\tVulkan\ta\t\nSbt::Hole\tCpu\ta\t\nModule::Wgsl\tVulkan\tb\tWGSL is SPIR-V\n";
        let t = table(&variants, noted);
        assert!(t.contains("| `Sbt::Hole` | yes | yes | 1 |  |"), "{t}");
        assert!(t.contains("| `Module::Wgsl` | yes | – | 1 | WGSL is SPIR-V |"), "{t}");
        assert!(t.contains("1 of 3 refusals (33%) are provoked on both backends, 1 on one, 1 by no bad-input case; 1 variants are faults"), "{t}");
        assert!(t.contains("| `Device::DeviceLost` | the GPU stopped |"), "{t}");
    }
}
