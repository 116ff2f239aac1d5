//! Every single-word corruption of a small module: each must be refused by
//! `Module::new` or, if accepted, be valid SPIR-V (the validation layer runs
//! spirv-val on every `vkCreateShaderModule` and the harness fails on its
//! messages). raykit checks the structure, the grammar (rspirv) and the ids of a
//! module, then runs SPIRV-Tools' validator on it (`raykit::validate::spirv`),
//! so none reaches the driver.

use raykit::Module;
use raykit_tests::with_context;

#[test]
fn single_word_corruptions_never_reach_the_driver_as_invalid_spirv() -> anyhow::Result<()> {
    with_context("single_word_corruptions_never_reach_the_driver_as_invalid_spirv", |ctx| {
        let base = include_bytes!("../data/raygen_main.rgen.spv");
        let log = ctx.messages();
        let mut reached = Vec::new();
        for word in 5..base.len() / 4 {
            for flip in [1u32, 0x100, 0x1_0000, 7] {
                let mut bytes = base.to_vec();
                let at = word * 4;
                let w = u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]) ^ flip;
                bytes[at..at + 4].copy_from_slice(&w.to_le_bytes());
                if Module::new(ctx, &bytes).is_ok() {
                    if let Some(message) = log.take().first() {
                        reached.push(format!("word {word} ^ {flip:#x}: {}", message.text));
                    }
                }
            }
        }
        anyhow::ensure!(reached.is_empty(), "{} corruptions reached the driver: {}", reached.len(), reached.join("\n"));
        Ok(())
    })
}
