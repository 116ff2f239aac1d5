//! `raykit_device::math` on each backend against `std`'s `f32` methods: a
//! raygen evaluates every function on a table of inputs and the host measures
//! the distance of each result from `std`'s in ulps. The exact functions must
//! agree to the bit on both backends (the CPU backend runs `std` itself). The
//! others are held to bounds set from lavapipe's GLSL.std.450 (measured
//! maxima: exp 50, exp2 3, ln 410 and log2 329 near 1, powf 77, sin/cos 1,
//! tan 2, asin 347 and acos 237 (through atan2), atan and atan2 347 for tiny
//! arguments), within what the Vulkan spec allows (e.g. 3 + 2·|x| ulps for
//! exp, an absolute 2⁻²¹ for ln near 1, 4096 ulps for atan); other drivers may
//! need their own.

use std::f32::consts::PI;

use math_test_device::{Params, FUNCTIONS};
use raykit::device::sampling::Pcg;
use raykit::glam::Vec4;
use raykit::{Backend, LinkOptions, Module, Pipeline, ProgramGroup, Sbt};
use raykit_tests::with_each_backend;

/// Each function's inputs, its `std` reference and the ulps allowed.
struct Check {
    /// Whether `(x, y, z)` is in the domain tested.
    domain: fn(f32, f32, f32) -> bool,
    /// The reference.
    reference: fn(f32, f32, f32) -> f32,
    /// The most ulps from the reference.
    max_ulps: u32,
}

/// `x − floor(x)`, the `fract` of GLSL (`std`'s `fract` truncates).
fn glsl_fract(x: f32) -> f32 {
    x - x.floor()
}

/// The checks, in the order of [`FUNCTIONS`].
fn checks() -> [Check; 29] {
    let any = |_: f32, _: f32, _: f32| true;
    let positive = |x: f32, _: f32, _: f32| x > 0.0;
    let turn = |x: f32, _: f32, _: f32| x.abs() <= PI;
    let unit = |x: f32, _: f32, _: f32| x.abs() <= 1.0;
    let exact = |reference: fn(f32, f32, f32) -> f32| Check { domain: any, reference, max_ulps: 0 };
    [
        exact(|x, _, _| x.floor()),
        exact(|x, _, _| x.ceil()),
        exact(|x, _, _| x.round()),
        exact(|x, _, _| x.trunc()),
        exact(|x, _, _| glsl_fract(x)),
        exact(|x, _, _| x.abs()),
        exact(|x, _, _| x.signum()),
        exact(|x, y, _| x.min(y)),
        exact(|x, y, _| x.max(y)),
        exact(|x, y, z| x.clamp(y, z)),
        Check { domain: any, reference: |x, y, z| x + z * (y - x), max_ulps: 1 },
        Check { domain: positive, reference: |x, _, _| x.sqrt(), max_ulps: 1 },
        Check { domain: positive, reference: |x, _, _| 1.0 / x.sqrt(), max_ulps: 2 },
        Check { domain: |x, _, _| x.abs() <= 80.0, reference: |x, _, _| x.exp(), max_ulps: 64 },
        Check { domain: |x, _, _| x.abs() <= 120.0, reference: |x, _, _| x.exp2(), max_ulps: 4 },
        Check { domain: positive, reference: |x, _, _| x.ln(), max_ulps: 512 },
        Check { domain: positive, reference: |x, _, _| x.log2(), max_ulps: 512 },
        Check { domain: |x, y, _| x > 0.0 && x.powf(y).is_normal(), reference: |x, y, _| x.powf(y), max_ulps: 128 },
        Check { domain: turn, reference: |x, _, _| x.sin(), max_ulps: 4 },
        Check { domain: turn, reference: |x, _, _| x.cos(), max_ulps: 4 },
        Check { domain: |x, _, _| x.abs() <= 1.5, reference: |x, _, _| x.tan(), max_ulps: 4 },
        Check { domain: turn, reference: |x, _, _| x.sin(), max_ulps: 4 },
        Check { domain: turn, reference: |x, _, _| x.cos(), max_ulps: 4 },
        Check { domain: unit, reference: |x, _, _| x.asin(), max_ulps: 512 },
        Check { domain: unit, reference: |x, _, _| x.acos(), max_ulps: 512 },
        Check { domain: any, reference: |x, _, _| x.atan(), max_ulps: 512 },
        Check { domain: |x, y, _| x != 0.0 || y != 0.0, reference: |x, y, _| x.atan2(y), max_ulps: 512 },
        Check {
            domain: any,
            reference: |x, y, z| {
                let t = ((x - y) / (z - y)).clamp(0.0, 1.0);
                t * t * (3.0 - 2.0 * t)
            },
            max_ulps: 2,
        },
        exact(|x, y, _| if x < y { 0.0 } else { 1.0 }),
    ]
}

/// The distance of `a` from `b` in ulps (0 for two NaNs, `u64::MAX` for one).
fn ulps(a: f32, b: f32) -> u64 {
    match (a.is_nan(), b.is_nan()) {
        (true, true) => return 0,
        (false, false) => {}
        _ => return u64::MAX,
    }
    let ordered = |f: f32| {
        let bits = f.to_bits() as i32;
        (if bits < 0 { i32::MIN.wrapping_sub(bits) } else { bits }) as i64
    };
    ordered(a).abs_diff(ordered(b))
}

/// The inputs: `x` across `[−100, 100]`, across `[−π, π]` and `[−1, 1]`,
/// log-uniform over `[1e-30, 1e30]`, and special values (halfway cases, ±0,
/// the largest odd integer below 2²⁴, a value just below ½); `y ≤ z` in
/// `[−10, 20]`.
fn inputs() -> Vec<Vec4> {
    let mut rng = Pcg::new(5, 17);
    let mut xs: Vec<f32> = vec![
        0.0,
        -0.0,
        0.5,
        -0.5,
        1.5,
        -1.5,
        2.5,
        -2.5,
        0.499_999_97,
        -0.499_999_97,
        16_777_215.0,
        8_388_609.5,
        1.0,
        -1.0,
        PI,
        -PI,
        1e-30,
        -1e-30,
    ];
    for _ in 0..1024 {
        xs.push(rng.next_f32() * 200.0 - 100.0);
        xs.push((rng.next_f32() * 2.0 - 1.0) * PI);
        xs.push(rng.next_f32() * 2.0 - 1.0);
        xs.push(10f32.powf(rng.next_f32() * 60.0 - 30.0));
    }
    xs.into_iter()
        .map(|x| {
            // Some exact ties for min, max, clamp and step.
            let y = if rng.next_f32() < 0.05 { x } else { rng.next_f32() * 20.0 - 10.0 };
            let z = y + rng.next_f32() * 10.0;
            Vec4::new(x, y, z, 0.0)
        })
        .collect()
}

#[test]
fn device_math_matches_std_on_each_backend() -> anyhow::Result<()> {
    let inputs = inputs();
    let checks = checks();
    assert_eq!(checks.len(), FUNCTIONS.len());
    with_each_backend("device_math_matches_std_on_each_backend", |ctx, backend| {
        let module = Module::from_device_crate(ctx, "math-test-device")?;
        let raygen = ProgramGroup::raygen(&module, math_test_device::RG)?;
        let pipeline = Pipeline::<Params>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        let input = ctx.buffer_from(&inputs)?;
        let output = ctx.buffer::<f32>(inputs.len() * FUNCTIONS.len())?;
        pipeline.launch(
            &sbt,
            &Params { inputs: input.handle(), outputs: output.handle() },
            [inputs.len() as u32, 1, 1],
        )?;
        let results = output.read()?;
        let mut failures = Vec::new();
        println!("{backend:?}: max ulps from std over {} inputs", inputs.len());
        for (k, (name, check)) in FUNCTIONS.iter().zip(&checks).enumerate() {
            let mut worst = (0u64, Vec4::ZERO, 0.0f32, 0.0f32);
            let mut tested = 0;
            for (i, v) in inputs.iter().enumerate() {
                if !(check.domain)(v.x, v.y, v.z) {
                    continue;
                }
                tested += 1;
                let (got, want) = (results[i * FUNCTIONS.len() + k], (check.reference)(v.x, v.y, v.z));
                let error = ulps(got, want);
                if error > worst.0 {
                    worst = (error, *v, got, want);
                }
            }
            // The CPU backend runs `std`'s methods: exact.
            let bound = if backend == Backend::Cpu { 0 } else { check.max_ulps };
            println!("  {name:<22} {:>6} ulps (bound {bound}, {tested} inputs)", worst.0);
            anyhow::ensure!(tested > 100, "{name}: only {tested} inputs in its domain");
            if worst.0 > bound as u64 {
                failures.push(format!("{name}: {} ulps at {:?}: {} vs std {}", worst.0, worst.1, worst.2, worst.3));
            }
        }
        anyhow::ensure!(failures.is_empty(), "{backend:?}: {failures:#?}");
        Ok(())
    })
}
