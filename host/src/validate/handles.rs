//! Checked handles: every launch checks the [`Buffer`](raykit_device::Buffer),
//! [`Texture2D`](raykit_device::Texture2D) and
//! [`Traversable`](raykit_device::Traversable) fields of its params (found through
//! [`LaunchParams::LAYOUT`](raykit_device::LaunchParams::LAYOUT)) against the
//! objects alive in the launching context, and refuses a dropped, foreign or stale
//! one with [`LaunchError::InvalidHandle`] naming the field.
//!
//! * A buffer handle is a slot of the context's bindless table in its low 12 bits
//!   and a generation in the 20 bits above, unique in the process (until it wraps
//!   after 2^20 buffers). It must be the null handle (0) or the handle of a live
//!   [`crate::DeviceBuffer`] of this context: the handle of a dropped buffer (its
//!   slot reused or not) and that of another context's buffer carry another
//!   generation than the slot's and are refused. Device programs use only the slot
//!   bits (`Buffer::table_index`); programs in GLSL or WGSL mask the handle with
//!   `BUFFER_TABLE_SLOTS - 1` (4095) the same way.
//! * A traversable must be [`Traversable::NULL`](raykit_device::Traversable::NULL)
//!   or the address of a live [`crate::Ias`] of this context, built (or updated)
//!   after the last refit of every GAS it instances.
//!
//! The same checks run on the handle fields of SBT records whose data type derives
//! [`SbtRecordData`](macro@raykit_device::SbtRecordData) (recorded by the
//! [`crate::Sbt`] builder and [`crate::Sbt::update`]); the error then names the
//! region, the record's index and the field.
//!
//! What raykit cannot see it does not check: handles inside records of plain
//! `bytemuck::Pod` types and inside buffers reach the device unchecked; see
//! [`raykit_device::Buffer`] for what the device reads through a bad one.

use std::collections::HashMap;
use std::sync::atomic::AtomicU64;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};

use raykit_device::{FieldLayout, ParamsLayout, Shape};

use crate::error::LaunchError;
use crate::error::{Error, Result};
use crate::types::sbt::SbtRegion;

/// Bits of a handle that name the slot; the bits above carry the generation.
pub(crate) const SLOT_BITS: u32 = raykit_abi::BUFFER_TABLE_SLOTS.trailing_zeros();

/// Generations are unique across the process (until they wrap after 2^20 buffers),
/// so a handle of another context, or of a buffer whose slot was reused, differs
/// from the live one's.
pub(crate) fn next_generation() -> u32 {
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(1);
    loop {
        let g = NEXT.fetch_add(1, Ordering::Relaxed) & ((1 << (32 - SLOT_BITS)) - 1);
        if g != 0 {
            return g;
        }
    }
}

/// The handle device programs get: the slot in the low bits, the generation above.
pub(crate) fn handle_value(slot: u32, generation: u32) -> u32 {
    slot | (generation << SLOT_BITS)
}

/// What a handle field holds.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
enum HandleKind {
    Buffer,
    Texture,
    Traversable,
}

/// One handle in a params struct: where it is and what it is called.
#[derive(Clone, Debug)]
pub(crate) struct HandleField {
    offset: u32,
    kind: HandleKind,
    name: String,
}

impl HandleField {
    /// Its offset and name, if it is a traversable.
    pub(crate) fn traversable(&self) -> Option<(u32, &str)> {
        (self.kind == HandleKind::Traversable).then_some((self.offset, self.name.as_str()))
    }
}

/// Every handle field of `layout`, nested structs and arrays included, in order.
pub(crate) fn handle_fields(layout: &ParamsLayout) -> Vec<HandleField> {
    let mut out = Vec::new();
    collect(layout.fields, 0, "", &mut out);
    out
}

/// Every handle field of SBT record data `T` (none for plain `Pod` data).
pub(crate) fn record_handle_fields<T: raykit_device::SbtRecordData>() -> Vec<HandleField> {
    let mut out = Vec::new();
    collect(T::FIELDS, 0, "", &mut out);
    out
}

fn collect(fields: &[FieldLayout], base: u32, prefix: &str, out: &mut Vec<HandleField>) {
    for field in fields {
        let name = if prefix.is_empty() { field.name.to_owned() } else { format!("{prefix}.{}", field.name) };
        collect_shape(&field.shape, base + field.offset, name, out);
    }
}

fn collect_shape(shape: &Shape, offset: u32, name: String, out: &mut Vec<HandleField>) {
    match shape {
        Shape::Buffer => out.push(HandleField { offset, kind: HandleKind::Buffer, name }),
        Shape::Texture => out.push(HandleField { offset, kind: HandleKind::Texture, name }),
        Shape::Traversable => out.push(HandleField { offset, kind: HandleKind::Traversable, name }),
        Shape::Struct(inner) => collect(inner.fields, offset, &name, out),
        Shape::Array { stride, len, element } => {
            for i in 0..*len {
                collect_shape(element, offset + i * stride, format!("{name}[{i}]"), out);
            }
        }
        _ => {}
    }
}

/// The versions of the GASes an IAS was built over, with the value of each at the build.
pub(crate) type BuiltOver = Vec<(Arc<AtomicU64>, u64)>;

/// A live instance acceleration structure as launches check it.
pub(crate) struct LiveIas {
    /// The versions of the GASes it was built over (a refit since makes it stale).
    pub(crate) over: BuiltOver,
    /// The hit records its instances can select (see `crate::validate::scene`).
    pub(crate) reach: Arc<crate::validate::hit_reach::HitReach>,
}

/// The live instance acceleration structures of a context, by device address.
#[derive(Default)]
pub(crate) struct LiveTraversables {
    by_address: Mutex<HashMap<u64, LiveIas>>,
}

impl LiveTraversables {
    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<u64, LiveIas>> {
        self.by_address.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Records (or re-records after an update) the IAS at `address`.
    pub(crate) fn insert(&self, address: u64, ias: LiveIas) {
        self.lock().insert(address, ias);
    }

    /// Forgets the IAS at `address` (it was dropped).
    pub(crate) fn remove(&self, address: u64) {
        self.lock().remove(&address);
    }

    /// What the traversable at `address` is: a live IAS, up to date or stale, or none.
    pub(crate) fn state(&self, address: u64) -> TraversableState {
        self.lock().get(&address).map_or(TraversableState::Unknown, LiveIas::state)
    }

    /// The hit records the live IAS at `address` can select.
    pub(crate) fn hit_reach(&self, address: u64) -> Option<Arc<crate::validate::hit_reach::HitReach>> {
        self.lock().get(&address).map(|ias| ias.reach.clone())
    }
}

/// The device address a `Traversable` field at `offset` of `bytes` holds (`None`
/// when the bytes end before it).
pub(crate) fn read_traversable(bytes: &[u8], offset: u32) -> Option<u64> {
    let word = bytes.get(offset as usize..offset as usize + 8)?;
    Some(u64::from_le_bytes(word.try_into().ok()?))
}

/// What a checked traversable is to its context.
pub(crate) enum TraversableState {
    /// A live IAS, built after the last refit of every GAS it instances.
    Live,
    /// No live IAS of this context.
    Unknown,
    /// A live IAS whose instance's GAS was refitted since it was built.
    Stale { instance: usize },
}

impl LiveIas {
    /// Whether a GAS it instances was refitted since it was built.
    pub(crate) fn state(&self) -> TraversableState {
        match self.over.iter().position(|(now, built)| now.load(Ordering::Acquire) != *built) {
            Some(instance) => TraversableState::Stale { instance },
            None => TraversableState::Live,
        }
    }
}

/// Checks the handles of `params` (laid out as `fields` says) with the context's
/// answers: whether a buffer handle is live, and what a traversable is. `record`
/// is the SBT record the bytes are the data of, `None` for launch params.
pub(crate) fn check_handles(
    fields: &[HandleField],
    params: &[u8],
    record: Option<(SbtRegion, usize)>,
    buffer_is_live: impl Fn(u32) -> bool,
    texture_is_live: impl Fn(u32) -> bool,
    mut traversable: impl FnMut(u64) -> TraversableState,
) -> Result<()> {
    let (buffer_fix, tlas_fix) = match record {
        None => (
            "put the handle() of a DeviceBuffer of this Context, alive until the launch is submitted, in the params",
            "put the handle() of a live Ias of this Context in the params",
        ),
        Some(_) => (
            "put the handle() of a DeviceBuffer of this Context, alive until the launch is submitted, in the record (Sbt::update)",
            "put the handle() of a live Ias of this Context in the record (Sbt::update)",
        ),
    };
    let read = |offset: u32, n: usize| params.get(offset as usize..offset as usize + n);
    for field in fields {
        match field.kind {
            HandleKind::Buffer => {
                let Some(bytes) = read(field.offset, 4) else { continue };
                let handle = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
                if !buffer_is_live(handle) {
                    return Err(Error::Launch(LaunchError::InvalidHandle {
                        record,
                        field: field.name.clone(),
                        problem: format!(
                            "buffer handle {handle:#x} names no live DeviceBuffer of this Context (its buffer was dropped, its slot reused, or it belongs to another Context)"
                        ),
                        fix: buffer_fix,
                    }));
                }
            }
            HandleKind::Texture => {
                let Some(bytes) = read(field.offset, 4) else { continue };
                let handle = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
                if !texture_is_live(handle) {
                    return Err(Error::Launch(LaunchError::InvalidHandle {
                        record,
                        field: field.name.clone(),
                        problem: format!(
                            "texture handle {handle:#x} names no live Texture of this Context (its texture was dropped, its slot reused, or it belongs to another Context)"
                        ),
                        fix: match record {
                            None => "put the handle() of a Texture of this Context, alive until the launch is submitted, in the params",
                            Some(_) => "put the handle() of a Texture of this Context, alive until the launch is submitted, in the record (Sbt::update)",
                        },
                    }));
                }
            }
            HandleKind::Traversable => {
                let Some(address) = read_traversable(params, field.offset) else { continue };
                if address == 0 {
                    continue;
                }
                match traversable(address) {
                    TraversableState::Live => {}
                    TraversableState::Unknown => {
                        return Err(Error::Launch(LaunchError::InvalidHandle {
                            record,
                            field: field.name.clone(),
                            problem: format!(
                                "traversable {address:#x} is no live IAS of this Context (it was dropped, rebuilt, or belongs to another Context)"
                            ),
                            fix: tlas_fix,
                        }))
                    }
                    TraversableState::Stale { instance } => {
                        return Err(Error::Launch(LaunchError::InvalidHandle {
                            record,
                            field: field.name.clone(),
                            problem: format!("the GAS of instance {instance} was refitted since this IAS was built"),
                            fix: "update the IAS (Ias::update with its instances) or rebuild it after refitting its GASes",
                        }))
                    }
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn handle_fields_are_found_in_nested_structs_and_arrays() {
        static ELEMENT: Shape = Shape::Buffer;
        static INNER: ParamsLayout = ParamsLayout {
            name: "Inner",
            size: 12,
            fields: &[
                FieldLayout { name: "n", type_name: "u32", offset: 0, size: 4, shape: Shape::Plain },
                FieldLayout {
                    name: "bufs",
                    type_name: "[Buffer<u32>; 2]",
                    offset: 4,
                    size: 8,
                    shape: Shape::Array { stride: 4, len: 2, element: &ELEMENT },
                },
            ],
        };
        static OUTER: ParamsLayout = ParamsLayout {
            name: "Outer",
            size: 24,
            fields: &[
                FieldLayout { name: "scene", type_name: "Traversable", offset: 0, size: 8, shape: Shape::Traversable },
                FieldLayout { name: "inner", type_name: "Inner", offset: 8, size: 12, shape: Shape::Struct(&INNER) },
            ],
        };
        let found: Vec<(u32, HandleKind, String)> =
            handle_fields(&OUTER).into_iter().map(|f| (f.offset, f.kind, f.name)).collect();
        assert_eq!(
            found,
            [
                (0, HandleKind::Traversable, "scene".to_owned()),
                (12, HandleKind::Buffer, "inner.bufs[0]".to_owned()),
                (16, HandleKind::Buffer, "inner.bufs[1]".to_owned()),
            ]
        );
    }
}
