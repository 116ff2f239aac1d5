//! Several devices, one launch: a [`DeviceGroup`] splits a launch grid into bands
//! of rows, one band per device, sized by each device's measured speed, and
//! gathers the bands into one host buffer.
//!
//! OptiX 7 leaves several GPUs to the application: one device context per GPU,
//! and the application splits the work. raykit does the splitting for it:
//!
//! 1. [`Context::all`] makes one context per ray-tracing device, and
//!    [`DeviceGroup::new`] takes those (or any contexts: GPUs of different kinds,
//!    lavapipe, the CPU backend, several contexts of one device).
//! 2. [`DeviceGroup::split`] builds each device's state — pipeline, SBT,
//!    acceleration structures, buffers — by calling the application's closure once
//!    per context, from the same inputs, on a thread per device.
//! 3. [`Split::launch`] gives each device a [`Band`] of rows and calls the
//!    application's launch closure for it, on a thread per device, all at once.
//! 4. [`Split::gather`] copies each device's band into one host buffer
//!    ([`BandRows::read_rows`]).
//!
//! # The device programs' part
//!
//! A device renders its band with a launch of `width × band rows`
//! ([`Band::launch_dims`]); Vulkan's launch index cannot be offset (there is no
//! base for `vkCmdTraceRaysKHR`), so the program adds the band's first row to its
//! launch index itself. The application puts [`Band::first_row`] in its launch
//! params, and the raygen program computes its pixel from it and the full image
//! size (not the launch's size):
//!
//! ```ignore
//! // device: `row_offset` and `size` are fields of the params
//! let pixel = ctx.launch_index().truncate() + UVec2::new(0, p.row_offset);
//! let linear = pixel.x + p.size.x * pixel.y;
//! // host, in the launch closure of Split::launch:
//! let params = Params { row_offset: band.first_row(), ..params };
//! pipeline.launch(&sbt, &params, band.launch_dims(width, 1))?;
//! ```
//!
//! A program that seeds its random numbers by that pixel computes the same
//! values whichever device renders the pixel: a split picture is the same as one
//! device's, bit for bit, on devices that compute alike (see below). Grids of
//! several slices (`depth` > 1) are split by rows too: every band covers every
//! slice.
//!
//! # Balancing
//!
//! Each device's time for its band is measured: the wall clock of its launch
//! closure, submission, device work and the wait included, which is what the
//! launch costs that device. With [`Balance::Measured`] (the default) the next
//! launch's bands follow each device's speed in rows per second, smoothed over
//! launches (half the last measurement, half the earlier estimate): a faster
//! device gets more rows, and when the bands stop changing every device takes the
//! same time, whatever the cost of each row. Every device keeps at least one row
//! while the grid has a row for each, so its speed is still measured. The first
//! launch splits the rows evenly (nothing is measured yet); [`Balance::Weights`]
//! fixes the shares instead, for devices whose relative speeds are known.
//!
//! # Progressive renders: rows that move between devices
//!
//! A progressive render accumulates over launches in each device's own buffers.
//! When the bands change, rows move from one device to another, and the new
//! device does not have what the old one accumulated for them. So before each
//! launch a split moves the state of every row that changes device: it reads the
//! rows from the device that rendered them last ([`BandRows::read_rows`]) and
//! writes them into the device that renders them next ([`BandRows::write_rows`]).
//! Accumulation goes on where it stopped, the sums are added in the same order
//! as on one device, and the picture is the same, bit for bit. Only rows whose
//! device changes are copied: once the bands settle, a few rows per launch. A
//! render that starts over (its next launch overwrites instead of adding) calls
//! [`Split::forget_rows`] first, so that nothing is copied; a render whose
//! launches are independent turns moving off ([`Split::set_carry_rows`]).
//!
//! # One device
//!
//! A group of one context does not split: [`Split::launch`] calls the launch
//! closure on the calling thread with one band of every row, and gathering reads
//! them directly — the same launch as without a group.
//!
//! # Devices of different kinds
//!
//! Devices that compute differently (an NVIDIA GPU beside lavapipe, or the CPU
//! backend) may round floats differently: each band is then the picture that its
//! device alone would have rendered, and the whole is the same as a one-device
//! render within that rounding.

use std::ops::Range;
use std::time::Instant;

use crate::context::Context;
use crate::error::DeviceGroupError;
use crate::error::{Error, Result};

/// Several contexts that split launches between them: one per GPU, usually
/// ([`DeviceGroup::all`]). See the [module docs](self).
#[derive(Clone, Debug)]
pub struct DeviceGroup {
    contexts: Vec<Context>,
}

impl DeviceGroup {
    /// A group of `contexts`, in this order (device `i` of bands and errors is
    /// `contexts[i]`). Any contexts: of different devices and backends, or
    /// several of one device (which then share its queue: useful for tests, not
    /// for speed).
    pub fn new(contexts: Vec<Context>) -> Result<DeviceGroup> {
        if contexts.is_empty() {
            return Err(Error::DeviceGroup(DeviceGroupError::Empty));
        }
        Ok(DeviceGroup { contexts })
    }

    /// A group of one context per ray-tracing device ([`Context::all`]).
    pub fn all(options: crate::ContextOptions) -> Result<DeviceGroup> {
        DeviceGroup::new(Context::all(options)?)
    }

    /// The contexts, in the group's order.
    pub fn contexts(&self) -> &[Context] {
        &self.contexts
    }

    /// Number of contexts (at least one).
    pub fn len(&self) -> usize {
        self.contexts.len()
    }

    /// Whether the group has no context: never (see [`DeviceGroup::new`]).
    pub fn is_empty(&self) -> bool {
        self.contexts.is_empty()
    }

    /// Prepares split launches over a grid of `rows` rows: builds each device's
    /// state with `build` (its pipeline, SBT, acceleration structures and
    /// buffers, from the same inputs on each device), one thread per device.
    ///
    /// Fails with [`DeviceGroupError::EmptySplit`] for `rows == 0`, with
    /// [`Error::InDevice`] naming the device whose `build` failed, and with
    /// [`DeviceGroupError::BandRowLength`] when the states' rows differ in length.
    pub fn split<T, F>(&self, rows: u32, build: F) -> Result<Split<T>>
    where
        T: BandRows + Send,
        F: Fn(&Context) -> Result<T> + Sync,
    {
        if rows == 0 {
            return Err(Error::DeviceGroup(DeviceGroupError::EmptySplit));
        }
        let states: Vec<T> = if let [ctx] = self.contexts.as_slice() {
            vec![build(ctx).map_err(|e| in_device(&self.contexts, 0, e))?]
        } else {
            let built: Vec<Result<T>> = std::thread::scope(|scope| {
                let build = &build;
                let handles: Vec<_> = self.contexts.iter().map(|ctx| scope.spawn(move || build(ctx))).collect();
                handles.into_iter().map(join).collect()
            });
            let mut states = Vec::with_capacity(built.len());
            for (device, state) in built.into_iter().enumerate() {
                states.push(state.map_err(|e| in_device(&self.contexts, device, e))?);
            }
            states
        };
        let row_len = states[0].row_len();
        for (device, state) in states.iter().enumerate() {
            if state.row_len() != row_len {
                return Err(Error::DeviceGroup(DeviceGroupError::BandRowLength {
                    device,
                    found: state.row_len(),
                    expected: row_len,
                }));
            }
        }
        let n = states.len();
        Ok(Split {
            contexts: self.contexts.clone(),
            states,
            total_rows: rows,
            row_len,
            next: partition(rows, &vec![1.0; n], true),
            held: vec![0..0; n],
            balance: Balance::Measured,
            rates: vec![None; n],
            last: vec![None; n],
            carry_rows: true,
        })
    }
}

/// What a per-device state of a [`Split`] lets the split read and write: its
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

/// How a [`Split`] shares rows between its devices.
#[derive(Clone, Debug, PartialEq)]
pub enum Balance {
    /// By each device's measured speed (rows per second), updated after every
    /// launch (see the [module docs](self)).
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

/// Split launches over a [`DeviceGroup`]: one state per device (built by
/// [`DeviceGroup::split`]), the bands of the next launch, and what each device
/// measured. See the [module docs](self).
pub struct Split<T> {
    contexts: Vec<Context>,
    states: Vec<T>,
    total_rows: u32,
    row_len: usize,
    /// The rows each device renders in the next launch.
    next: Vec<Range<u32>>,
    /// The rows whose state each device holds: those it rendered last.
    held: Vec<Range<u32>>,
    balance: Balance,
    /// Smoothed rows per second of each device.
    rates: Vec<Option<f64>>,
    /// Each device's timing in the last launch (`None`: it had no rows).
    last: Vec<Option<BandTiming>>,
    carry_rows: bool,
}

impl<T> std::fmt::Debug for Split<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Split")
            .field("devices", &self.contexts.iter().map(|c| c.device_name().into_owned()).collect::<Vec<_>>())
            .field("rows", &self.total_rows)
            .field("row_len", &self.row_len)
            .field("next", &self.next)
            .field("held", &self.held)
            .field("balance", &self.balance)
            .field("rates", &self.rates)
            .finish_non_exhaustive()
    }
}

impl<T: BandRows> Split<T> {
    /// Number of devices.
    pub fn len(&self) -> usize {
        self.states.len()
    }

    /// Whether there is no device: never.
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }

    /// Rows of the grid.
    pub fn rows(&self) -> u32 {
        self.total_rows
    }

    /// Elements per row (of every device's state).
    pub fn row_len(&self) -> usize {
        self.row_len
    }

    /// The contexts, in the group's order.
    pub fn contexts(&self) -> &[Context] {
        &self.contexts
    }

    /// The per-device states, in the group's order.
    pub fn states(&self) -> &[T] {
        &self.states
    }

    /// The per-device states, to change (the bands stay as they are).
    pub fn states_mut(&mut self) -> &mut [T] {
        &mut self.states
    }

    /// The bands the next launch gives each device, in the group's order.
    pub fn bands(&self) -> Vec<Band> {
        self.next
            .iter()
            .enumerate()
            .map(|(device, rows)| Band { device, rows: rows.clone(), total_rows: self.total_rows })
            .collect()
    }

    /// The rows each device rendered last, whose state it holds (empty before the
    /// first launch and after [`Split::forget_rows`]).
    pub fn held_bands(&self) -> Vec<Band> {
        self.held
            .iter()
            .enumerate()
            .map(|(device, rows)| Band { device, rows: rows.clone(), total_rows: self.total_rows })
            .collect()
    }

    /// Each device's timing in the last launch (`None` before the first, and for
    /// a device that had no rows).
    pub fn timings(&self) -> &[Option<BandTiming>] {
        &self.last
    }

    /// Each device's estimated speed in rows per second, smoothed over the
    /// launches so far, which [`Balance::Measured`] shares the rows by (`None`
    /// before its first measurement).
    pub fn rates(&self) -> &[Option<f64>] {
        &self.rates
    }

    /// How the rows are shared.
    pub fn balance(&self) -> &Balance {
        &self.balance
    }

    /// Shares the rows of the next launches as `balance` says; with
    /// [`Balance::Measured`], from the speeds measured so far (evenly when none
    /// is). Fails with [`DeviceGroupError::BandWeights`] for weights that are not one
    /// finite, non-negative number per device with a positive sum.
    pub fn set_balance(&mut self, balance: Balance) -> Result<()> {
        match &balance {
            Balance::Weights(weights) => {
                let reason = if weights.len() != self.states.len() {
                    Some("give one weight per device of the group")
                } else if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
                    Some("weights must be finite and not negative")
                } else if weights.iter().sum::<f64>() <= 0.0 {
                    Some("at least one weight must be positive")
                } else {
                    None
                };
                if let Some(reason) = reason {
                    return Err(Error::DeviceGroup(DeviceGroupError::BandWeights { weights: weights.clone(), reason }));
                }
                self.next = partition(self.total_rows, weights, false);
            }
            Balance::Measured => self.next = partition(self.total_rows, &self.measured_weights(), true),
        }
        self.balance = balance;
        Ok(())
    }

    /// Whether rows that change device carry their state over (on by default;
    /// see the [module docs](self)). Off for renders whose launches do not build
    /// on earlier ones.
    pub fn set_carry_rows(&mut self, carry: bool) {
        self.carry_rows = carry;
    }

    /// Forgets which device holds which rows: the next launch copies no rows
    /// between devices. For a render that starts over, whose next launch
    /// overwrites what the earlier ones left. The measured speeds stay.
    pub fn forget_rows(&mut self) {
        self.held.iter_mut().for_each(|h| *h = 0..0);
    }

    /// One split launch: moves the rows that change device (see the
    /// [module docs](self)), then calls `launch` with each device's state and
    /// band, on a thread per device, all at once (a device whose band is empty
    /// sits out), and waits for them all. Then measures, and with
    /// [`Balance::Measured`] sets the next launch's bands.
    ///
    /// `launch` renders the band's rows: it launches [`Band::launch_dims`] with
    /// [`Band::first_row`] in its params, and returns when the launch has
    /// finished (what it returns early is measured as fast).
    ///
    /// With one device: `launch` runs on this thread with every row, and nothing
    /// is moved or balanced.
    ///
    /// Errors are the first failing device's, in [`Error::InDevice`]. The other
    /// devices' launches still ran; the failed device's rows are forgotten (a
    /// gather refuses them until a launch renders them again), so start the render
    /// over after an error.
    pub fn launch<F>(&mut self, launch: F) -> Result<()>
    where
        T: Send,
        F: Fn(&mut T, &Band) -> Result<()> + Sync,
    {
        if self.states.len() == 1 {
            let band = Band { device: 0, rows: 0..self.total_rows, total_rows: self.total_rows };
            let started = Instant::now();
            let result = launch(&mut self.states[0], &band);
            let seconds = started.elapsed().as_secs_f64();
            if let Err(e) = result {
                self.held[0] = 0..0;
                self.last[0] = None;
                return Err(in_device(&self.contexts, 0, e));
            }
            self.held[0] = band.rows;
            self.last[0] = Some(BandTiming { rows: self.total_rows, seconds });
            self.fold_timings();
            return Ok(());
        }
        if self.carry_rows {
            self.move_rows()?;
        }
        let bands = self.bands();
        let results: Vec<Option<Result<f64>>> = std::thread::scope(|scope| {
            let launch = &launch;
            let handles: Vec<_> = self
                .states
                .iter_mut()
                .zip(&bands)
                .map(|(state, band)| {
                    (!band.is_empty()).then(|| {
                        scope.spawn(move || {
                            let started = Instant::now();
                            launch(state, band).map(|()| started.elapsed().as_secs_f64())
                        })
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.map(join)).collect()
        });
        let mut first_error = None;
        for (device, (band, result)) in bands.into_iter().zip(results).enumerate() {
            match result {
                None => {
                    self.held[device] = 0..0;
                    self.last[device] = None;
                }
                Some(Ok(seconds)) => {
                    self.last[device] = Some(BandTiming { rows: band.row_count(), seconds });
                    self.held[device] = band.rows;
                }
                Some(Err(e)) => {
                    self.held[device] = 0..0;
                    self.last[device] = None;
                    if first_error.is_none() {
                        first_error = Some(in_device(&self.contexts, device, e));
                    }
                }
            }
        }
        if let Some(e) = first_error {
            return Err(e);
        }
        self.rebalance();
        Ok(())
    }

    /// Copies every row into `out` (`rows() × row_len()` elements), each from the
    /// device that rendered it last, one thread per device.
    ///
    /// Fails with [`DeviceGroupError::GatherSize`] when `out` has another length, and with
    /// [`DeviceGroupError::NotLaunched`] for rows no launch rendered yet.
    pub fn gather(&self, out: &mut [T::Item]) -> Result<()>
    where
        T: Sync,
    {
        let needed = self.total_rows as usize * self.row_len;
        if out.len() != needed {
            return Err(Error::DeviceGroup(DeviceGroupError::GatherSize {
                rows: self.total_rows,
                row_len: self.row_len,
                len: out.len(),
            }));
        }
        let mut held: Vec<(usize, Range<u32>)> =
            self.held.iter().cloned().enumerate().filter(|(_, rows)| !rows.is_empty()).collect();
        held.sort_by_key(|(_, rows)| rows.start);
        let mut next_row = 0;
        for (_, rows) in &held {
            if rows.start != next_row {
                return Err(Error::DeviceGroup(DeviceGroupError::NotLaunched { first: next_row, end: rows.start }));
            }
            next_row = rows.end;
        }
        if next_row != self.total_rows {
            return Err(Error::DeviceGroup(DeviceGroupError::NotLaunched { first: next_row, end: self.total_rows }));
        }
        if let [(device, rows)] = held.as_slice() {
            return self.states[*device]
                .read_rows(rows.clone(), out)
                .map_err(|e| in_device(&self.contexts, *device, e));
        }
        let mut parts = Vec::with_capacity(held.len());
        let mut rest = out;
        for (device, rows) in held {
            let (part, tail) = rest.split_at_mut(rows.len() * self.row_len);
            parts.push((device, rows, part));
            rest = tail;
        }
        let results: Vec<(usize, Result<()>)> = std::thread::scope(|scope| {
            let handles: Vec<_> = parts
                .into_iter()
                .map(|(device, rows, part)| {
                    let state = &self.states[device];
                    (device, scope.spawn(move || state.read_rows(rows, part)))
                })
                .collect();
            handles.into_iter().map(|(device, h)| (device, join(h))).collect()
        });
        for (device, result) in results {
            result.map_err(|e| in_device(&self.contexts, device, e))?;
        }
        Ok(())
    }

    /// [`Split::gather`] into a new vector.
    pub fn gather_vec(&self) -> Result<Vec<T::Item>>
    where
        T: Sync,
    {
        let mut out = vec![<T::Item as bytemuck::Zeroable>::zeroed(); self.total_rows as usize * self.row_len];
        self.gather(&mut out)?;
        Ok(out)
    }

    /// Before a launch: copies each row that changes device from the device that
    /// holds it into the one that renders it next.
    fn move_rows(&mut self) -> Result<()> {
        let n = self.states.len();
        for to in 0..n {
            for from in 0..n {
                if from == to {
                    continue;
                }
                let (want, have) = (&self.next[to], &self.held[from]);
                let rows = want.start.max(have.start)..want.end.min(have.end);
                if rows.is_empty() {
                    continue;
                }
                let mut data = vec![<T::Item as bytemuck::Zeroable>::zeroed(); rows.len() * self.row_len];
                self.states[from].read_rows(rows.clone(), &mut data).map_err(|e| in_device(&self.contexts, from, e))?;
                self.states[to].write_rows(rows, &data).map_err(|e| in_device(&self.contexts, to, e))?;
            }
        }
        Ok(())
    }

    /// After a launch: folds its timings into the rates and, when balancing by
    /// measurement, sets the next bands from them.
    fn rebalance(&mut self) {
        self.fold_timings();
        if self.balance == Balance::Measured {
            self.next = partition(self.total_rows, &self.measured_weights(), true);
        }
    }

    /// Folds the last launch's timings into the smoothed rates: half the new
    /// measurement, half the earlier estimate.
    fn fold_timings(&mut self) {
        for (rate, timing) in self.rates.iter_mut().zip(&self.last) {
            if let Some(timing) = timing {
                let measured = timing.rows_per_second();
                *rate = Some(rate.map_or(measured, |old| 0.5 * old + 0.5 * measured));
            }
        }
    }

    /// The measured rates as weights; a device not measured yet counts as the
    /// mean of the others (all alike when none is).
    fn measured_weights(&self) -> Vec<f64> {
        let known: Vec<f64> = self.rates.iter().flatten().copied().collect();
        let mean = if known.is_empty() { 1.0 } else { known.iter().sum::<f64>() / known.len() as f64 };
        self.rates.iter().map(|r| r.unwrap_or(mean)).collect()
    }
}

/// Joins a thread of a split, passing a panic of the application's closure on.
fn join<R>(handle: std::thread::ScopedJoinHandle<'_, R>) -> R {
    handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
}

/// `error` of device `device` of `contexts`, naming it.
fn in_device(contexts: &[Context], device: usize, error: Error) -> Error {
    let name = contexts.get(device).map(|c| c.device_name().into_owned()).unwrap_or_default();
    Error::InDevice { device, name, source: Box::new(error) }
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
