//! A test hook (the `fault-injection` feature, never in normal builds): a gate
//! in front of the device that holds a context's submissions until the test
//! opens it, so work is surely still pending while the test drops, updates or
//! rebuilds what that work uses, however fast the GPU.
//!
//! While a [`SubmissionGate`] is closed, every submission of its context waits on
//! the device (a wait on a
//! [timeline semaphore](https://registry.khronos.org/vulkan/specs/latest/html/vkspec.html#synchronization-semaphores)
//! in `vkQueueSubmit`) for the value the gate signals from the host when it opens.
//! Drops never wait (they queue on the GPU timeline, see [`crate::timeline`]), so
//! they cannot hang on a closed gate. A host wait can: any blocking wait of the
//! context ([`crate::Launch::wait`], [`crate::DeviceBuffer::read`],
//! [`crate::Context::wait_idle`], a blocking build, the context's drop, …) opens
//! the gate first, so a gate left closed never deadlocks; a test checks with
//! [`SubmissionGate::is_open`] that nothing waited where it should not have.

use std::sync::Arc;

use crate::context::{Context, ContextRepr};
use crate::error::Result;
use crate::vulkan::context::ContextInner;
/// A closed gate in front of the device for one context's submissions (test hook,
/// `fault-injection` feature): see the [module docs](self). Dropping it opens it.
#[must_use = "the gate opens when dropped"]
pub struct SubmissionGate {
    owner: GateOwner,
    value: u64,
}

/// The context whose gate it is.
enum GateOwner {
    Vulkan(Arc<ContextInner>),
    Cpu(Arc<crate::cpu::CpuContext>),
}

impl SubmissionGate {
    /// Whether the gate is open: by [`SubmissionGate::open`], or by a host wait of
    /// the context meanwhile.
    pub fn is_open(&self) -> bool {
        match &self.owner {
            GateOwner::Vulkan(ctx) => !ctx.gate.is_closed_at(self.value),
            GateOwner::Cpu(ctx) => !ctx.gate.is_closed(),
        }
    }

    /// Opens the gate: the held submissions start on the device.
    pub fn open(self) -> Result<()> {
        self.open_now()
    }

    fn open_now(&self) -> Result<()> {
        match &self.owner {
            GateOwner::Vulkan(ctx) => ctx.open_gate(),
            GateOwner::Cpu(ctx) => {
                ctx.gate.open();
                Ok(())
            }
        }
    }
}

impl Drop for SubmissionGate {
    fn drop(&mut self) {
        // Errors only on a lost device, where nothing waits on the gate any more.
        let _ = self.open_now();
    }
}

impl std::fmt::Debug for SubmissionGate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SubmissionGate").field("open", &self.is_open()).finish()
    }
}

impl Context {
    /// Test hook: closes a gate in front of the device, so every submission of
    /// this context from now on waits on the device until the gate opens (see
    /// [`crate::gate`]). Closing a closed gate returns the same gate.
    #[doc(hidden)]
    pub fn close_submission_gate(&self) -> Result<SubmissionGate> {
        match self.repr() {
            ContextRepr::Cpu(cpu) => {
                cpu.gate.close();
                Ok(SubmissionGate { owner: GateOwner::Cpu(cpu.clone()), value: 0 })
            }
            ContextRepr::Vulkan(inner) => {
                let value = inner.close_gate()?;
                Ok(SubmissionGate { owner: GateOwner::Vulkan(inner.clone()), value })
            }
        }
    }
}

impl Context {
    /// Test hook: from now on, device-local buffers of this Vulkan context that
    /// the host could map are read and written through staging copies, as on a
    /// GPU whose memory the host cannot map (made before or after the call). No
    /// effect on the CPU backend.
    #[doc(hidden)]
    pub fn force_staging_copies(&self, on: bool) {
        if let Some(inner) = self.as_vulkan() {
            inner.force_staging.store(on, std::sync::atomic::Ordering::Relaxed);
        }
    }
}
