//! Errors of device groups and their split launches.

/// Errors of device groups and their split launches..
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DeviceGroupError {
    /// A [`crate::DeviceGroup`] was made of no contexts.
    #[error("a device group needs at least one context; Context::all lists the ray-tracing devices")]
    Empty,

    /// A split launch over a grid with no rows.
    #[error("a split launch needs at least one row to split, got a grid of 0 rows")]
    EmptySplit,

    /// Band weights given to a split launch cannot divide its rows.
    #[error("band weights {weights:?}: {reason}")]
    BandWeights {
        /// The weights given.
        weights: Vec<f64>,
        /// What is wrong with them.
        reason: &'static str,
    },

    /// The per-device states of a split launch disagree on the length of a row.
    #[error("device {device} of the group has rows of {found} elements, but device 0's rows have {expected}; build every device's state for the same grid")]
    BandRowLength {
        /// The device that differs.
        device: usize,
        /// Its row length.
        found: usize,
        /// Device 0's.
        expected: usize,
    },

    /// The host buffer given to a gather does not hold the grid.
    #[error("gathering {rows} rows of {row_len} elements needs {} elements, but the buffer holds {len}", *.rows as usize * .row_len)]
    GatherSize {
        /// Rows of the grid.
        rows: u32,
        /// Elements per row.
        row_len: usize,
        /// Elements in the buffer given.
        len: usize,
    },

    /// A gather before any split launch: no device holds rows yet.
    #[error("nothing to gather: rows {first}..{end} were not rendered by the launches since the split was made or its rows forgotten; launch first")]
    NotLaunched {
        /// First row no device holds.
        first: u32,
        /// One past the last such row.
        end: u32,
    },
}
