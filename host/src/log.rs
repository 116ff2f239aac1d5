//! Messages from the Vulkan validation layers, collected per context.
//!
//! With validation on ([`crate::ContextOptions::validation`]), every warning and
//! error the Khronos validation layer reports lands in the context's
//! [`MessageLog`]. raykit's tests require it to stay empty.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// How serious a message is.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Severity {
    /// Informational.
    Info,
    /// A warning: legal but likely wrong or slow.
    Warning,
    /// An error: invalid API use.
    Error,
}

/// One message from the validation layer.
#[derive(Clone, Debug)]
pub struct ValidationMessage {
    /// Its severity.
    pub severity: Severity,
    /// The VUID or message id.
    pub id: String,
    /// The text.
    pub text: String,
}

impl std::fmt::Display for ValidationMessage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{:?}] {}: {}", self.severity, self.id, self.text)
    }
}

/// A shared, growing list of validation messages, which also records whether
/// its context has been destroyed.
#[derive(Clone, Debug, Default)]
pub struct MessageLog {
    messages: Arc<Mutex<Vec<ValidationMessage>>>,
    destroyed: Arc<AtomicBool>,
}

impl MessageLog {
    pub(crate) fn push(&self, message: ValidationMessage) {
        self.messages.lock().unwrap_or_else(|p| p.into_inner()).push(message);
    }

    /// A copy of every message so far.
    pub fn snapshot(&self) -> Vec<ValidationMessage> {
        self.messages.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// Removes and returns every message so far.
    pub fn take(&self) -> Vec<ValidationMessage> {
        std::mem::take(&mut *self.messages.lock().unwrap_or_else(|p| p.into_inner()))
    }

    /// Whether the context this log belongs to has been destroyed: its device and
    /// instance are gone, and the validation layer has said what it had to say
    /// about objects left alive. `false` after the last [`crate::Context`] handle
    /// was dropped means some raykit object (a buffer, a pipeline, …) still holds
    /// the context — leaked with `std::mem::forget`, kept in a static, or in a
    /// reference cycle.
    pub fn context_destroyed(&self) -> bool {
        self.destroyed.load(Ordering::Acquire)
    }

    pub(crate) fn mark_destroyed(&self) {
        self.destroyed.store(true, Ordering::Release);
    }
}
