//! A new project that uses raykit: a host binary whose `build.rs` compiles its
//! device crate through raykit-builder and embeds the SPIR-V.

use std::path::{Path, PathBuf};

use crate::error::{io, Error, Result};

/// The template's files: their path in the new project and their text, with
/// `{{raykit}}` standing for the raykit checkout.
const FILES: [(&str, &str); 6] = [
    ("Cargo.toml", include_str!("../../templates/new-project/Cargo.toml.tmpl")),
    ("build.rs", include_str!("../../templates/new-project/build.rs.tmpl")),
    ("src/main.rs", include_str!("../../templates/new-project/src/main.rs.tmpl")),
    ("device/Cargo.toml", include_str!("../../templates/new-project/device/Cargo.toml.tmpl")),
    ("device/src/lib.rs", include_str!("../../templates/new-project/device/src/lib.rs.tmpl")),
    (".gitignore", include_str!("../../templates/new-project/gitignore.tmpl")),
];

/// The raykit checkout this crate belongs to.
pub fn raykit_root() -> PathBuf {
    let builder = Path::new(env!("CARGO_MANIFEST_DIR"));
    builder.parent().map(Path::to_path_buf).unwrap_or_else(|| builder.to_path_buf())
}

/// Writes a new project (`my-app` and its device crate `my-app-device`) into
/// `dest`, which must be missing or empty, depending on raykit at `raykit` by
/// path. Returns the files written.
pub fn write_new_project(dest: &Path, raykit: &Path) -> Result<Vec<PathBuf>> {
    if std::fs::read_dir(dest).is_ok_and(|mut d| d.next().is_some()) {
        return Err(Error::NotEmpty { path: dest.to_owned() });
    }
    let raykit = raykit.canonicalize().map_err(io("finding raykit at", raykit))?;
    let raykit = raykit.to_str().ok_or_else(|| Error::NotEmpty { path: raykit.clone() })?.replace('\\', "/");
    let mut written = Vec::new();
    for (name, text) in FILES {
        let path = dest.join(name);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(io("creating", parent))?;
        }
        std::fs::write(&path, text.replace("{{raykit}}", &raykit)).map_err(io("writing", &path))?;
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
        let err = write_new_project(&dest, &raykit_root()).unwrap_err();
        assert!(matches!(err, Error::NotEmpty { .. }), "{err}");
        std::fs::remove_dir_all(&dest).unwrap();
    }
}
