//! Specialization constants, set when a pipeline is linked.

/// Values of specialization constants for
/// [`Pipeline::with_specialization`](crate::Pipeline::with_specialization):
/// `u32`s by constant ID (device programs declare them as
/// `#[spec_constant(id = N, default = D)] x: u32`).
#[derive(Clone, Debug, Default)]
#[must_use]
pub struct Specialization {
    values: Vec<(u32, u32)>,
}

impl Specialization {
    /// The constants set, by id.
    pub(crate) fn values(&self) -> &[(u32, u32)] {
        &self.values
    }

    /// No constants set: every program sees its defaults.
    pub fn new() -> Self {
        Specialization::default()
    }

    /// Sets constant `id` to `value` (a later value for the same ID replaces it).
    /// IDs reserved by raykit ([`RESERVED_SPEC_IDS`](raykit_abi::RESERVED_SPEC_IDS)) are ignored here.
    pub fn set(mut self, id: u32, value: u32) -> Self {
        if !raykit_abi::is_reserved_spec_id(id) {
            self.values.retain(|(i, _)| *i != id);
            self.values.push((id, value));
        }
        self
    }

    /// Sets constant `id` to the bits of `value`.
    pub fn set_f32(self, id: u32, value: f32) -> Self {
        self.set(id, value.to_bits())
    }
}
