//! With the library hidden (`RAYKIT_OIDN_DIR` naming an empty folder), creating
//! a denoiser is a typed error that names the install command. One test in its
//! own binary: it sets the variable for the whole process.

use raykit_denoise::{DenoiseDevice, Denoiser, Error, INSTALL_COMMAND, LIBRARY_DIR_VAR};

#[test]
fn a_hidden_library_is_a_typed_error_naming_the_command() {
    let empty = std::env::temp_dir().join(format!("raykit-denoise-hidden-{}", std::process::id()));
    std::fs::create_dir_all(&empty).unwrap();
    std::env::set_var(LIBRARY_DIR_VAR, &empty);
    for device in [DenoiseDevice::Auto, DenoiseDevice::Cpu, DenoiseDevice::Cuda] {
        let err = Denoiser::new(device).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, Error::LibraryMissing { .. }), "{device:?}: {text}");
        assert!(text.contains(INSTALL_COMMAND), "{text}");
        assert!(text.contains(&empty.display().to_string()), "{text}");
    }
    println!("{}", Denoiser::new(DenoiseDevice::Cpu).unwrap_err());
}
