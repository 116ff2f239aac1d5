//! SPIR-V validation before the driver sees a module, with SPIRV-Tools' validator
//! (`spirv-val`, through the `spirv-tools` crate), for the environment raykit
//! creates: Vulkan 1.2 with `scalarBlockLayout` (rust-gpu's push-constant blocks
//! put a `Vec3` at offset 12, which only scalar layout allows).
//!
//! [`Module::new`](crate::Module::new) validates the module as given (its
//! specialization constants at their defaults); linking validates it again with
//! the pipeline's constants frozen in ([`freeze_spec_constants`]), so a constant
//! that sizes an array to 0 is refused, and arrays sized past
//! [`MAX_ARRAY_LENGTH`] elements by a constant are refused before the driver tries
//! to allocate them.
//!
//! The `spirv-tools` crate runs the `spirv-val` executable by default (Debian:
//! `apt-get install spirv-tools`): building SPIRV-Tools from C++ source (its
//! `use-compiled-tools` feature, enabled by raykit's `compiled-spirv-tools`
//! feature) takes many minutes on a small machine. Where no validator is
//! installed, [`validator_available`] is false and modules are not validated
//! (raykit's own structural checks still run).

use std::collections::BTreeSet;
use std::collections::{HashMap, HashSet};
use std::sync::{Mutex, OnceLock};

use rspirv::spirv::{Decoration, Op};
use sha2::{Digest, Sha256};
use spirv_tools::val::{Validator, ValidatorOptions};

use crate::error::ModuleError;
use crate::error::{Error, Result};

/// The most elements an array sized by a specialization constant may have.
pub const MAX_ARRAY_LENGTH: u64 = 1 << 22;

/// Whether SPIRV-Tools' validator can run here.
pub fn validator_available() -> bool {
    static AVAILABLE: OnceLock<bool> = OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        if cfg!(feature = "compiled-spirv-tools") {
            return true;
        }
        std::process::Command::new("spirv-val")
            .arg("--version")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    })
}

/// Validates `words` for Vulkan 1.2 with scalar block layout; the validator's
/// message becomes [`ModuleError::InvalidSpirv`]. Does nothing where no validator is
/// installed (see [`validator_available`]).
///
/// A module that passed once is remembered (by its SHA-256) for the life of the
/// process, so pipelines made again from the same modules, and modules shared by
/// several pipelines, are validated once.
pub fn validate(words: &[u32]) -> Result<()> {
    if !validator_available() {
        return Ok(());
    }
    let digest: [u8; 32] = Sha256::digest(bytemuck::cast_slice::<u32, u8>(words)).into();
    let passed = || PASSED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    if passed().contains(&digest) {
        return Ok(());
    }
    run_validator(words)?;
    let mut passed = passed();
    if passed.len() >= MAX_REMEMBERED {
        passed.clear();
    }
    passed.insert(digest);
    Ok(())
}

/// Modules that passed validation in this process, by SHA-256 of their words.
static PASSED: Mutex<BTreeSet<[u8; 32]>> = Mutex::new(BTreeSet::new());

/// How many validated modules [`PASSED`] remembers before it starts over.
const MAX_REMEMBERED: usize = 4096;

fn run_validator(words: &[u32]) -> Result<()> {
    let validator = spirv_tools::val::create(Some(spirv_tools::TargetEnv::Vulkan_1_2));
    let options = ValidatorOptions { scalar_block_layout: true, ..ValidatorOptions::default() };
    validator.validate(words, Some(options)).map_err(|e| {
        Error::Module(ModuleError::InvalidSpirv {
            reason: format!("the SPIR-V validator (spirv-val) refuses it: {}", e.to_string().trim_end()),
        })
    })
}

/// The instructions of a structurally checked module: (word offset, words).
fn instructions(words: &[u32]) -> impl Iterator<Item = (usize, &[u32])> {
    let mut at = 5;
    std::iter::from_fn(move || {
        let word_count = ((*words.get(at)? >> 16) as usize).max(1);
        let inst = words.get(at..at + word_count)?;
        at += word_count;
        Some((at - word_count, inst))
    })
}

/// Turns every specialization constant of `words` into a constant with the value
/// `values` gives its `SpecId` (or its default), as a pipeline created with those
/// values sees it; then refuses arrays those constants size past
/// [`MAX_ARRAY_LENGTH`]. (What SPIRV-Tools' `--freeze-spec-const` pass does, for
/// scalar constants; `OpSpecConstantOp` and composites keep their form.)
pub fn freeze_spec_constants(words: &[u32], values: &[(u32, u32)]) -> Result<Vec<u32>> {
    let values: HashMap<u32, u32> = values.iter().copied().collect();
    let mut spec_ids: HashMap<u32, u32> = HashMap::new();
    for (_, inst) in instructions(words) {
        if inst[0] & 0xffff == Op::Decorate as u32 && inst.len() >= 4 && inst[2] == Decoration::SpecId as u32 {
            spec_ids.insert(inst[1], inst[3]);
        }
    }
    let mut out = words.to_vec();
    let mut frozen = HashMap::new();
    for (at, inst) in instructions(words) {
        let op = inst[0] & 0xffff;
        let Some(result) = inst.get(2).copied() else { continue };
        let value = spec_ids.get(&result).and_then(|id| values.get(id)).copied();
        if op == Op::SpecConstant as u32 && inst.len() >= 4 {
            out[at] = (inst[0] & 0xffff_0000) | Op::Constant as u32;
            if let Some(v) = value {
                out[at + 3] = v;
                // A 64-bit constant gets the 32-bit value zero-extended.
                if inst.len() >= 5 {
                    out[at + 4] = 0;
                }
            }
            frozen.insert(result, u64::from(out[at + 3]) | inst.get(4).map_or(0, |_| u64::from(out[at + 4]) << 32));
        } else if op == Op::SpecConstantTrue as u32 || op == Op::SpecConstantFalse as u32 {
            let truth = value.map_or(op == Op::SpecConstantTrue as u32, |v| v != 0);
            let constant = if truth { Op::ConstantTrue } else { Op::ConstantFalse };
            out[at] = (inst[0] & 0xffff_0000) | constant as u32;
        }
    }
    // The constant's SpecId decoration must go with it: a SpecId on a constant is invalid.
    let frozen_ids: HashSet<u32> = frozen.keys().copied().collect();
    let mut kept = out[..5].to_vec();
    for (_, inst) in instructions(&out) {
        let is_spec_id = inst[0] & 0xffff == Op::Decorate as u32
            && inst.len() >= 4
            && inst[2] == Decoration::SpecId as u32
            && (frozen_ids.contains(&inst[1]) || spec_ids.contains_key(&inst[1]));
        if !is_spec_id {
            kept.extend_from_slice(inst);
        }
    }
    for (_, inst) in instructions(&kept) {
        if inst[0] & 0xffff == Op::TypeArray as u32 && inst.len() >= 4 {
            if let Some(&length) = frozen.get(&inst[3]) {
                if length > MAX_ARRAY_LENGTH {
                    return Err(Error::Module(ModuleError::InvalidSpirv {
                        reason: format!(
                            "a specialization constant sizes array type %{} to {length} elements, over raykit's limit of {MAX_ARRAY_LENGTH}; give the constant a smaller value, or keep large data in a `Buffer<T>`",
                            inst[1]
                        ),
                    }));
                }
            }
        }
    }
    Ok(kept)
}
