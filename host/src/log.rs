//! Logs: OptiX's log callback and log strings, on
//! [`VK_EXT_debug_utils`](https://registry.khronos.org/vulkan/specs/latest/man/html/VK_EXT_debug_utils.html).
//!
//! With validation on ([`crate::ContextOptions::validation`]), every warning and
//! error the Khronos validation layer reports lands in the context's
//! [`MessageLog`]; raykit's tests require it to stay empty. A [`LogCallback`] in
//! [`crate::ContextOptions::log_callback`] also receives each message as it is
//! reported, with its level, text and the objects it concerns — named, since raykit
//! names the Vulkan objects it makes (`vkSetDebugUtilsObjectNameEXT`).
//!
//! The layer reports on the thread that makes the Vulkan call, so raykit also
//! collects what was reported during one creation call: [`crate::Module::creation_log`]
//! and [`crate::Pipeline::creation_log`] (OptiX's log strings of
//! `optixModuleCreate` and `optixPipelineCreate`).

use std::cell::RefCell;
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
    /// The Vulkan objects it concerns.
    pub objects: Vec<LoggedObject>,
}

/// A Vulkan object a message concerns.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LoggedObject {
    /// Its type, e.g. `FENCE`, `PIPELINE`.
    pub object_type: String,
    /// Its handle.
    pub handle: u64,
    /// Its debug name, if it has one (raykit names what it makes).
    pub name: Option<String>,
}

/// A user's log callback (OptiX's `OptixLogCallback`): called with every message
/// the context's debug messenger reports, on the thread of the Vulkan call that
/// caused it.
#[derive(Clone)]
pub struct LogCallback(Arc<dyn Fn(&ValidationMessage) + Send + Sync>);

impl LogCallback {
    /// Wraps `f`.
    pub fn new(f: impl Fn(&ValidationMessage) + Send + Sync + 'static) -> LogCallback {
        LogCallback(Arc::new(f))
    }

    pub(crate) fn call(&self, message: &ValidationMessage) {
        (self.0)(message);
    }
}

impl std::fmt::Debug for LogCallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("LogCallback(..)")
    }
}

thread_local! {
    /// Messages reported on this thread during the creation calls in progress.
    static CAPTURES: RefCell<Vec<Vec<ValidationMessage>>> = const { RefCell::new(Vec::new()) };
}

/// Runs `f` and returns, with its result, the messages reported on this thread
/// while it ran.
pub(crate) fn capture<R>(f: impl FnOnce() -> R) -> (R, Vec<ValidationMessage>) {
    CAPTURES.with(|c| c.borrow_mut().push(Vec::new()));
    let result = f();
    let messages = CAPTURES.with(|c| c.borrow_mut().pop()).unwrap_or_default();
    (result, messages)
}

/// Adds `message` to every capture in progress on this thread.
pub(crate) fn record_in_captures(message: &ValidationMessage) {
    // `try_with`: the callback may run while the thread is shutting down.
    let _ = CAPTURES.try_with(|c| {
        if let Ok(mut captures) = c.try_borrow_mut() {
            for capture in captures.iter_mut() {
                capture.push(message.clone());
            }
        }
    });
}

impl std::fmt::Display for ValidationMessage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "[{:?}] {}: {}", self.severity, self.id, self.text)?;
        for o in &self.objects {
            write!(
                f,
                " [{} {:#x}{}]",
                o.object_type,
                o.handle,
                o.name.as_deref().map(|n| format!(" \"{n}\"")).unwrap_or_default()
            )?;
        }
        Ok(())
    }
}

/// A shared, growing list of validation messages, which also records whether
/// its context has been destroyed.
#[derive(Clone, Debug, Default)]
pub struct MessageLog {
    messages: Arc<Mutex<Vec<ValidationMessage>>>,
    callback: Option<LogCallback>,
    destroyed: Arc<AtomicBool>,
}

impl MessageLog {
    pub(crate) fn with_callback(callback: Option<LogCallback>) -> MessageLog {
        MessageLog { messages: Arc::default(), callback, destroyed: Arc::default() }
    }

    pub(crate) fn push(&self, message: ValidationMessage) {
        record_in_captures(&message);
        if let Some(callback) = &self.callback {
            // This runs inside Vulkan's callback: a panic must not unwind into C.
            let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| callback.call(&message)));
        }
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
