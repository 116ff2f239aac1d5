//! The book gate: `mdbook build docs/book` without a warning, and every
//! relative link and `#anchor` of the book and the READMEs resolving.
//!
//! mdbook is installed when missing, with `cargo install --locked` from
//! crates.io at the pinned [`MDBOOK_VERSION`] (without its `serve` and `watch`
//! features, which the gate does not use), into raykit's per-user cache
//! (`raykit_builder::cache_dir()`, `~/.cache/raykit/mdbook-<version>`), so every
//! clone shares one build. An `mdbook` on `PATH` of that version is used as it is.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context as _};

/// The mdbook the gate builds the book with (builds with stable Rust 1.88 and later).
pub const MDBOOK_VERSION: &str = "0.5.4";

/// The Markdown files outside the book whose links are checked too.
const READMES: [&str; 3] = ["README.md", "examples/README.md", "bench/README.md"];

/// Builds the book and checks its links; fails naming each problem.
pub fn check(root: &Path) -> anyhow::Result<()> {
    let mdbook = ensure_mdbook()?;
    let out = Command::new(&mdbook)
        .current_dir(root)
        .args(["build", "docs/book"])
        .output()
        .with_context(|| format!("running {}", mdbook.display()))?;
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    let warnings: Vec<&str> = log.lines().filter(|l| l.contains("WARN") || l.contains("ERROR")).collect();
    if !out.status.success() || !warnings.is_empty() {
        bail!("`mdbook build docs/book` failed or warned ({}):\n{log}", out.status);
    }
    let problems = check_links(root)?;
    if !problems.is_empty() {
        bail!("broken links in the book or the READMEs:\n  {}", problems.join("\n  "));
    }
    Ok(())
}

/// The mdbook binary of [`MDBOOK_VERSION`]: on `PATH`, in the cache, or installed into the cache.
fn ensure_mdbook() -> anyhow::Result<PathBuf> {
    let version_of = |bin: &Path| -> Option<String> {
        let out = Command::new(bin).arg("--version").output().ok()?;
        out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
    };
    let wanted = format!("mdbook v{MDBOOK_VERSION}");
    if version_of(Path::new("mdbook")).as_deref() == Some(wanted.as_str()) {
        return Ok(PathBuf::from("mdbook"));
    }
    let dir = raykit_builder::cache_dir().join(format!("mdbook-{MDBOOK_VERSION}"));
    let bin = dir.join("bin").join("mdbook");
    if version_of(&bin).as_deref() == Some(wanted.as_str()) {
        return Ok(bin);
    }
    println!(
        "xtask: installing mdbook {MDBOOK_VERSION} into {} (cargo install --locked, once per machine)",
        dir.display()
    );
    let mut install = crate::cargo();
    install
        .args(["install", "--locked", "mdbook", "--version", MDBOOK_VERSION])
        .args(["--no-default-features", "--features", "search", "--root"])
        .arg(&dir)
        .arg("--target-dir")
        .arg(dir.join("build"));
    crate::run(&mut install, "cargo install mdbook")?;
    let _ = std::fs::remove_dir_all(dir.join("build"));
    if version_of(&bin).as_deref() != Some(wanted.as_str()) {
        bail!("installed mdbook {MDBOOK_VERSION}, but {} does not run", bin.display());
    }
    println!("xtask: mdbook {MDBOOK_VERSION} installed");
    Ok(bin)
}

/// Every relative link of the book's chapters and the READMEs whose file is
/// missing, or whose `#anchor` names no heading of the Markdown file it points at.
pub fn check_links(root: &Path) -> anyhow::Result<Vec<String>> {
    let src = root.join("docs/book/src");
    let mut files: Vec<PathBuf> = READMES.iter().map(|f| root.join(f)).filter(|p| p.is_file()).collect();
    for entry in std::fs::read_dir(&src).with_context(|| format!("reading {}", src.display()))? {
        let path = entry?.path();
        if path.extension().is_some_and(|e| e == "md") {
            files.push(path);
        }
    }
    files.sort();
    let mut anchors: BTreeMap<PathBuf, BTreeSet<String>> = BTreeMap::new();
    let mut problems = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).with_context(|| format!("reading {}", file.display()))?;
        let shown = file.strip_prefix(root).unwrap_or(file).display().to_string();
        let in_book = file.starts_with(&src);
        for target in links(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, anchor) = target.split_once('#').unwrap_or((target.as_str(), ""));
            let resolved =
                if path.is_empty() { file.clone() } else { normalise(&file.parent().unwrap_or(root).join(path)) };
            if !resolved.exists() {
                problems.push(format!("{shown}: `{target}`: no such file"));
                continue;
            }
            if in_book && !resolved.starts_with(&src) {
                problems
                    .push(format!("{shown}: `{target}` leaves the book (the rendered book has only docs/book/src)"));
                continue;
            }
            if anchor.is_empty() || resolved.extension().is_none_or(|e| e != "md") {
                continue;
            }
            if !anchors.contains_key(&resolved) {
                let target_text = std::fs::read_to_string(&resolved)?;
                anchors.insert(resolved.clone(), heading_ids(&target_text));
            }
            if !anchors[&resolved].contains(anchor) {
                problems.push(format!("{shown}: `{target}`: no heading with id `{anchor}`"));
            }
        }
    }
    Ok(problems)
}

/// `a/b/../c` as `a/c`, without touching the file system.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// The targets of the inline links `[text](target)` and images of `text`,
/// outside code blocks and code spans.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        if fenced {
            continue;
        }
        // Drop code spans, which may hold `](` that is no link.
        let mut plain = String::new();
        for (i, piece) in line.split('`').enumerate() {
            if i % 2 == 0 {
                plain.push_str(piece);
            }
        }
        let mut rest = plain.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            let Some(end) = after.find(')') else { break };
            let target = after[..end].split_whitespace().next().unwrap_or("");
            if !target.is_empty() {
                out.push(target.to_owned());
            }
            rest = &after[end..];
        }
    }
    out
}

/// The ids mdbook (and GitHub) give a file's headings: lowercased, spaces as
/// `-`, only alphanumerics, `-` and `_` kept; a repeated id gets `-1`, `-2`, ….
fn heading_ids(text: &str) -> BTreeSet<String> {
    let mut ids = BTreeSet::new();
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
            continue;
        }
        let Some(title) = line.strip_prefix('#').filter(|_| !fenced) else { continue };
        let title = title.trim_start_matches('#');
        if !title.starts_with(' ') {
            continue;
        }
        let title = title.trim().replace('`', "");
        let id: String = title
            .chars()
            .flat_map(char::to_lowercase)
            .filter_map(|c| match c {
                ' ' => Some('-'),
                c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
                _ => None,
            })
            .collect();
        let n = seen.entry(id.clone()).or_insert(0);
        ids.insert(if *n == 0 { id.clone() } else { format!("{id}-{n}") });
        *n += 1;
    }
    ids
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heading_ids_follow_mdbook() {
        let ids =
            heading_ids("# The CPU backend\n## What stays the user's responsibility\n## `Gas` and `Ias`\n## A\n## A\n");
        let want = ["the-cpu-backend", "what-stays-the-users-responsibility", "gas-and-ias", "a", "a-1"];
        assert_eq!(ids, want.iter().map(|s| s.to_string()).collect());
    }

    #[test]
    fn links_skip_code() {
        let text = "see [a](a.md#x) and `[b](b.md)`\n```\n[c](c.md)\n```\n![pic](p.png \"t\")";
        assert_eq!(links(text), ["a.md#x", "p.png"]);
    }

    #[test]
    fn the_book_and_readmes_have_no_broken_links() {
        let problems = check_links(&crate::project_root()).expect("reading the book");
        assert!(problems.is_empty(), "broken links:\n{}", problems.join("\n"));
    }
}
