//! `cargo xtask lint`: the gates every change passes before the tests run
//! (`cargo xtask test` runs them first and stops at the first that fails).
//!
//! 1. `rustfmt`: `cargo fmt --all -- --check` with the tree's `rustfmt.toml`.
//! 2. `rustfmt outside the workspace`: the crates the workspace excludes
//!    (`builder/shader-builder` pins a nightly without rustfmt, `fuzz` is built by
//!    cargo-fuzz, `examples/first_renderer` and `examples/next_week` are projects of their own), checked with
//!    this stable rustfmt and the same `rustfmt.toml`.
//! 3. `committed binaries`: every binary file `git ls-files` lists is a test
//!    fixture with a `build.sh` and a `SHA256SUMS` beside it naming it
//!    (`tests/committed_spirv.rs` checks the hashes and rebuilds).
//! 4. `clippy`: `cargo clippy --workspace --all-targets -- -D warnings`.
//! 5. `rustdoc`: `RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps --lib`
//!    (broken or ambiguous intra-doc links, links to private items, …).
//! 6. `doctests`: `cargo test --workspace --doc` (the crates' examples, the
//!    README's, which `examples/triangle` compiles as its own doctests, and the
//!    book's, which `raykit-book` (`docs/book/doctests.rs`) compiles chapter by chapter).
//! 7. `book`: `mdbook build docs/book` with no warning, and no broken relative link
//!    or `#anchor` in the book or the READMEs (see `book.rs`; mdbook is installed
//!    into raykit's cache when missing).

use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context as _};

/// Files of the crates outside the workspace that rustfmt checks (it follows their
/// `mod` declarations).
const EXCLUDED_CRATE_ROOTS: [&str; 9] = [
    "builder/shader-builder/build.rs",
    "builder/shader-builder/src/main.rs",
    "fuzz/fuzz_targets/spirv_intake.rs",
    "examples/first_renderer/build.rs",
    "examples/first_renderer/src/main.rs",
    "examples/first_renderer/device/src/lib.rs",
    "examples/next_week/build.rs",
    "examples/next_week/src/main.rs",
    "examples/next_week/device/src/lib.rs",
];

/// One gate: its name, the command, and what to run to fix or see the problem.
struct Gate {
    name: &'static str,
    command: Command,
    fix: String,
}

impl Gate {
    fn cargo(name: &'static str, args: &[&str], fix: &str) -> Gate {
        let mut command = crate::cargo();
        command.args(args);
        Gate { name, command, fix: fix.to_owned() }
    }

    fn run(mut self) -> anyhow::Result<()> {
        println!("xtask lint: {}", self.name);
        let status = self.command.status().with_context(|| format!("starting the {} gate", self.name))?;
        if !status.success() {
            bail!("lint gate `{}` failed ({status}); to fix or see it: {}", self.name, self.fix);
        }
        Ok(())
    }
}

/// Runs every gate in order; the first that fails ends the run with an error
/// naming it and the command that fixes it or shows it again. clippy and rustdoc
/// go on past a crate that fails, so one run reports every crate's problems.
pub fn run_all(root: &Path) -> anyhow::Result<()> {
    Gate::cargo("rustfmt", &["fmt", "--all", "--", "--check"], "cargo fmt --all").run()?;

    let config = root.join("rustfmt.toml");
    let mut rustfmt = Command::new("rustfmt");
    rustfmt.current_dir(root).args(["--check", "--edition", "2021", "--config-path"]).arg(&config);
    rustfmt.args(EXCLUDED_CRATE_ROOTS);
    Gate {
        name: "rustfmt outside the workspace",
        command: rustfmt,
        fix: format!("rustfmt --edition 2021 --config-path rustfmt.toml {}", EXCLUDED_CRATE_ROOTS.join(" ")),
    }
    .run()?;

    println!("xtask lint: committed binaries");
    committed_binaries(root)?;

    println!("xtask lint: layers of host/src");
    crate::layers::check(root)?;
    crate::layers::check_dispatch(root)?;

    Gate::cargo(
        "clippy",
        &["clippy", "--workspace", "--all-targets", "--keep-going", "--", "-D", "warnings"],
        "cargo clippy --workspace --all-targets -- -D warnings",
    )
    .run()?;

    let mut doc = Gate::cargo(
        "rustdoc",
        &["doc", "--workspace", "--no-deps", "--lib", "--keep-going"],
        "RUSTDOCFLAGS=\"-D warnings\" cargo doc --workspace --no-deps --lib",
    );
    doc.command.env("RUSTDOCFLAGS", "-D warnings");
    doc.run()?;

    let mut doctests = Gate::cargo("doctests", &["test", "--workspace", "--doc"], "cargo test --workspace --doc");
    doctests.command.env("RAYKIT_SPIRV_DIR", crate::shaders::spirv_dir(root));
    doctests.run()?;

    println!("xtask lint: book");
    crate::book::check(root).context("lint gate `book` failed; to see it: mdbook build docs/book")
}

/// Fails when `git ls-files` lists a binary file (one with a NUL byte in its first
/// 8000 bytes, git's own test) that no `SHA256SUMS` beside it names.
fn committed_binaries(root: &Path) -> anyhow::Result<()> {
    let out = Command::new("git")
        .current_dir(root)
        .args(["ls-files", "-z"])
        .output()
        .context("running git ls-files (the committed-binaries gate needs git)")?;
    if !out.status.success() {
        bail!("git ls-files failed: {}", String::from_utf8_lossy(&out.stderr).trim());
    }
    let mut unexplained = Vec::new();
    for name in out.stdout.split(|&b| b == 0).filter(|n| !n.is_empty()) {
        let name = String::from_utf8_lossy(name);
        let path = root.join(&*name);
        let Ok(bytes) = std::fs::read(&path) else { continue }; // deleted in the work tree
        if !bytes.iter().take(8000).any(|&b| b == 0) {
            continue;
        }
        let file = path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
        let folder = path.parent().unwrap_or(root);
        let listed = std::fs::read_to_string(folder.join("SHA256SUMS"))
            .is_ok_and(|sums| sums.lines().any(|l| l.split_once("  ").is_some_and(|(_, f)| f == file)));
        if !listed || !folder.join("build.sh").exists() {
            unexplained.push(name.into_owned());
        }
    }
    if !unexplained.is_empty() {
        bail!(
            "lint gate `committed binaries` failed: {} tracked but not a documented fixture:\n  {}\n\
             A binary belongs in git only as a test fixture with a build.sh beside it that rebuilds it and \
             records it in SHA256SUMS (see tests/data/build.sh); otherwise remove it: git rm --cached FILE",
            if unexplained.len() == 1 { "this binary file is" } else { "these binary files are" },
            unexplained.join("\n  ")
        );
    }
    Ok(())
}
