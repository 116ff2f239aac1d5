//! SPIR-V intake and reflection on arbitrary bytes: what `Module::new` runs before
//! Vulkan sees a module (size and magic check, the structural check, rspirv's
//! parser, entry-point and params-block reflection), then the params layout check
//! against a real host layout, and the error's message. Inputs that reflect go on
//! through what linking runs: specialization constants frozen in (with values
//! taken from the input) and SPIRV-Tools' validator (the installed `spirv-val`,
//! so each such input costs a process: about 10 ms). None of it may panic, hang
//! or allocate without bound.
#![no_main]

use libfuzzer_sys::fuzz_target;
use raykit::device::LaunchParams;
use raykit::spirv::{check, ParamsDelivery};

fuzz_target!(|data: &[u8]| {
    match raykit::module::reflect_entry_points(data) {
        Ok(entries) => {
            let words: Vec<u32> = data.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
            // Spec constant 3 takes the input's last word: 0, 2^31 and everything between.
            let value = words.last().copied().unwrap_or(0);
            match raykit::validate::spirv::freeze_spec_constants(&words, &[(3, value), (0, 1)]) {
                Ok(frozen) => {
                    if let Err(e) = raykit::validate::spirv::validate(&frozen) {
                        std::hint::black_box(e.to_string());
                    }
                }
                Err(e) => {
                    std::hint::black_box(e.to_string());
                }
            }
            for entry in &entries {
                std::hint::black_box((&entry.traces, &entry.bindings));
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
