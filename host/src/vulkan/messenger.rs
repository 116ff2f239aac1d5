//! The debug messenger's callback on Vulkan: what `VK_EXT_debug_utils` reports,
//! turned into [`ValidationMessage`]s and delivered to the contexts whose objects
//! it names (see [`crate::log`]).

use std::ffi::{c_void, CStr};

use ash::vk;

use crate::log::{record_in_captures, untag, LoggedObject, Routes, Severity, ValidationMessage};

/// The debug messenger's callback: turns the message into a [`ValidationMessage`],
/// records it in this thread's captures and delivers it to the contexts it concerns.
pub(crate) unsafe extern "system" fn debug_callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user_data: *mut c_void,
) -> vk::Bool32 {
    if user_data.is_null() || data.is_null() {
        return vk::FALSE;
    }
    // SAFETY: `user_data` is the instance's `Routes`, which lives for the rest of the
    // process; `data` and the strings and objects it points to are valid for this call.
    let (routes, data) = unsafe { (&*(user_data as *const Routes), &*data) };
    let text = |p: *const std::ffi::c_char| {
        if p.is_null() {
            String::new()
        } else {
            // SAFETY: as above: the strings of `data` are valid and NUL-terminated.
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    let mut named = Vec::new();
    let objects = if data.p_objects.is_null() || data.object_count == 0 {
        Vec::new()
    } else {
        // SAFETY: `p_objects` holds `object_count` objects.
        unsafe { std::slice::from_raw_parts(data.p_objects, data.object_count as usize) }
            .iter()
            .map(|o| {
                let name = (!o.p_object_name.is_null()).then(|| text(o.p_object_name)).map(|name| {
                    let (context, given) = untag(&name);
                    named.extend(context);
                    given.to_owned()
                });
                LoggedObject { object_type: format!("{:?}", o.object_type), handle: o.object_handle, name }
            })
            .collect()
    };
    let severity = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) {
        Severity::Error
    } else if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::WARNING) {
        Severity::Warning
    } else {
        Severity::Info
    };
    let message = ValidationMessage { severity, id: text(data.p_message_id_name), text: text(data.p_message), objects };
    record_in_captures(&message);
    for log in routes.targets(&named) {
        log.push(message.clone());
    }
    vk::FALSE
}
