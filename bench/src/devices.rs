//! The `devices` suite: the path tracer on one device against the same render
//! split across a device group, side by side in one run.
//!
//! The group is `--devices` (default `all`: one context per ray-tracing GPU,
//! `Context::all`; `N`: N contexts over the devices in turn, which on a machine
//! with one device share it). One device is the group's first context alone,
//! through a group of one (a direct launch, no split). The render is the Cornell
//! box at `--path-size` (default 512) with `--spp` paths per pixel (64 when left
//! at 1) in progressive launches of `--spp-per-launch` (default 16), timed by the
//! wall clock from the first launch to the image gathered in host memory: what
//! a user waits for. One warm-up render each (it also lets the group measure its
//! devices: the timed renders start from those bands), then `--reps` renders
//! each, alternating. The speed-up is the median of per-repetition ratios of the
//! one device's time to the group's.
//!
//! Both renders are checked: when every device of the group has the same name
//! (one GPU model and driver), the same picture bit for bit; otherwise the same
//! rays within 1%, and the differing pixels are counted.

use std::time::Instant;

use path_tracer::{GroupRenderer, Programs};
use raykit::glam::Vec4;
use raykit::{ContextOptions, DeviceGroup};

use crate::stats::Summary;
use crate::trace::Options;

/// The suite's results.
pub struct Results {
    devices: Vec<String>,
    size: u32,
    spp: u32,
    spp_per_launch: u32,
    reps: usize,
    rays: u64,
    one: Summary,
    group: Summary,
    speedup: Summary,
    /// The group's last bands, rows per device.
    bands: Vec<u32>,
    /// Rows per second of each device, as the group measured them.
    rates: Vec<Option<f64>>,
    /// Pixels whose accumulated value differs between the renders.
    differing: usize,
}

/// Runs the suite over the devices `opts.devices` names (`device`: a name filter).
pub fn run(opts: &Options, device: Option<&str>) -> anyhow::Result<Results> {
    let options = ContextOptions {
        validation: Some(false),
        device_name_contains: device.map(str::to_owned),
        ..Default::default()
    };
    let group = DeviceGroup::new(path_tracer::device_contexts(&opts.devices, options)?)?;
    let devices: Vec<String> = group.contexts().iter().map(|c| c.device_name().into_owned()).collect();
    eprintln!("devices: {} device(s): {}", devices.len(), devices.join(", "));
    let one = DeviceGroup::new(group.contexts()[..1].to_vec())?;
    let size = opts.path_size;
    let spp = if opts.spp == 1 { 64 } else { opts.spp };
    let per_launch = opts.spp_per_launch.clamp(1, spp);
    let mut single = GroupRenderer::new(&one, size, size, Programs::rust)?;
    let mut split = GroupRenderer::new(&group, size, size, Programs::rust)?;
    let render = |renderer: &mut GroupRenderer| -> anyhow::Result<(f64, Vec<Vec4>)> {
        renderer.reset();
        let started = Instant::now();
        while renderer.samples_done() < spp {
            renderer.launch(per_launch.min(spp - renderer.samples_done()))?;
        }
        let accum = renderer.accumulation()?;
        Ok((started.elapsed().as_secs_f64(), accum))
    };
    let (_, warm_one) = render(&mut single)?;
    let (_, warm_group) = render(&mut split)?;
    let rays = |accum: &[Vec4]| accum.iter().map(|p| f64::from(p.w)).sum::<f64>() as u64;
    let (rays_one, rays_group) = (rays(&warm_one), rays(&warm_group));
    let bits = |p: &Vec4| p.to_array().map(f32::to_bits);
    let differing = warm_one.iter().zip(&warm_group).filter(|(a, b)| bits(a) != bits(b)).count();
    if devices.iter().all(|d| *d == devices[0]) {
        anyhow::ensure!(differing == 0, "{differing} pixels differ between one device and the group of alike devices");
    } else {
        // Devices that round differently may send a grazing ray another way.
        anyhow::ensure!(
            rays_one.abs_diff(rays_group) * 100 <= rays_one,
            "one device traced {rays_one} rays, the group {rays_group}"
        );
    }
    let (mut one_s, mut group_s) = (Vec::new(), Vec::new());
    for rep in 0..opts.reps {
        let (a, b) = crate::launch::pair(rep, || render(&mut single), || render(&mut split))?;
        one_s.push(a.0);
        group_s.push(b.0);
    }
    let ratios: Vec<f64> = one_s.iter().zip(&group_s).map(|(a, b)| a / b).collect();
    let bands = split.split().held_bands().iter().map(|b| b.row_count()).collect();
    Ok(Results {
        devices,
        size,
        spp,
        spp_per_launch: per_launch,
        reps: opts.reps,
        rays: rays_one,
        one: Summary::of(&one_s),
        group: Summary::of(&group_s),
        speedup: Summary::of(&ratios),
        bands,
        rates: split.split().rates().to_vec(),
        differing,
    })
}

/// The results as a Markdown table.
pub fn markdown(r: &Results) -> String {
    let mut s = format!(
        "The path tracer (Cornell box, {0}x{0}, {1} spp in launches of {2}), wall clock from the first launch to the \
         gathered image; {3} render(s) each, alternating, after a warm-up each; median (± half the interquartile \
         range); speed-up: median of per-repetition ratios. Group: {4}.\n\n",
        r.size,
        r.spp,
        r.spp_per_launch,
        r.reps,
        r.devices.join(", ")
    );
    s.push_str("| render | devices | rays | s/render | Mrays/s | speed-up (min–max) |\n");
    s.push_str("|---|---:|---:|---:|---:|---:|\n");
    for (name, n, t, speedup) in [
        ("one device", 1, &r.one, String::from("1.00")),
        (
            "split",
            r.devices.len(),
            &r.group,
            format!("{:.2} ({:.2}–{:.2})", r.speedup.median, r.speedup.min, r.speedup.max),
        ),
    ] {
        s.push_str(&format!(
            "| {name} | {n} | {} | {:.3} ± {:.1}% | {:.1} | {speedup} |\n",
            r.rays,
            t.median,
            t.spread_percent(),
            r.rays as f64 / t.median / 1e6,
        ));
    }
    let rates: Vec<String> = r.rates.iter().map(|x| x.map_or_else(|| "-".to_owned(), |x| format!("{x:.0}"))).collect();
    let bands: Vec<String> = r.bands.iter().map(u32::to_string).collect();
    s.push_str(&format!(
        "\nLast bands (rows per device): {}; measured rows/s: {}; pixels differing from the one-device render: {}.\n",
        bands.join(" / "),
        rates.join(" / "),
        r.differing
    ));
    s
}

/// The results as JSON.
pub fn json(r: &Results) -> serde_json::Value {
    serde_json::json!({
        "devices": r.devices, "size": r.size, "spp": r.spp, "spp_per_launch": r.spp_per_launch, "reps": r.reps,
        "rays": r.rays, "one_device_seconds": r.one.json(), "group_seconds": r.group.json(),
        "speedup": r.speedup.json(), "bands": r.bands, "rows_per_second": r.rates, "differing_pixels": r.differing,
    })
}
