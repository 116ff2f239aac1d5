//! The bands a split launch gives its devices: their rows, how they are
//! balanced, and the times that balance them.

use std::ops::Range;

use crate::error::Result;

/// What a per-device state of a [`Split`](super::Split) lets the split read and write: its
/// rows of the result, as they stand after the launches so far (for a
/// progressive render, the accumulated sums). Gathering reads them; rows that
/// change device are read from one state and written into another.
///
/// Rows are numbered in the whole grid (row `r` of a band starting at row `f` is
/// launch row `r - f`).
pub trait BandRows {
    /// One element of a row (a pixel's accumulated value, say).
    type Item: bytemuck::Pod + Send;

    /// Elements per row: the same on every device of a split.
    fn row_len(&self) -> usize;

    /// Copies rows `rows` into `out` (`rows.len() × row_len()` elements). Waits
    /// for this device's launches to finish first.
    fn read_rows(&self, rows: Range<u32>, out: &mut [Self::Item]) -> Result<()>;

    /// Overwrites rows `rows` with `data` (`rows.len() × row_len()` elements),
    /// so that the next launch continues from them.
    fn write_rows(&mut self, rows: Range<u32>, data: &[Self::Item]) -> Result<()>;
}

/// The rows one device renders in one split launch.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Band {
    /// The device's index in the group.
    pub device: usize,
    /// The rows, numbered in the whole grid.
    pub rows: Range<u32>,
    /// Rows of the whole grid.
    pub total_rows: u32,
}

impl Band {
    /// The first row: what the device program adds to its launch index's `y`.
    pub fn first_row(&self) -> u32 {
        self.rows.start
    }

    /// Rows in the band.
    pub fn row_count(&self) -> u32 {
        self.rows.end.saturating_sub(self.rows.start)
    }

    /// Whether the band has no rows (the device sits the launch out).
    pub fn is_empty(&self) -> bool {
        self.row_count() == 0
    }

    /// The launch dimensions of the band: `[width, rows, depth]`.
    pub fn launch_dims(&self, width: u32, depth: u32) -> [u32; 3] {
        [width, self.row_count(), depth]
    }
}

/// How a [`Split`](super::Split) shares rows between its devices.
#[derive(Clone, Debug, PartialEq)]
pub enum Balance {
    /// By each device's measured speed (rows per second), updated after every
    /// launch (see the [module docs](super)).
    Measured,
    /// In these proportions, one weight per device, fixed. A weight of zero
    /// leaves a device out.
    Weights(Vec<f64>),
}

/// How long one device took for its band in the last launch.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BandTiming {
    /// Rows it rendered.
    pub rows: u32,
    /// Seconds its launch closure took (submission, device work, wait).
    pub seconds: f64,
}

impl BandTiming {
    /// Rows per second.
    pub fn rows_per_second(&self) -> f64 {
        f64::from(self.rows) / self.seconds.max(1e-9)
    }
}

/// Splits `rows` into consecutive bands in proportion to `weights` (largest
/// remainders get the rows left over). With `at_least_one`, every device gets a
/// row first when there are enough rows.
pub(crate) fn partition(rows: u32, weights: &[f64], at_least_one: bool) -> Vec<Range<u32>> {
    let n = weights.len();
    let base = u32::from(at_least_one && rows as usize >= n);
    let rest = rows - base * n as u32;
    let total: f64 = weights.iter().sum();
    let exact: Vec<f64> = weights
        .iter()
        .map(|w| if total > 0.0 { f64::from(rest) * w / total } else { f64::from(rest) / n as f64 })
        .collect();
    let mut counts: Vec<u32> = exact.iter().map(|e| e.floor() as u32).collect();
    let mut left = rest.saturating_sub(counts.iter().sum());
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| (exact[b] - exact[b].floor()).total_cmp(&(exact[a] - exact[a].floor())).then(a.cmp(&b)));
    for &device in order.iter().cycle() {
        if left == 0 {
            break;
        }
        counts[device] += 1;
        left -= 1;
    }
    let mut start = 0;
    counts
        .iter()
        .map(|count| {
            let band = start..start + base + count;
            start = band.end;
            band
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sizes(bands: &[Range<u32>]) -> Vec<u32> {
        bands.iter().map(|b| b.end - b.start).collect()
    }

    #[test]
    fn partition_covers_every_row_in_order() {
        for rows in [1, 2, 3, 7, 64, 1000, 1081] {
            for weights in [vec![1.0], vec![1.0, 1.0], vec![1.0, 3.0, 0.5], vec![0.001, 1000.0]] {
                for at_least_one in [false, true] {
                    let bands = partition(rows, &weights, at_least_one);
                    assert_eq!(bands.len(), weights.len());
                    assert_eq!(bands[0].start, 0);
                    assert_eq!(bands.last().map(|b| b.end), Some(rows));
                    for pair in bands.windows(2) {
                        assert_eq!(pair[0].end, pair[1].start, "{rows} {weights:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn partition_follows_the_weights() {
        assert_eq!(sizes(&partition(64, &[1.0, 1.0], true)), [32, 32]);
        assert_eq!(sizes(&partition(64, &[1.0, 3.0], false)), [16, 48]);
        assert_eq!(sizes(&partition(10, &[1.0, 1.0, 1.0], false)), [4, 3, 3]);
        // Every device keeps a row to be measured by, when asked.
        assert_eq!(sizes(&partition(100, &[1e-9, 1.0], true)), [1, 99]);
        assert_eq!(sizes(&partition(100, &[0.0, 1.0], false)), [0, 100]);
        // Fewer rows than devices: some get none.
        assert_eq!(sizes(&partition(2, &[1.0, 1.0, 1.0], true)), [1, 1, 0]);
        for (rows, weights) in [(1000u32, [2.0, 5.0, 3.0]), (97, [0.1, 0.7, 0.2])] {
            let total: f64 = weights.iter().sum();
            for (size, w) in sizes(&partition(rows, &weights, true)).iter().zip(weights) {
                let exact = f64::from(rows) * w / total;
                assert!((f64::from(*size) - exact).abs() <= 2.0, "{size} rows for {exact}");
            }
        }
    }

    #[test]
    fn bands_tell_their_launch() {
        let band = Band { device: 1, rows: 10..25, total_rows: 64 };
        assert_eq!(band.first_row(), 10);
        assert_eq!(band.row_count(), 15);
        assert_eq!(band.launch_dims(64, 1), [64, 15, 1]);
        assert!(!band.is_empty());
        assert!(Band { device: 0, rows: 3..3, total_rows: 4 }.is_empty());
    }
}
