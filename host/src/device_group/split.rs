//! A split launch: one state per device, the launches of its bands, and the
//! gather of their rows.

use std::ops::Range;
use std::time::Instant;

use super::band::{partition, Balance, Band, BandRows, BandTiming};
use crate::context::Context;
use crate::error::DeviceGroupError;
use crate::error::{Error, Result};

/// Split launches over a [`DeviceGroup`](super::DeviceGroup): one state per device (built by
/// [`DeviceGroup::split`](super::DeviceGroup::split)), the bands of the next launch, and what each device
/// measured. See the [module docs](super).
pub struct Split<T> {
    pub(super) contexts: Vec<Context>,
    pub(super) states: Vec<T>,
    pub(super) total_rows: u32,
    pub(super) row_len: usize,
    /// The rows each device renders in the next launch.
    pub(super) next: Vec<Range<u32>>,
    /// The rows whose state each device holds: those it rendered last.
    pub(super) held: Vec<Range<u32>>,
    pub(super) balance: Balance,
    /// Smoothed rows per second of each device.
    pub(super) rates: Vec<Option<f64>>,
    /// Each device's timing in the last launch (`None`: it had no rows).
    pub(super) last: Vec<Option<BandTiming>>,
    pub(super) carry_rows: bool,
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
    /// first launch and after [`Split::forget_rows`](super::Split::forget_rows)).
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
    /// see the [module docs](super)). Off for renders whose launches do not build
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
    /// [module docs](super)), then calls `launch` with each device's state and
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

    /// [`Split::gather`](super::Split::gather) into a new vector.
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
pub(super) fn join<R>(handle: std::thread::ScopedJoinHandle<'_, R>) -> R {
    handle.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic))
}

/// `error` of device `device` of `contexts`, naming it.
pub(super) fn in_device(contexts: &[Context], device: usize, error: Error) -> Error {
    let name = contexts.get(device).map(|c| c.device_name().into_owned()).unwrap_or_default();
    Error::InDevice { device, name, source: Box::new(error) }
}
