//! Launches split across a device group (`raykit::device_group`).
//!
//! Only single-device machines run these tests, so several contexts stand for
//! several devices: two contexts of one lavapipe device (which share its
//! `VkDevice` and queue, as contexts of one GPU do), and lavapipe beside the CPU
//! backend. What is checked:
//!
//! * two contexts of one device: the path tracer's split, gathered and
//!   rebalanced render — bands forced unequal and changed between launches, so
//!   that rows move between the devices in the middle of the progressive render —
//!   is the one-device render, bit for bit;
//! * lavapipe beside the CPU backend: the bands follow each device's measured
//!   speed (one device slowed down on purpose, either way round); with fixed
//!   bands each band is its own device's one-device render, bit for bit; with
//!   rows moving between the devices the render is, bit for bit, the sum of each
//!   launch's contribution by the device that rendered the row; and it matches
//!   the one-device render within the two devices' float rounding;
//! * the GLSL and WGSL twins of the path tracer render bands as the Rust
//!   programs do;
//! * a group of one device launches directly, on the calling thread, and equals a
//!   plain render;
//! * rows carry their state between devices (and do not when told not to);
//! * bad input in a group of mixed backends gives typed errors naming the device
//!   (the cases of one backend are in the bad-input catalogue).

use std::ops::Range;
use std::time::Duration;

use path_tracer::{DevicePart, GroupRenderer, Programs, Renderer, Scene};
use raykit::glam::Vec4;
use raykit::{Backend, Balance, Band, BandRows, Context, ContextOptions, DeviceBuffer, DeviceGroup, Error, Split};
use raykit_tests::{test_options, with_contexts};

const W: u32 = 64;
const H: u32 = 64;
/// Paths per pixel of each launch.
const SPP: u32 = 2;

fn vulkan() -> ContextOptions {
    ContextOptions { backend: Some(Backend::Vulkan), ..test_options() }
}

fn cpu() -> ContextOptions {
    ContextOptions { backend: Some(Backend::Cpu), ..test_options() }
}

/// Fails unless `got` and `want` are the same bits, naming the first difference.
fn same_bits(got: &[Vec4], want: &[Vec4], what: &str) -> anyhow::Result<()> {
    anyhow::ensure!(got.len() == want.len(), "{what}: {} pixels against {}", got.len(), want.len());
    let bits = |v: &Vec4| v.to_array().map(f32::to_bits);
    let differing: Vec<usize> = (0..got.len()).filter(|&i| bits(&got[i]) != bits(&want[i])).collect();
    if let Some(&first) = differing.first() {
        anyhow::bail!(
            "{what}: {} of {} pixels differ; the first is pixel {first} (row {}): {:?} against {:?}",
            differing.len(),
            got.len(),
            first / W as usize,
            got[first],
            want[first]
        );
    }
    Ok(())
}

/// The elements of `rows` of an image.
fn rows_of(image: &[Vec4], rows: &Range<u32>) -> Vec<Vec4> {
    image[rows.start as usize * W as usize..rows.end as usize * W as usize].to_vec()
}

/// The path tracer on `ctx` alone: `launches` launches of [`SPP`] paths per pixel;
/// the accumulation buffer.
fn one_device_render(ctx: &Context, launches: u32) -> anyhow::Result<Vec<Vec4>> {
    let scene = Scene::new(ctx)?;
    let mut renderer = Renderer::new(ctx, &Programs::rust(ctx)?, &scene, W, H)?;
    for _ in 0..launches {
        renderer.launch(SPP)?;
    }
    Ok(renderer.accumulation()?)
}

/// What launch `subframe` alone adds to each pixel on `ctx`: the sums of its
/// paths, as the accumulation buffer holds them after a launch over zeros.
fn contributions(ctx: &Context, launches: u32) -> anyhow::Result<Vec<Vec<Vec4>>> {
    let scene = Scene::new(ctx)?;
    let mut renderer = Renderer::new(ctx, &Programs::rust(ctx)?, &scene, W, H)?;
    let every_row = Band { device: 0, rows: 0..H, total_rows: H };
    let zeros = vec![Vec4::ZERO; (W * H) as usize];
    let mut out = Vec::new();
    for subframe in 0..launches {
        renderer.write_rows(0..H, &zeros)?;
        renderer.launch_band(subframe, SPP, &every_row)?;
        out.push(renderer.accumulation()?);
    }
    Ok(out)
}

/// The device that rendered each row in the last launch.
fn owners<T: BandRows>(split: &Split<T>) -> Vec<usize> {
    let mut owner = vec![usize::MAX; split.rows() as usize];
    for band in split.held_bands() {
        for row in band.rows {
            owner[row as usize] = band.device;
        }
    }
    owner
}

#[test]
fn two_contexts_of_one_device_render_the_one_device_picture_bit_for_bit() -> anyhow::Result<()> {
    let name = "two_contexts_of_one_device_render_the_one_device_picture_bit_for_bit";
    with_contexts(name, vec![vulkan(), vulkan()], |ctx| {
        anyhow::ensure!(ctx[0].shares_device_with(&ctx[1]), "two contexts of one device share it");
        // Forced shares that change every launch, and one launch by measured speed.
        let schedule = [
            Balance::Weights(vec![1.0, 3.0]),
            Balance::Weights(vec![3.0, 1.0]),
            Balance::Measured,
            Balance::Weights(vec![1.0, 1.0]),
            Balance::Weights(vec![5.0, 1.0]),
            Balance::Weights(vec![1.0, 7.0]),
        ];
        let launches = schedule.len() as u32;
        let reference = one_device_render(&ctx[0], launches)?;
        let group = DeviceGroup::new(ctx.to_vec())?;
        let mut renderer = GroupRenderer::new(&group, W, H, Programs::rust)?;
        let mut before: Option<Vec<usize>> = None;
        let (mut down, mut up) = (0, 0);
        for balance in schedule {
            renderer.split_mut().set_balance(balance.clone())?;
            let bands = renderer.split().bands();
            renderer.launch(SPP)?;
            anyhow::ensure!(renderer.split().held_bands() == bands, "launched {bands:?} with {balance:?}");
            anyhow::ensure!(bands.iter().all(|b| !b.is_empty()), "every device has rows: {bands:?}");
            let now = owners(renderer.split());
            if let Some(before) = &before {
                down += before.iter().zip(&now).filter(|(b, n)| (**b, **n) == (0, 1)).count();
                up += before.iter().zip(&now).filter(|(b, n)| (**b, **n) == (1, 0)).count();
            }
            before = Some(now);
        }
        anyhow::ensure!(down > 0 && up > 0, "rows moved both ways mid-render: {down} to device 1, {up} to device 0");
        same_bits(&renderer.accumulation()?, &reference, "split render against one device")?;
        let image = renderer.image()?;
        let mean = image.radiance.iter().map(|c| c.element_sum()).sum::<f32>() / image.radiance.len() as f32;
        anyhow::ensure!(mean > 0.01 && image.rays >= u64::from(W * H * SPP * launches), "a real picture: {mean}");
        println!("{down} rows moved to device 1 and {up} to device 0 during the render; identical to one device");
        Ok(())
    })
}

/// Makes the path tracer's programs on a context.
type MakePrograms = fn(&Context) -> raykit::Result<Programs>;

#[test]
fn the_glsl_and_wgsl_twins_render_bands_too() -> anyhow::Result<()> {
    with_contexts("the_glsl_and_wgsl_twins_render_bands_too", vec![vulkan(), vulkan()], |ctx| {
        let twins: [(&str, MakePrograms); 2] = [("GLSL", Programs::glsl), ("WGSL", Programs::wgsl)];
        for (twin, programs) in twins {
            let scene = Scene::new(&ctx[0])?;
            let mut one = Renderer::new(&ctx[0], &programs(&ctx[0])?, &scene, W, H)?;
            let group = DeviceGroup::new(ctx.to_vec())?;
            let mut split = GroupRenderer::new(&group, W, H, programs)?;
            for weights in [[1.0, 3.0], [3.0, 1.0]] {
                one.launch(SPP)?;
                split.split_mut().set_balance(Balance::Weights(weights.to_vec()))?;
                split.launch(SPP)?;
            }
            same_bits(&split.accumulation()?, &one.accumulation()?, &format!("{twin} twin split against one device"))?;
        }
        Ok(())
    })
}

/// A device part made slow on purpose: its launches take `delay` longer per row.
struct Slowed {
    part: DevicePart,
    delay: Duration,
}

impl BandRows for Slowed {
    type Item = Vec4;
    fn row_len(&self) -> usize {
        self.part.row_len()
    }
    fn read_rows(&self, rows: Range<u32>, out: &mut [Vec4]) -> raykit::Result<()> {
        self.part.read_rows(rows, out)
    }
    fn write_rows(&mut self, rows: Range<u32>, data: &[Vec4]) -> raykit::Result<()> {
        self.part.write_rows(rows, data)
    }
}

/// Fails unless `bands` share the rows as `rates` say: one row each, and the
/// rest in proportion to the rates (within a row of rounding).
fn check_follow_rates(bands: &[Band], rates: &[Option<f64>]) -> anyhow::Result<()> {
    let rates: Vec<f64> = rates
        .iter()
        .map(|r| r.ok_or_else(|| anyhow::anyhow!("a device was not measured")))
        .collect::<anyhow::Result<_>>()?;
    let total: f64 = rates.iter().sum();
    let spare = f64::from(H) - bands.len() as f64;
    for (band, rate) in bands.iter().zip(&rates) {
        let share = 1.0 + spare * rate / total;
        anyhow::ensure!(
            (f64::from(band.row_count()) - share).abs() <= 1.0,
            "band {band:?} for a share of {share:.2} rows (rates {rates:?} rows/s)"
        );
    }
    Ok(())
}

#[test]
fn a_mixed_group_is_balanced_by_measured_speed() -> anyhow::Result<()> {
    with_contexts("a_mixed_group_is_balanced_by_measured_speed", vec![vulkan(), cpu()], |ctx| {
        let group = DeviceGroup::new(ctx.to_vec())?;
        // Each way round: the slowed device ends with few rows.
        for slow in [Backend::Vulkan, Backend::Cpu] {
            let mut split = group.split(H, |c| {
                let scene = Scene::new(c)?;
                let renderer = Renderer::new(c, &Programs::rust(c)?, &scene, W, H)?;
                let delay = if c.backend() == slow { Duration::from_millis(50) } else { Duration::ZERO };
                Ok(Slowed { part: DevicePart { renderer, scene }, delay })
            })?;
            let slow_device = usize::from(slow == Backend::Cpu);
            anyhow::ensure!(split.bands().iter().all(|b| b.row_count() == H / 2), "the first launch splits evenly");
            for subframe in 0..4 {
                split.launch(|s, band| {
                    s.part.renderer.launch_band(subframe, 1, band)?;
                    std::thread::sleep(s.delay * band.row_count());
                    Ok(())
                })?;
                check_follow_rates(&split.bands(), split.rates())?;
            }
            let bands = split.bands();
            let (slow_rows, fast_rows) = (bands[slow_device].row_count(), bands[1 - slow_device].row_count());
            anyhow::ensure!(
                slow_rows * 4 < fast_rows,
                "the {slow:?} device, slowed by 50 ms a row, still gets {slow_rows} rows against {fast_rows}: {:?}",
                split.timings()
            );
            println!("{slow:?} slowed: rows {slow_rows} against {fast_rows}, rates {:?} rows/s", split.rates());
            // What was rendered is still whole.
            anyhow::ensure!(split.gather_vec()?.iter().all(|p| p.w > 0.0), "every pixel traced rays");
        }
        Ok(())
    })
}

#[test]
fn a_mixed_group_renders_each_row_as_the_device_that_rendered_it() -> anyhow::Result<()> {
    let name = "a_mixed_group_renders_each_row_as_the_device_that_rendered_it";
    with_contexts(name, vec![vulkan(), cpu()], |ctx| {
        const LAUNCHES: u32 = 4;
        let singles = [one_device_render(&ctx[0], LAUNCHES)?, one_device_render(&ctx[1], LAUNCHES)?];
        let group = DeviceGroup::new(ctx.to_vec())?;
        let mut renderer = GroupRenderer::new(&group, W, H, Programs::rust)?;

        // Fixed bands: each band is its own device's one-device render.
        renderer.split_mut().set_balance(Balance::Weights(vec![1.0, 1.0]))?;
        for _ in 0..LAUNCHES {
            renderer.launch(SPP)?;
        }
        let fixed = renderer.accumulation()?;
        for band in renderer.split().held_bands() {
            let what = format!("rows {:?} against device {}'s own render", band.rows, band.device);
            same_bits(&rows_of(&fixed, &band.rows), &rows_of(&singles[band.device], &band.rows), &what)?;
        }

        // Rows moving between the devices (measured speeds, then forced shares):
        // each row is the sum, in launch order, of what each launch's device adds.
        let parts = [contributions(&ctx[0], LAUNCHES)?, contributions(&ctx[1], LAUNCHES)?];
        let schedule =
            [Balance::Measured, Balance::Weights(vec![1.0, 3.0]), Balance::Measured, Balance::Weights(vec![4.0, 1.0])];
        renderer.reset();
        let mut expected = vec![Vec4::ZERO; (W * H) as usize];
        let mut owner_history = Vec::new();
        for (subframe, balance) in schedule.into_iter().enumerate() {
            renderer.split_mut().set_balance(balance)?;
            renderer.launch(SPP)?;
            let owner = owners(renderer.split());
            for (i, pixel) in expected.iter_mut().enumerate() {
                *pixel += parts[owner[i / W as usize]][subframe][i];
            }
            owner_history.push(owner);
        }
        let moved =
            owner_history.windows(2).map(|w| w[0].iter().zip(&w[1]).filter(|(a, b)| a != b).count()).sum::<usize>();
        anyhow::ensure!(moved > 0, "rows moved between the devices");
        let moving = renderer.accumulation()?;
        same_bits(&moving, &expected, "split render against each launch's contributions")?;

        // Against the one-device render: the same within float rounding. The two
        // devices round some operations differently, so sums differ in their last
        // bits; and a ray that grazes an edge may go either way, after which its
        // path differs. So: most pixels the same paths (the same ray count) with
        // radiance within 1e-4 relative, and every 8×8 block's mean within 2%.
        let [same_paths, close, blocks] = compare_to_one_device(&moving, &singles[0]);
        let pixels = (W * H) as usize;
        println!(
            "against lavapipe alone: {same_paths} of {pixels} pixels with the same paths within 1e-4; \
             {close} of {blocks} 8x8 blocks within 2%"
        );
        anyhow::ensure!(close == blocks, "only {close} of {blocks} blocks within 2% of the one-device render");
        anyhow::ensure!(same_paths * 100 >= pixels * 95, "only {same_paths} pixels follow the same paths");
        println!("moved {moved} rows between lavapipe and the CPU backend");
        Ok(())
    })
}

/// Pixels with the same ray count and radiance within 1e-4 relative, 8×8
/// blocks whose mean radiance is within 2% (or 0.002 absolute) per channel, and
/// the number of blocks.
fn compare_to_one_device(got: &[Vec4], want: &[Vec4]) -> [usize; 3] {
    let same_paths = got
        .iter()
        .zip(want)
        .filter(|(a, b)| a.w == b.w && (a.truncate() - b.truncate()).abs().cmple(b.truncate().abs() * 1e-4).all())
        .count();
    let mut close = 0;
    let mut blocks = 0;
    for by in (0..H).step_by(8) {
        for bx in (0..W).step_by(8) {
            let mean = |image: &[Vec4]| {
                let mut sum = raykit::glam::Vec3::ZERO;
                for y in by..by + 8 {
                    for x in bx..bx + 8 {
                        sum += image[(y * W + x) as usize].truncate();
                    }
                }
                sum / 64.0
            };
            let (a, b) = (mean(got), mean(want));
            let ok = (a - b).abs().cmple(b.abs() * 0.02 + raykit::glam::Vec3::splat(0.002)).all();
            close += usize::from(ok);
            blocks += 1;
        }
    }
    [same_paths, close, blocks]
}

/// A test state in a device buffer: one `u32` per element, and the devices'
/// launches bump every element of their band.
struct Counters {
    buffer: DeviceBuffer<u32>,
    row_len: usize,
    launched_on: Vec<std::thread::ThreadId>,
}

impl Counters {
    fn new(ctx: &Context, rows: u32, row_len: usize) -> raykit::Result<Counters> {
        Ok(Counters { buffer: ctx.buffer(rows as usize * row_len)?, row_len, launched_on: Vec::new() })
    }

    /// Adds 1 to every element of `band`'s rows.
    fn bump(&mut self, band: &Band) -> raykit::Result<()> {
        let first = band.first_row() as usize * self.row_len;
        let mut data = vec![0u32; band.row_count() as usize * self.row_len];
        self.buffer.read_into(first, &mut data)?;
        data.iter_mut().for_each(|v| *v += 1);
        self.launched_on.push(std::thread::current().id());
        self.buffer.write_at(first, &data)
    }
}

impl BandRows for Counters {
    type Item = u32;
    fn row_len(&self) -> usize {
        self.row_len
    }
    fn read_rows(&self, rows: Range<u32>, out: &mut [u32]) -> raykit::Result<()> {
        self.buffer.read_into(rows.start as usize * self.row_len, out)
    }
    fn write_rows(&mut self, rows: Range<u32>, data: &[u32]) -> raykit::Result<()> {
        self.buffer.write_at(rows.start as usize * self.row_len, data)
    }
}

#[test]
fn a_group_of_one_device_launches_directly_and_equals_a_plain_render() -> anyhow::Result<()> {
    let name = "a_group_of_one_device_launches_directly_and_equals_a_plain_render";
    with_contexts(name, vec![vulkan()], |ctx| {
        let reference = one_device_render(&ctx[0], 3)?;
        let group = DeviceGroup::new(ctx.to_vec())?;
        let mut renderer = GroupRenderer::new(&group, W, H, Programs::rust)?;
        for _ in 0..3 {
            renderer.launch(SPP)?;
        }
        same_bits(&renderer.accumulation()?, &reference, "a group of one against a plain render")?;
        // No split: one band of every row, launched on the calling thread.
        let mut split = group.split(H, |c| Counters::new(c, H, 4))?;
        for _ in 0..3 {
            split.launch(|state, band| {
                assert_eq!(band.rows, 0..H, "one band of every row");
                state.bump(band)
            })?;
        }
        let caller = std::thread::current().id();
        anyhow::ensure!(split.states()[0].launched_on.iter().all(|t| *t == caller), "launched on the calling thread");
        anyhow::ensure!(split.bands()[0].rows == (0..H), "the band stays whole");
        anyhow::ensure!(split.timings()[0].is_some() && split.rates()[0].is_some(), "the launches were measured");
        anyhow::ensure!(split.gather_vec()?.iter().all(|v| *v == 3), "three launches counted");
        Ok(())
    })
}

#[test]
fn rows_that_change_device_carry_their_state() -> anyhow::Result<()> {
    with_contexts("rows_that_change_device_carry_their_state", vec![vulkan(), cpu(), cpu()], |ctx| {
        let group = DeviceGroup::new(ctx.to_vec())?;
        let schedule =
            [[1.0, 1.0, 1.0], [1.0, 5.0, 1.0], [6.0, 1.0, 1.0], [1.0, 1.0, 9.0], [0.0, 1.0, 0.0], [2.0, 1.0, 3.0]];
        for carry in [true, false] {
            let mut split = group.split(37, |c| Counters::new(c, 37, 3))?;
            split.set_carry_rows(carry);
            for weights in schedule {
                split.set_balance(Balance::Weights(weights.to_vec()))?;
                split.launch(Counters::bump)?;
            }
            let counts = split.gather_vec()?;
            let launches = schedule.len() as u32;
            if carry {
                anyhow::ensure!(counts.iter().all(|c| *c == launches), "every row counted every launch: {counts:?}");
                // The threads: one per device with rows.
                let threads: std::collections::HashSet<_> =
                    split.states().iter().flat_map(|s| s.launched_on.iter().copied()).collect();
                anyhow::ensure!(threads.len() > 3, "launches ran on threads of their own");
            } else {
                anyhow::ensure!(counts.iter().any(|c| *c != launches), "without carrying, moved rows lose their state");
            }
        }
        // A device weighted zero sits out, and keeps nothing.
        let mut split = group.split(10, |c| Counters::new(c, 10, 1))?;
        split.set_balance(Balance::Weights(vec![0.0, 1.0, 1.0]))?;
        split.launch(Counters::bump)?;
        anyhow::ensure!(split.held_bands()[0].is_empty() && split.timings()[0].is_none(), "device 0 sat out");
        anyhow::ensure!(split.gather_vec()? == vec![1; 10], "the others rendered every row");
        Ok(())
    })
}

#[test]
fn context_all_makes_one_context_per_device() -> anyhow::Result<()> {
    let Some(first) = raykit_tests::context_or_skip("context_all_makes_one_context_per_device", vulkan())? else {
        return Ok(());
    };
    let all = Context::all(vulkan())?;
    anyhow::ensure!(!all.is_empty(), "at least the device Context::new found");
    anyhow::ensure!(all[0].shares_device_with(&first), "the first is the device Context::new picks");
    for (i, a) in all.iter().enumerate() {
        for b in &all[i + 1..] {
            anyhow::ensure!(!a.shares_device_with(b), "one context per device");
        }
    }
    let group = DeviceGroup::all(vulkan())?;
    anyhow::ensure!(group.len() == all.len(), "DeviceGroup::all is Context::all");
    let cpu_all = Context::all(cpu())?;
    anyhow::ensure!(cpu_all.len() == 1 && cpu_all[0].backend() == Backend::Cpu, "one CPU-backend context");
    // device_index picks among the usable devices.
    let second = Context::new(ContextOptions { device_index: Some(0), ..vulkan() })?;
    anyhow::ensure!(second.shares_device_with(&first), "device_index 0 is the first device");
    Ok(())
}

#[test]
fn bad_input_gives_typed_errors() -> anyhow::Result<()> {
    with_contexts("device_group_bad_input_gives_typed_errors", vec![vulkan(), cpu()], |ctx| {
        let group = DeviceGroup::new(ctx.to_vec())?;
        // A build that fails on one device names it: the GLSL twin needs Vulkan.
        match GroupRenderer::new(&group, W, H, Programs::glsl) {
            Err(Error::InDevice { device: 1, name, source }) => {
                anyhow::ensure!(
                    matches!(*source, Error::Device(raykit::DeviceError::NotOnCpuBackend { .. })),
                    "{source}"
                );
                anyhow::ensure!(name == ctx[1].device_name(), "named {name}");
            }
            Err(other) => anyhow::bail!("GLSL programs on the CPU backend: {other}"),
            Ok(_) => anyhow::bail!("GLSL programs on the CPU backend were accepted"),
        }
        match group.split(4, |c| Counters::new(c, 4, if c.backend() == Backend::Cpu { 3 } else { 4 })) {
            Err(Error::DeviceGroup(raykit::DeviceGroupError::BandRowLength { device: 1, found: 3, expected: 4 })) => {}
            other => anyhow::bail!("rows of different lengths: {other:?}"),
        }
        let mut split = group.split(8, |c| Counters::new(c, 8, 4))?;
        for bad in [vec![1.0], vec![1.0, -1.0], vec![f64::NAN, 1.0], vec![0.0, 0.0], vec![1.0, f64::INFINITY]] {
            match split.set_balance(Balance::Weights(bad.clone())) {
                Err(e @ Error::DeviceGroup(raykit::DeviceGroupError::BandWeights { .. })) => println!("{e}"),
                other => anyhow::bail!("weights {bad:?}: {other:?}"),
            }
        }
        anyhow::ensure!(split.balance() == &Balance::Measured, "refused weights change nothing");
        split.launch(Counters::bump)?;
        // A launch failing on one device names it, and its rows are forgotten.
        let held = split.bands()[1].rows.clone();
        let err = split.launch(|state, band| {
            if band.device == 1 {
                // Past the buffer's end: a typed error from the device's buffer.
                let mut out = vec![0u32; 4];
                state.buffer.read_into(8 * 4, &mut out)?;
            }
            state.bump(band)
        });
        match err {
            Err(Error::InDevice { device: 1, source, .. }) => {
                anyhow::ensure!(
                    matches!(
                        *source,
                        Error::Resource(raykit::ResourceError::BufferRange { start: 32, end: 36, len: 32 })
                    ),
                    "{source}"
                );
            }
            other => anyhow::bail!("a launch failing on device 1: {other:?}"),
        }
        match split.gather_vec() {
            Err(Error::DeviceGroup(raykit::DeviceGroupError::NotLaunched { first, end })) => {
                anyhow::ensure!(first == held.start && end == held.end, "rows {first}..{end} against {held:?}")
            }
            other => anyhow::bail!("a gather after a failed launch: {other:?}"),
        }
        match Context::new(ContextOptions { device_index: Some(99), ..vulkan() }) {
            Err(Error::Device(raykit::DeviceError::DeviceIndexOutOfRange { index: 99, usable })) => {
                anyhow::ensure!(usable.iter().any(|n| *n == ctx[0].device_name()), "usable: {usable:?}");
            }
            other => anyhow::bail!("device index 99: {other:?}"),
        }
        Ok(())
    })
}
