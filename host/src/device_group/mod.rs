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

use crate::context::Context;
use crate::error::DeviceGroupError;
use crate::error::{Error, Result};

mod band;
mod split;

pub(crate) use band::partition;
pub use band::{Balance, Band, BandRows, BandTiming};
pub use split::Split;
use split::{in_device, join};

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
