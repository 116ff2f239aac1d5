//! The denoiser on OIDN's CPU device (the library installed by
//! `cargo xtask setup --denoise`; without it these tests fail naming that command).

use raykit_denoise::{DenoiseDevice, Denoiser, DeviceKind, Error, Input};

fn denoiser() -> Denoiser {
    match Denoiser::new(DenoiseDevice::Cpu) {
        Ok(d) => d,
        Err(e) => panic!("{e}"),
    }
}

/// A smooth picture, and the same with deterministic noise of mean zero.
fn pictures(w: u32, h: u32) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let mut state = 0x1234_5678u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    };
    let mut clean = Vec::new();
    let mut noisy = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let c = [x as f32 / w as f32, y as f32 / h as f32, 0.5];
            clean.push(c);
            noisy.push(c.map(|v| (v * (0.2 + 1.6 * next())).max(0.0)));
        }
    }
    (clean, noisy)
}

fn mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let sum: f64 = a.iter().zip(b).flat_map(|(p, q)| (0..3).map(move |i| (p[i] as f64 - q[i] as f64).powi(2))).sum();
    sum / (a.len() * 3) as f64
}

#[test]
fn the_cpu_device_denoises_a_noisy_gradient() {
    let d = denoiser();
    assert_eq!(d.device(), DeviceKind::Cpu);
    assert!(d.version() >= 20500, "OIDN version {}", d.version());
    let (clean, noisy) = pictures(64, 48);
    let out = d.denoise(&Input::new(64, 48, &noisy)).unwrap();
    let (before, after) = (mse(&noisy, &clean), mse(&out, &clean));
    println!("gradient: MSE noisy {before:.5}, denoised {after:.5} ({:.1}×)", before / after);
    assert!(after * 5.0 < before, "MSE {before} -> {after}");
    assert!(out.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
}

#[test]
fn mismatched_guides_are_typed_errors() {
    let d = denoiser();
    let (_, noisy) = pictures(8, 8);
    let err = d.denoise(&Input::new(8, 8, &noisy).with_albedo(&noisy[..10])).unwrap_err();
    assert!(matches!(err, Error::SizeMismatch { image: "albedo", expected: 64, got: 10, .. }), "{err}");
    assert!(matches!(d.denoise(&Input::new(8, 9, &noisy)), Err(Error::SizeMismatch { image: "color", .. })));
}

#[test]
fn auto_takes_cuda_only_where_it_works() {
    let auto = Denoiser::new(DenoiseDevice::Auto).unwrap();
    match Denoiser::new(DenoiseDevice::Cuda) {
        Ok(cuda) => {
            assert_eq!(cuda.device(), DeviceKind::Cuda);
            assert_eq!(auto.device(), DeviceKind::Cuda);
        }
        Err(e) => {
            assert!(matches!(e, Error::DeviceUnavailable { requested: DeviceKind::Cuda, .. }), "{e}");
            println!("no CUDA device: {e}");
            assert_eq!(auto.device(), DeviceKind::Cpu);
        }
    }
}
