//! A new project that uses raykit: a host binary whose `build.rs` compiles its
//! device crate through raykit-builder and embeds the SPIR-V.

use std::path::{Path, PathBuf};

use crate::error::{io, Error, Result};

/// The template's files: their path in the new project and their text, with
/// `{{raykit}}` standing for the raykit checkout, `{{name}}` for the package name
/// and `{{crate}}` for it as a Rust identifier.
const FILES: [(&str, &str); 7] = [
    ("Cargo.toml", include_str!("../../templates/new-project/Cargo.toml.tmpl")),
    ("build.rs", include_str!("../../templates/new-project/build.rs.tmpl")),
    ("src/main.rs", include_str!("../../templates/new-project/src/main.rs.tmpl")),
    ("src/view.rs", include_str!("../../templates/new-project/src/view.rs.tmpl")),
    ("device/Cargo.toml", include_str!("../../templates/new-project/device/Cargo.toml.tmpl")),
    ("device/src/lib.rs", include_str!("../../templates/new-project/device/src/lib.rs.tmpl")),
    (".gitignore", include_str!("../../templates/new-project/gitignore.tmpl")),
];

/// The raykit checkout this crate belongs to.
pub fn raykit_root() -> PathBuf {
    let builder = Path::new(env!("CARGO_MANIFEST_DIR"));
    builder.parent().map(Path::to_path_buf).unwrap_or_else(|| builder.to_path_buf())
}

/// Names a Rust keyword or a crate of the standard library, which cargo refuses
/// (or which would shadow the standard library) as a package name.
const RESERVED_NAMES: [&str; 57] = [
    "as",
    "async",
    "await",
    "box",
    "break",
    "const",
    "continue",
    "crate",
    "dyn",
    "else",
    "enum",
    "extern",
    "false",
    "fn",
    "for",
    "if",
    "impl",
    "in",
    "let",
    "loop",
    "match",
    "mod",
    "move",
    "mut",
    "pub",
    "ref",
    "return",
    "self",
    "static",
    "struct",
    "super",
    "trait",
    "true",
    "type",
    "unsafe",
    "use",
    "where",
    "while",
    "abstract",
    "become",
    "do",
    "final",
    "macro",
    "override",
    "priv",
    "try",
    "typeof",
    "unsized",
    "virtual",
    "yield",
    "gen",
    "std",
    "core",
    "alloc",
    "test",
    "proc_macro",
    "proc-macro",
];

/// Names cargo refuses for packages because they are directories of its own
/// build output (`target/debug/deps`, ...).
const CARGO_ARTIFACT_NAMES: [&str; 4] = ["build", "deps", "examples", "incremental"];

/// File names Windows reserves (cargo refuses them there): a project named so
/// could not be checked out on Windows.
const WINDOWS_RESERVED_NAMES: [&str; 22] = [
    "con", "prn", "aux", "nul", "com1", "com2", "com3", "com4", "com5", "com6", "com7", "com8", "com9", "lpt1", "lpt2",
    "lpt3", "lpt4", "lpt5", "lpt6", "lpt7", "lpt8", "lpt9",
];

/// The package names of raykit's workspace. A new project depends on some of
/// them and cargo tells packages apart by name (with `-` and `_` the same), so
/// neither the project nor its device crate may take one.
const RAYKIT_PACKAGES: [&str; 31] = [
    "accel-test-device",
    "gltf-pathtracer-device",
    "gltf_pathtracer",
    "math-test-device",
    "next-week-reference",
    "one-dependency",
    "params-device",
    "path-tracer-device",
    "path_tracer",
    "program-model",
    "program-model-device",
    "raykit",
    "raykit-abi",
    "raykit-bench",
    "raykit-book",
    "raykit-builder",
    "raykit-denoise",
    "raykit-device",
    "raykit-macros",
    "raykit-scene",
    "raykit-spirv",
    "raykit-tests",
    "raykit-viewer",
    "raykit-viewer-device",
    "raykit-wgsl",
    "spheres-test-device",
    "stack-test-device",
    "texture-test-device",
    "triangle",
    "triangle-device",
    "xtask",
];

/// `name` as cargo compares package names: `_` and `-` are the same.
fn normalised(name: &str) -> String {
    name.replace('_', "-")
}

/// Why cargo (or raykit's workspace) would not take `name` as a package name.
fn refusal(name: &str) -> Option<String> {
    let same = |reserved: &str| normalised(reserved) == normalised(name);
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        return Some(format!("package names cannot start with a digit (`{name}`)"));
    }
    if RESERVED_NAMES.iter().any(|r| same(r)) {
        return Some(format!("`{name}` is a Rust keyword or a standard-library crate"));
    }
    if CARGO_ARTIFACT_NAMES.iter().any(|r| same(r)) {
        return Some(format!("cargo refuses `{name}` as a package name: it is one of its build directories"));
    }
    if WINDOWS_RESERVED_NAMES.iter().any(|r| same(r)) {
        return Some(format!("`{name}` is a file name Windows reserves"));
    }
    let device = format!("{name}-device");
    if let Some(taken) = RAYKIT_PACKAGES.iter().find(|r| same(r) || normalised(r) == normalised(&device)) {
        let which = if same(taken) { "the project" } else { "its device crate" };
        return Some(format!(
            "{which} would be named `{taken}`, the name of one of raykit's own packages, which cargo would confuse \
             with it"
        ));
    }
    None
}

/// The package name of a new project written into `dest`: the directory's name,
/// with characters cargo does not accept in a name (anything but ASCII letters,
/// digits, `-` and `_`) turned into `-`, lowercased. The device crate is
/// `<name>-device`. A name that is empty, starts with a digit, is a keyword, a
/// standard-library crate, one of cargo's build directories (`build`, `deps`,
/// `examples`, `incremental`), a name Windows reserves, or would make the
/// project or its device crate share a name with one of raykit's packages is
/// [`Error::ProjectName`], with the fix.
pub fn project_name(dest: &Path) -> Result<String> {
    let refuse = |reason: String| Error::ProjectName { path: dest.to_owned(), reason };
    let Some(base) = dest.file_name().and_then(|n| n.to_str()) else {
        let reason = "the path has no final directory name in UTF-8".to_owned();
        return Err(refuse(reason));
    };
    let mut name: String = base
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || c == '_' { c.to_ascii_lowercase() } else { '-' })
        .collect();
    while name.contains("--") {
        name = name.replace("--", "-");
    }
    let name = name.trim_matches('-').to_owned();
    if name.is_empty() {
        return Err(refuse(format!("`{base}` has no letters or digits to make a package name from")));
    }
    match refusal(&name) {
        Some(reason) => Err(refuse(reason)),
        None => Ok(name),
    }
}

/// Writes a new project into `dest`, which must be missing or empty, depending
/// on raykit at `raykit` by path: a host package named after the directory (see
/// [`project_name`]) and its device crate `<name>-device`. Returns the files
/// written.
pub fn write_new_project(dest: &Path, raykit: &Path) -> Result<Vec<PathBuf>> {
    if std::fs::read_dir(dest).is_ok_and(|mut d| d.next().is_some()) {
        return Err(Error::NotEmpty { path: dest.to_owned() });
    }
    let name = project_name(dest)?;
    let crate_name = name.replace('-', "_");
    let raykit = raykit.canonicalize().map_err(io("finding raykit at", raykit))?;
    let raykit = raykit.to_str().ok_or_else(|| Error::NotEmpty { path: raykit.clone() })?.replace('\\', "/");
    let mut written = Vec::new();
    for (file, text) in FILES {
        let path = dest.join(file);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(io("creating", parent))?;
        }
        let text = text.replace("{{raykit}}", &raykit).replace("{{name}}", &name).replace("{{crate}}", &crate_name);
        std::fs::write(&path, text).map_err(io("writing", &path))?;
        written.push(path);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_every_file_with_the_raykit_path() {
        let dest = std::env::temp_dir().join(format!("raykit-template-unit-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dest);
        let files = write_new_project(&dest, &raykit_root()).unwrap();
        assert_eq!(files.len(), FILES.len());
        let manifest = std::fs::read_to_string(dest.join("Cargo.toml")).unwrap();
        assert!(manifest.contains(&format!("{}/host", raykit_root().canonicalize().unwrap().display())));
        assert!(!manifest.contains("{{"));
        assert!(manifest.contains(&format!("name = \"raykit-template-unit-{}\"", std::process::id())), "{manifest}");
        let main = std::fs::read_to_string(dest.join("src/main.rs")).unwrap();
        assert!(main.contains(&format!("use raykit_template_unit_{}_device::", std::process::id())), "{main}");
        let err = write_new_project(&dest, &raykit_root()).unwrap_err();
        assert!(matches!(err, Error::NotEmpty { .. }), "{err}");
        std::fs::remove_dir_all(&dest).unwrap();
    }

    #[test]
    fn the_package_name_comes_from_the_directory() {
        let name = |p: &str| project_name(Path::new(p)).map_err(|e| e.to_string());
        assert_eq!(name("/tmp/spheres").as_deref(), Ok("spheres"));
        assert_eq!(name("work/My Renderer").as_deref(), Ok("my-renderer"));
        assert_eq!(name("a/weekend_2.0/").as_deref(), Ok("weekend_2-0"));
        for (path, says) in [("/tmp/2d", "start with a digit"), ("/tmp/...", "no letters"), ("x/fn", "keyword")] {
            let err = name(path).unwrap_err();
            assert!(err.contains(says) && err.contains("choose"), "{path}: {err}");
        }
    }

    #[test]
    fn names_cargo_or_raykit_would_refuse_are_refused_with_the_reason() {
        let cases = [
            ("x/build", "build directories"),
            ("x/deps", "build directories"),
            ("x/Examples", "build directories"),
            ("x/incremental", "build directories"),
            ("x/test", "standard-library"),
            ("x/std", "standard-library"),
            ("x/core", "standard-library"),
            ("x/proc_macro", "standard-library"),
            ("x/match", "keyword"),
            ("x/3d-renderer", "start with a digit"),
            ("x/CON", "Windows"),
            ("x/lpt1", "Windows"),
            ("x/raykit", "`raykit`"),
            ("x/raykit_device", "`raykit-device`"),
            ("x/Raykit Scene", "`raykit-scene`"),
            ("x/xtask", "`xtask`"),
            ("x/triangle", "the project would be named `triangle`"),
            ("x/params", "its device crate would be named `params-device`"),
            ("x/raykit-viewer", "`raykit-viewer`"),
        ];
        for (path, says) in cases {
            let err = project_name(Path::new(path)).expect_err(path).to_string();
            let name = Path::new(path).file_name().unwrap().to_str().unwrap();
            assert!(err.contains(name) && err.contains(says) && err.contains("choose another"), "{path}: {err}");
        }
        for ok in ["builder", "my-deps", "tests", "raykit-demo", "triangles", "core2"] {
            assert!(project_name(&Path::new("x").join(ok)).is_ok(), "{ok}");
        }
    }

    #[test]
    fn the_reserved_package_names_are_those_of_the_workspace() {
        let root = raykit_root();
        let manifest = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
        let members = manifest.split("members = [").nth(1).and_then(|m| m.split(']').next()).unwrap();
        let mut names: Vec<String> = members
            .split(',')
            .map(|m| m.trim().trim_matches('"'))
            .filter(|m| !m.is_empty())
            .map(|member| {
                let package = std::fs::read_to_string(root.join(member).join("Cargo.toml")).unwrap();
                let line = package.lines().find(|l| l.starts_with("name")).unwrap().to_owned();
                line.split('"').nth(1).unwrap().to_owned()
            })
            .collect();
        names.sort();
        assert_eq!(names, RAYKIT_PACKAGES, "update RAYKIT_PACKAGES to the workspace's members");
    }
}
