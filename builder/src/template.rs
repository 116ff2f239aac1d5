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

/// The package name of a new project written into `dest`: the directory's name,
/// with characters cargo does not accept in a name (anything but ASCII letters,
/// digits, `-` and `_`) turned into `-`, lowercased. The device crate is
/// `<name>-device`. A name that is empty, starts with a digit or is reserved
/// is [`Error::ProjectName`], with the fix.
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
    if name.starts_with(|c: char| c.is_ascii_digit()) {
        return Err(refuse(format!("package names cannot start with a digit (`{name}`)")));
    }
    if RESERVED_NAMES.contains(&name.as_str()) {
        return Err(refuse(format!("`{name}` is a Rust keyword or a standard-library crate")));
    }
    Ok(name)
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
}
