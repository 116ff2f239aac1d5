//! SPIR-V intake and reflection on arbitrary bytes: what `Module::new` runs before
//! Vulkan sees a module (size and magic check, the structural check, rspirv's
//! parser, entry-point and params-block reflection), then the params layout check
//! against a real host layout, and the error's message. None of it may panic, hang
//! or allocate without bound.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raykit::device::LaunchParams;
use raykit::spirv::{check, ParamsDelivery};

fuzz_target!(|data: &[u8]| {
    match raykit::module::reflect_entry_points(data) {
        Ok(entries) => {
            for entry in &entries {
                if entry.params.is_empty() {
                    continue;
                }
                for delivery in [ParamsDelivery::PushConstants, ParamsDelivery::UniformBuffer { set: 1, binding: 0 }] {
                    if let Err(e) = check(&triangle_device::Params::LAYOUT, &entry.name, &entry.params, delivery) {
                        std::hint::black_box(e.to_string());
                    }
                }
            }
        }
        Err(e) => {
            std::hint::black_box(e.to_string());
        }
    }
});
