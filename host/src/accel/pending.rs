//! Builds in flight: what an asynchronous build returns.

use crate::error::Result;
use crate::vulkan::accel::build::InFlight;

/// Builds submitted to the GPU and not yet waited for: OptiX's asynchronous
/// `optixAccelBuild` on a stream. [`PendingBuild::wait`] returns the built
/// structures; dropping it waits too, so nothing is freed while in use.
#[must_use = "a PendingBuild holds the structures being built; call wait() to get them"]
pub struct PendingBuild<T> {
    // Field order matters: the in-flight work is waited on before `value` drops.
    /// The work on the device; `None` for structures built already (the CPU backend).
    in_flight: Option<InFlight>,
    value: T,
    finish: fn(&mut T, &[u64]),
}

impl<T> PendingBuild<T> {
    pub(crate) fn new(in_flight: InFlight, value: T, finish: fn(&mut T, &[u64])) -> Self {
        PendingBuild { in_flight: Some(in_flight), value, finish }
    }

    /// Structures built already.
    pub(crate) fn ready(value: T) -> Self {
        PendingBuild { in_flight: None, value, finish: |_, _| {} }
    }

    /// Whether the GPU has finished, without blocking.
    pub fn is_ready(&self) -> Result<bool> {
        self.in_flight.as_ref().map_or(Ok(true), InFlight::is_done)
    }

    /// Blocks until the builds have finished; releases their scratch and input
    /// memory and returns the structures.
    pub fn wait(self) -> Result<T> {
        let PendingBuild { in_flight, mut value, finish } = self;
        if let Some(in_flight) = in_flight {
            let sizes = in_flight.wait()?;
            finish(&mut value, &sizes);
        }
        Ok(value)
    }
}

impl<T> std::fmt::Debug for PendingBuild<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PendingBuild").finish_non_exhaustive()
    }
}
