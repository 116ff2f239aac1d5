//! The Vulkan half of the submission gate (test hook, `fault-injection` feature;
//! see `crate::gate`): a timeline semaphore every submission of the context
//! waits on while the gate is closed.

use std::sync::{Mutex, MutexGuard};

use ash::vk;

use crate::error::{Error, Result};
use crate::vulkan::context::ContextInner;

/// The gate's state: its semaphore (made on first close), the value submissions
/// wait for while it is closed, and the last value signalled.
#[derive(Default)]
pub(crate) struct GateState {
    semaphore: Option<vk::Semaphore>,
    closed_at: Option<u64>,
    signalled: u64,
}

/// A context's gate.
#[derive(Default)]
pub(crate) struct Gate {
    state: Mutex<GateState>,
}

impl Gate {
    fn lock(&self) -> MutexGuard<'_, GateState> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The semaphore and value a submission made now must wait for, if closed.
    pub(crate) fn wait(&self) -> Option<(vk::Semaphore, u64)> {
        let state = self.lock();
        Some((state.semaphore?, state.closed_at?))
    }

    /// Whether the gate is closed at `value` still.
    pub(crate) fn is_closed_at(&self, value: u64) -> bool {
        self.lock().closed_at == Some(value)
    }

    /// Destroys the semaphore.
    ///
    /// # Safety
    /// The gate must be open and no submission waiting on it pending.
    pub(crate) unsafe fn destroy(&self, device: &ash::Device) {
        if let Some(semaphore) = self.lock().semaphore.take() {
            // SAFETY: per the contract above.
            unsafe { device.destroy_semaphore(semaphore, None) };
        }
    }
}

impl ContextInner {
    /// Opens the gate if it is closed (signals the value gated submissions wait for).
    pub(crate) fn open_gate(&self) -> Result<()> {
        let mut state = self.gate.lock();
        let (Some(semaphore), Some(value)) = (state.semaphore, state.closed_at.take()) else { return Ok(()) };
        let info = vk::SemaphoreSignalInfo::default().semaphore(semaphore).value(value);
        // SAFETY: a live timeline semaphore of this device; `value` is above every
        // value signalled before (each close takes the next one).
        unsafe { self.device.signal_semaphore(&info) }
            .map_err(self.shared.error("vkSignalSemaphore", "opening the submission gate"))?;
        state.signalled = value;
        Ok(())
    }

    pub(crate) fn close_gate(&self) -> Result<u64> {
        let mut state = self.gate.lock();
        if let Some(value) = state.closed_at {
            return Ok(value);
        }
        if state.semaphore.is_none() {
            let mut kind = vk::SemaphoreTypeCreateInfo::default().semaphore_type(vk::SemaphoreType::TIMELINE);
            let info = vk::SemaphoreCreateInfo::default().push_next(&mut kind);
            // SAFETY: valid create info; the timelineSemaphore feature is enabled.
            let semaphore =
                unsafe { self.device.create_semaphore(&info, None) }.map_err(Error::vk("vkCreateSemaphore"))?;
            self.set_name(semaphore, "submission gate");
            state.semaphore = Some(semaphore);
        }
        let value = state.signalled + 1;
        state.closed_at = Some(value);
        Ok(value)
    }
}
