//! Buffer elements: the layout `#[derive(Element)]` recorded on the host against
//! the one its hidden compute entry point (`__raykit_element__<Struct>`) gives the SPIR-V.
//!
//! Device programs read a buffer element word by word, where the device
//! compiler put each field; the derive makes each target's compiler put field
//! `k` at 4 × its first word, so comparing the two recorded layouts compares the
//! words the host writes with the words the device reads.

use std::collections::HashMap;

use raykit_abi::{ParamsLayout, Shape, ELEMENT_LAYOUT_ENTRY_PREFIX};

use super::{bad, check, parse, reflect_params, LayoutError, ParamsBlock, ParamsDelivery, Result};

/// The hidden entry point that records element struct `name` in a device crate's SPIR-V.
pub fn element_entry(name: &str) -> String {
    format!("{ELEMENT_LAYOUT_ENTRY_PREFIX}{name}")
}

/// The struct layout a `#[derive(Element)]` type records (its `Element::SHAPE`).
fn element_layout(shape: &Shape) -> Result<&'static ParamsLayout> {
    match shape {
        Shape::Struct(layout) => Ok(layout),
        _ => Err(bad("the element is not a struct deriving `Element`: only those record a layout to compare")),
    }
}

/// Checks the element struct whose `Element::SHAPE` is `shape` against the
/// params blocks of a module's entry points (by name, as [`reflect_params`]
/// gives them).
pub fn check_element(shape: &Shape, blocks: &HashMap<String, Vec<ParamsBlock>>) -> Result<()> {
    let host = element_layout(shape)?;
    let entry = element_entry(host.name);
    let Some(blocks) = blocks.get(&entry) else {
        return Err(LayoutError::ElementNotRecorded { struct_name: host.name, entry });
    };
    check_element_blocks(host, &entry, blocks)
}

/// Checks `host` against the push-constant block of its recording entry point.
pub fn check_element_blocks(host: &'static ParamsLayout, entry: &str, blocks: &[ParamsBlock]) -> Result<()> {
    match check(host, entry, blocks, ParamsDelivery::PushConstants) {
        Err(LayoutError::Mismatch { field, host: host_text, device, .. }) => {
            Err(LayoutError::ElementMismatch { struct_name: host.name, field, host: host_text, device })
        }
        other => other,
    }
}

/// Checks the element struct whose `Element::SHAPE` is `shape` against the SPIR-V
/// file `path` that `cargo xtask build-shaders` wrote for the crate defining it:
/// what the tests `#[derive(Element)]` generates in device crates run.
pub fn check_element_file(path: &std::path::Path, shape: &Shape) -> Result<()> {
    let words = super::built::read_built_words(path)?;
    check_element(shape, &reflect_params(&parse(&words)?)?)
}
