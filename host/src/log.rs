//! Messages from the Vulkan validation layers, collected per context.
//!
//! With validation on ([`crate::ContextOptions::validation`]), every warning and
//! error the Khronos validation layer reports lands in the context's
//! [`MessageLog`]. raykit's tests require it to stay empty.

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

/// A shared, growing list of validation messages.
#[derive(Clone, Debug, Default)]
pub struct MessageLog {
    messages: Arc<Mutex<Vec<ValidationMessage>>>,
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
}
