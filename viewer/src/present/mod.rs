//! Getting the display pass's pixels onto the window: a swapchain on raykit's own
//! Vulkan device ([`vulkan`]), or softbuffer ([`soft`]) on the CPU backend and
//! where a Vulkan device cannot present.

pub mod soft;
pub mod vulkan;

use std::sync::Arc;

use raykit::Context;
use winit::window::Window;

use crate::display::{DisplayPass, PixelFormat};
use crate::error::{Result, ViewerError};

/// What a presentation did.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Presented {
    /// The frame is on the window.
    Shown,
    /// Nothing to show on (minimised, or the swapchain is being recreated).
    Skipped,
    /// The window's surface is this size, not the picture's: resize the picture.
    Resize(u32, u32),
}

/// A window's presenter.
pub enum Presenter {
    /// A swapchain on raykit's device; the pixels are copied into its images.
    Vulkan(Box<vulkan::SwapchainPresenter>),
    /// softbuffer; the pixels are read back to the host.
    Soft(soft::SoftPresenter),
}

impl Presenter {
    /// The presenter for `window` on `ctx`: a swapchain on a Vulkan context that
    /// can present to the window, softbuffer otherwise. Returns the pixel format
    /// the display pass must write.
    pub fn new(ctx: &Context, window: Arc<Window>) -> Result<(Presenter, PixelFormat)> {
        if ctx.backend() == raykit::Backend::Vulkan {
            match vulkan::SwapchainPresenter::new(ctx, window.clone()) {
                Ok((presenter, format)) => return Ok((Presenter::Vulkan(Box::new(presenter)), format)),
                Err(ViewerError::Presentation(why)) => {
                    eprintln!("viewer: the Vulkan device cannot present ({why}); presenting through softbuffer")
                }
                Err(e) => return Err(e),
            }
        }
        Ok((Presenter::Soft(soft::SoftPresenter::new(window)?), PixelFormat::SOFTBUFFER))
    }

    /// Shows the display pass's last picture.
    pub fn present(&mut self, display: &DisplayPass) -> Result<Presented> {
        match self {
            Presenter::Vulkan(p) => p.present(display),
            Presenter::Soft(p) => p.present(display),
        }
    }

    /// The window was resized: recreate what depends on its size.
    pub fn resized(&mut self) {
        if let Presenter::Vulkan(p) = self {
            p.mark_out_of_date();
        }
    }

    /// What presents: `swapchain` or `softbuffer`.
    pub fn name(&self) -> &'static str {
        match self {
            Presenter::Vulkan(_) => "swapchain",
            Presenter::Soft(_) => "softbuffer",
        }
    }
}
