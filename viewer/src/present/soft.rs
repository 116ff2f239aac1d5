//! Presentation through softbuffer: the pixels are read back from the display
//! pass's buffer (host memory on the CPU backend) and put on the window.

use std::num::NonZeroU32;
use std::sync::Arc;

use winit::window::Window;

use crate::display::DisplayPass;
use crate::error::{Result, ViewerError};
use crate::present::Presented;

/// A softbuffer surface on a window.
pub struct SoftPresenter {
    surface: softbuffer::Surface<Arc<Window>, Arc<Window>>,
    /// Kept for the surface's life.
    _context: softbuffer::Context<Arc<Window>>,
}

impl SoftPresenter {
    /// A surface on `window`.
    pub fn new(window: Arc<Window>) -> Result<SoftPresenter> {
        let error = |e: softbuffer::SoftBufferError| ViewerError::Softbuffer(e.to_string());
        let context = softbuffer::Context::new(window.clone()).map_err(error)?;
        let surface = softbuffer::Surface::new(&context, window).map_err(error)?;
        Ok(SoftPresenter { surface, _context: context })
    }

    /// Shows the display pass's pixels (softbuffer's `0RGB` words).
    pub fn present(&mut self, display: &DisplayPass) -> Result<Presented> {
        let error = |e: softbuffer::SoftBufferError| ViewerError::Softbuffer(e.to_string());
        let (width, height) = display.size();
        let (Some(w), Some(h)) = (NonZeroU32::new(width), NonZeroU32::new(height)) else {
            return Ok(Presented::Skipped);
        };
        let pixels = display.pixels().read()?;
        self.surface.resize(w, h).map_err(error)?;
        let mut buffer = self.surface.buffer_mut().map_err(error)?;
        if buffer.len() != pixels.len() {
            return Ok(Presented::Skipped);
        }
        buffer.copy_from_slice(&pixels);
        buffer.present().map_err(error)?;
        Ok(Presented::Shown)
    }
}
