//! WGSL intake on arbitrary text: what `Module::from_wgsl` runs before Vulkan
//! sees a module — the limits on source size, tokens, nesting and expression
//! depth, naga's parser and validator on a thread of their own, the SPIR-V
//! writer and raykit's fix-ups (`raykit::wgsl::compile_to_bytes`) — then the
//! reflection every SPIR-V module gets (`raykit::module::reflect_entry_points`),
//! and every error's message. None of it may panic, hang or allocate without
//! bound.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(source) = std::str::from_utf8(data) else { return };
    match raykit::wgsl::compile_to_bytes(source, "fuzz.wgsl") {
        Ok(spirv) => match raykit::module::reflect_entry_points(&spirv) {
            Ok(entries) => {
                for entry in &entries {
                    std::hint::black_box((&entry.params, &entry.traces, entry.record, &entry.bindings));
                }
            }
            Err(e) => {
                std::hint::black_box(e.to_string());
            }
        },
        Err(e) => {
            std::hint::black_box(e.to_string());
        }
    }
});
