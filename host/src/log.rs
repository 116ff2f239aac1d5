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
//! Each context's messages are its own, also when several contexts share one device
//! (see [`crate::context`]): raykit's debug names carry the id of the context that made
//! the object (`raykit#3 DeviceBuffer`), and the messenger hands a message to the
//! contexts whose objects it names, with the names as given (without the id). A
//! message that names no object of a live context (one about the device or queue
//! themselves, or about an object made through the raw handles and not named with
//! [`crate::Context::set_debug_name`]) goes to every context on the instance.
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
    /// Its debug name, if it has one (raykit names what it makes), as it was given:
    /// without the context id raykit's debug names carry for routing.
    pub name: Option<String>,
}

/// A user's log callback (OptiX's `OptixLogCallback`): called with every message
/// that reaches its context, on the thread of the Vulkan call that caused it. It
/// may run while raykit creates or destroys a device or a pipeline, under the locks
/// that guard those: it must not create or drop a [`crate::Context`] or a pipeline
/// itself (nor an object holding the last reference to one).
#[derive(Clone)]
#[doc(alias("OptixLogCallback", "optixDeviceContextSetLogCallback"))]
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

    /// Adds `message` to this log (and hands it to the log callback). The
    /// messenger records it in the thread's captures once, before delivering it.
    pub(crate) fn push(&self, message: ValidationMessage) {
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

    /// Whether the context this log belongs to has been destroyed: every object it
    /// made is gone and, if it was the last context on its device, the device too
    /// (and the validation layer has said what it had to say about objects left
    /// alive on it). `false` after the last [`crate::Context`] handle
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

/// The prefix of raykit's debug names, before the context id.
const TAG: &str = "raykit#";

/// `name` as the debug name of an object of context `context`.
pub(crate) fn tagged_name(context: u64, name: &str) -> String {
    format!("{TAG}{context} {name}")
}

/// The context id and the name given, of a debug name made by [`tagged_name`].
pub(crate) fn untag(name: &str) -> (Option<u64>, &str) {
    let Some(rest) = name.strip_prefix(TAG) else { return (None, name) };
    let Some((id, given)) = rest.split_once(' ') else { return (None, name) };
    match id.parse() {
        Ok(id) => (Some(id), given),
        Err(_) => (None, name),
    }
}

/// The live contexts of one instance and their logs: where its messenger delivers.
#[derive(Default)]
pub(crate) struct Routes {
    contexts: Mutex<Vec<(u64, MessageLog)>>,
}

impl Routes {
    /// Delivers messages naming context `id`'s objects (and those naming none) to `log`.
    pub(crate) fn add(&self, id: u64, log: MessageLog) {
        self.contexts.lock().unwrap_or_else(|p| p.into_inner()).push((id, log));
    }

    /// Stops delivering to context `id`.
    pub(crate) fn remove(&self, id: u64) {
        self.contexts.lock().unwrap_or_else(|p| p.into_inner()).retain(|(i, _)| *i != id);
    }

    /// The logs `message` goes to: those of the contexts in `named`, or every
    /// context's when none of them is alive.
    pub(crate) fn targets(&self, named: &[u64]) -> Vec<MessageLog> {
        let contexts = self.contexts.lock().unwrap_or_else(|p| p.into_inner());
        let chosen: Vec<MessageLog> =
            contexts.iter().filter(|(id, _)| named.contains(id)).map(|(_, log)| log.clone()).collect();
        if chosen.is_empty() {
            contexts.iter().map(|(_, log)| log.clone()).collect()
        } else {
            chosen
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn debug_names_carry_the_context_and_give_the_name_back() {
        assert_eq!(untag(&tagged_name(17, "DeviceBuffer")), (Some(17), "DeviceBuffer"));
        assert_eq!(untag(&tagged_name(3, "raykit module a b")), (Some(3), "raykit module a b"));
        assert_eq!(untag("deliberately leaked fence"), (None, "deliberately leaked fence"));
        assert_eq!(untag("raykit#x y"), (None, "raykit#x y"));
        assert_eq!(untag("raykit#5"), (None, "raykit#5"));
    }

    #[test]
    fn messages_go_to_the_contexts_they_name_or_to_all() {
        let routes = Routes::default();
        let (a, b) = (MessageLog::default(), MessageLog::default());
        routes.add(1, a.clone());
        routes.add(2, b.clone());
        assert_eq!(routes.targets(&[2]).len(), 1);
        routes.targets(&[2])[0].push(ValidationMessage {
            severity: Severity::Error,
            id: String::new(),
            text: "x".into(),
            objects: Vec::new(),
        });
        assert_eq!((a.snapshot().len(), b.snapshot().len()), (0, 1));
        assert_eq!(routes.targets(&[]).len(), 2);
        assert_eq!(routes.targets(&[9]).len(), 2, "a context that is gone: every live one");
        routes.remove(1);
        assert_eq!(routes.targets(&[1]).len(), 1);
    }
}
