//! The `--denoise` options of a program's command line (the `cli` feature), for
//! `#[command(flatten)]` in a clap parser: the path tracers, the viewer's own
//! command line and the new-project template take the same three.

use crate::{DenoiseDevice, Denoiser, Result};

/// `--denoise`, `--denoise-device` and `--no-guides`.
#[derive(clap::Args, Clone, Debug, Default, PartialEq, Eq)]
pub struct DenoiseArgs {
    /// Denoise the picture with Intel Open Image Denoise (install it with
    /// `cargo xtask setup --denoise`; see `--denoise-device`, `--no-guides`).
    #[arg(long)]
    pub denoise: bool,
    /// Where the denoiser runs: `auto` (OIDN's CUDA device where it works, else
    /// the CPU), `cpu` or `cuda`.
    #[arg(long, value_enum, default_value_t = DenoiseDevice::Auto, requires = "denoise")]
    pub denoise_device: DenoiseDevice,
    /// Denoise the colour alone, without the first-hit albedo and normal guides.
    #[arg(long, requires = "denoise")]
    pub no_guides: bool,
}

impl DenoiseArgs {
    /// Whether guides are wanted: `--denoise` without `--no-guides`.
    pub fn guides(&self) -> bool {
        self.denoise && !self.no_guides
    }

    /// The denoiser `--denoise` asks for (loaded now, so a missing library fails
    /// before any rendering, naming its install command), or `None` without it.
    pub fn denoiser(&self) -> Result<Option<Denoiser>> {
        self.denoise.then(|| Denoiser::new(self.denoise_device)).transpose()
    }
}
