//! Equirectangular environment maps with the tables that importance-sample
//! them: per texel a sampling weight (luminance × sin θ, the texel's share of
//! solid angle), a marginal CDF over rows and a conditional CDF per row, laid
//! out as [`raykit_device::environment`] reads them on the device (upload
//! [`EnvironmentMap::cdf`] as a `Buffer<f32>`, the radiance as a texture).

use glam::{Vec2, Vec3};
use raykit_device::environment::{environment_pdf, equirect_uv, sample_environment, EnvironmentSample};

/// Why an environment map could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EnvironmentError {
    /// The size and the texel count disagree, or the map is empty.
    #[error("environment map of {width}×{height} with {texels} texels; give width × height (at least 1×1) texels, row 0 at the top (straight up)")]
    Size {
        /// Width given.
        width: u32,
        /// Height given.
        height: u32,
        /// Texels given.
        texels: usize,
    },
    /// A texel is negative, infinite or NaN.
    #[error("environment map texel {index} is {value}; radiance must be finite and non-negative")]
    BadTexel {
        /// The texel's index.
        index: usize,
        /// Its value.
        value: Vec3,
    },
}

/// An equirectangular map of linear radiance and its sampling tables.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    /// Width in texels (φ from −π to π, `u = 0.5` looking down −z).
    pub width: u32,
    /// Height in texels (θ from 0, straight up, to π).
    pub height: u32,
    /// Linear RGB radiance, row-major, row 0 at the top.
    pub radiance: Vec<Vec3>,
    /// The marginal and conditional CDFs (see [`raykit_device::environment`]).
    pub cdf: Vec<f32>,
}

/// Rec. 709 luminance.
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl EnvironmentMap {
    /// The map of `radiance` (`width × height`, row 0 at the top) and its tables.
    /// A black map is sampled uniformly over its texels.
    pub fn new(width: u32, height: u32, radiance: Vec<Vec3>) -> Result<EnvironmentMap, EnvironmentError> {
        if width == 0 || height == 0 || radiance.len() != width as usize * height as usize {
            return Err(EnvironmentError::Size { width, height, texels: radiance.len() });
        }
        if let Some((index, &value)) =
            radiance.iter().enumerate().find(|(_, c)| !c.is_finite() || c.min_element() < 0.0)
        {
            return Err(EnvironmentError::BadTexel { index, value });
        }
        let (w, h) = (width as usize, height as usize);
        let mut rows = vec![0.0f64; h];
        let mut conditional = Vec::with_capacity(h * (w + 1));
        for (y, row_sum) in rows.iter_mut().enumerate() {
            let sin_theta = (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin();
            let weights: Vec<f64> =
                radiance[y * w..(y + 1) * w].iter().map(|&c| luminance(c) as f64 * sin_theta).collect();
            *row_sum = weights.iter().sum();
            conditional.extend(cumulative(&weights, *row_sum));
        }
        let total: f64 = rows.iter().sum();
        let mut cdf = cumulative(&rows, total);
        cdf.extend(conditional);
        Ok(EnvironmentMap { width, height, radiance, cdf })
    }

    /// The map of an `image` crate picture (linear radiance).
    pub fn from_image(image: &image::Rgb32FImage) -> Result<EnvironmentMap, EnvironmentError> {
        let radiance = image.pixels().map(|p| Vec3::from_array(p.0)).collect();
        Self::new(image.width(), image.height(), radiance)
    }

    /// A direction sampled from two uniform numbers in `[0, 1)` (what device
    /// programs compute from the same tables).
    pub fn sample(&self, u1: f32, u2: f32) -> EnvironmentSample {
        sample_environment(self.width, self.height, |i| self.cdf[i as usize], u1, u2)
    }

    /// The pdf per steradian of sampling unit direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        environment_pdf(self.width, self.height, |i| self.cdf[i as usize], d)
    }

    /// The radiance of the texel `d` falls in.
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let uv: Vec2 = equirect_uv(d);
        let x = ((uv.x * self.width as f32) as u32).min(self.width - 1);
        let y = ((uv.y * self.height as f32) as u32).min(self.height - 1);
        self.radiance[(y * self.width + x) as usize]
    }

    /// The solid angle of texel row `y`'s texels.
    pub fn texel_solid_angle(&self, y: u32) -> f64 {
        let pi = std::f64::consts::PI;
        let (t0, t1) = (pi * y as f64 / self.height as f64, pi * (y + 1) as f64 / self.height as f64);
        2.0 * pi / self.width as f64 * (t0.cos() - t1.cos())
    }
}

/// `0, w0, w0 + w1, …` over `total` (`n + 1` entries, the last 1); uniform when `total` is 0.
fn cumulative(weights: &[f64], total: f64) -> Vec<f32> {
    let n = weights.len();
    let mut out = Vec::with_capacity(n + 1);
    let mut sum = 0.0;
    out.push(0.0);
    for (i, &w) in weights.iter().enumerate() {
        sum += w;
        out.push(if total > 0.0 { (sum / total) as f32 } else { (i + 1) as f32 / n as f32 });
    }
    out[n] = 1.0;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use raykit_device::sampling::Pcg;

    /// A sky: dim blue everywhere, a bright sun near the horizon.
    fn sky() -> EnvironmentMap {
        let (w, h) = (32u32, 16u32);
        let mut radiance = vec![Vec3::new(0.1, 0.2, 0.4); (w * h) as usize];
        radiance[(6 * w + 20) as usize] = Vec3::new(500.0, 450.0, 400.0);
        radiance[(6 * w + 21) as usize] = Vec3::new(200.0, 180.0, 160.0);
        EnvironmentMap::new(w, h, radiance).unwrap()
    }

    fn mean_and_se(xs: &[f64]) -> (f64, f64) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
        (mean, (var / n).sqrt())
    }

    #[test]
    fn the_pdf_integrates_to_one_and_matches_the_samples() {
        let map = sky();
        let mut rng = Pcg::new(9, 1);
        // ∫ pdf dω by uniform sphere sampling: E[4π pdf(ω)] = 1.
        let uniform: Vec<f64> = (0..200_000)
            .map(|_| {
                let z = 1.0 - 2.0 * rng.next_f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
                let d = Vec3::new(r * phi.cos(), z, r * phi.sin());
                4.0 * std::f64::consts::PI * map.pdf(d) as f64
            })
            .collect();
        let (mean, se) = mean_and_se(&uniform);
        assert!((mean - 1.0).abs() < 5.0 * se, "∫pdf = {mean} ± {se}");
        // Each sample's pdf is the pdf of its direction.
        for _ in 0..10_000 {
            let s = map.sample(rng.next_f32(), rng.next_f32());
            assert!((s.direction.length() - 1.0).abs() < 1e-4);
            let p = map.pdf(s.direction);
            assert!((s.pdf - p).abs() <= 1e-3 * p.max(1e-3) || s.pdf == 0.0, "{} vs {p}", s.pdf);
        }
    }

    #[test]
    fn importance_sampling_estimates_the_irradiance_integral_with_less_variance() {
        let map = sky();
        // ∫ L dω exactly, texel by texel (L is constant per texel).
        let exact: f64 = (0..map.height)
            .map(|y| {
                let row: f64 =
                    (0..map.width).map(|x| luminance(map.radiance[(y * map.width + x) as usize]) as f64).sum();
                row * map.texel_solid_angle(y)
            })
            .sum();
        let mut rng = Pcg::new(5, 5);
        let n = 100_000;
        let importance: Vec<f64> = (0..n)
            .map(|_| {
                let s = map.sample(rng.next_f32(), rng.next_f32());
                if s.pdf > 0.0 {
                    luminance(map.radiance(s.direction)) as f64 / s.pdf as f64
                } else {
                    0.0
                }
            })
            .collect();
        let (mean, se) = mean_and_se(&importance);
        assert!((mean - exact).abs() < 5.0 * se + 1e-4 * exact, "{mean} ± {se} vs {exact}");
        let uniform: Vec<f64> = (0..n)
            .map(|_| {
                let z = 1.0 - 2.0 * rng.next_f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
                luminance(map.radiance(Vec3::new(r * phi.cos(), z, r * phi.sin()))) as f64 * 4.0 * std::f64::consts::PI
            })
            .collect();
        let (_, se_uniform) = mean_and_se(&uniform);
        assert!(se * 5.0 < se_uniform, "importance SE {se} not well below uniform SE {se_uniform}");
    }

    #[test]
    fn bad_maps_are_refused() {
        assert!(matches!(EnvironmentMap::new(2, 2, vec![Vec3::ONE; 3]), Err(EnvironmentError::Size { .. })));
        let mut texels = vec![Vec3::ONE; 4];
        texels[2] = Vec3::new(f32::NAN, 0.0, 0.0);
        assert!(matches!(EnvironmentMap::new(2, 2, texels), Err(EnvironmentError::BadTexel { index: 2, .. })));
        // A black map is sampled uniformly: still a pdf.
        let black = EnvironmentMap::new(4, 2, vec![Vec3::ZERO; 8]).unwrap();
        assert!(black.sample(0.3, 0.6).pdf > 0.0);
    }
}
