//! glTF's metallic-roughness BSDF: a Lambertian diffuse lobe for the dielectric
//! part and a GGX (Trowbridge–Reitz) microfacet lobe with Smith masking and
//! Schlick's Fresnel, mixed by `metallic` as the glTF 2.0 specification's
//! appendix B does (`F0 = mix(0.04, base colour, metallic)`, the diffuse lobe
//! weighted by `1 − metallic`). The appendix weights the diffuse lobe by
//! `1 − F(v·h)`, which reflects more than it receives (the white furnace below
//! measures an albedo of 1.025 at normal incidence); here it is weighted by
//! `(1 − F(n·v)) (1 − F(n·l))` with the dielectric's `F0 = 0.04`, which keeps the
//! albedo at or below 1.
//!
//! Directions are in the shading frame (normal = +z). [`sample`] picks the
//! specular lobe with probability [`specular_probability`], draws its half
//! vector from the visible normals, or a cosine-weighted diffuse direction, and
//! returns the direction with `f · cos θ / pdf` and the pdf of the mixture, so
//! that [`eval`] and [`pdf`] agree with it (multiple importance sampling with
//! light samples needs both).

use raykit_device::glam::Vec3;
use raykit_device::sampling::{
    cosine_hemisphere_pdf, cosine_sample_hemisphere, ggx_d, ggx_g2, ggx_sample_vndf, ggx_vndf_pdf, reflect, PI,
};

/// A surface's material at a point (after its textures are applied).
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct SurfaceMaterial {
    /// Base colour (linear).
    pub base_color: Vec3,
    /// Metallic, 0..1.
    pub metallic: f32,
    /// Perceptual roughness, 0..1 (the GGX α is its square).
    pub roughness: f32,
}

impl SurfaceMaterial {
    /// GGX α, kept above 10⁻³ so that the lobe stays a function.
    pub fn alpha(&self) -> f32 {
        (self.roughness * self.roughness).max(1e-3)
    }
    /// Reflectance at normal incidence.
    pub fn f0(&self) -> Vec3 {
        Vec3::splat(0.04).lerp(self.base_color, self.metallic)
    }
}

/// Schlick's Fresnel.
pub fn fresnel(f0: Vec3, cos: f32) -> Vec3 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    f0 + (Vec3::ONE - f0) * (m2 * m2 * m)
}

/// The probability with which [`sample`] picks the specular lobe.
pub fn specular_probability(m: &SurfaceMaterial, v: Vec3) -> f32 {
    let f = fresnel(m.f0(), v.z.max(0.0));
    let spec = f.max_element();
    let diffuse = (1.0 - m.metallic) * m.base_color.max_element();
    if spec + diffuse > 0.0 {
        (spec / (spec + diffuse)).clamp(0.05, 1.0)
    } else {
        1.0
    }
}

/// `f(v, l) · cos θl` for view `v` and light `l` (both away from the surface).
pub fn eval(m: &SurfaceMaterial, v: Vec3, l: Vec3) -> Vec3 {
    if v.z <= 0.0 || l.z <= 0.0 {
        return Vec3::ZERO;
    }
    let h = (v + l).normalize();
    let alpha = m.alpha();
    let f = fresnel(m.f0(), v.dot(h).max(0.0));
    let specular = f * (ggx_d(h.z, alpha) * ggx_g2(v.z, l.z, alpha) / (4.0 * v.z * l.z));
    // The dielectric part's Fresnel (F0 = 0.04), as glTF mixes a dielectric and a metal.
    let f0 = Vec3::splat(0.04);
    let diffuse =
        (Vec3::ONE - fresnel(f0, v.z)) * (Vec3::ONE - fresnel(f0, l.z)) * m.base_color * ((1.0 - m.metallic) / PI);
    (specular + diffuse) * l.z
}

/// The pdf (per steradian) with which [`sample`] picks `l` for view `v`.
pub fn pdf(m: &SurfaceMaterial, v: Vec3, l: Vec3) -> f32 {
    if v.z <= 0.0 || l.z <= 0.0 {
        return 0.0;
    }
    let h = (v + l).normalize();
    let p_spec = specular_probability(m, v);
    let spec = ggx_vndf_pdf(v, h, m.alpha()) / (4.0 * v.dot(h).max(1e-8));
    p_spec * spec + (1.0 - p_spec) * cosine_hemisphere_pdf(l.z)
}

/// A sampled direction.
#[derive(Copy, Clone, Debug, PartialEq)]
pub struct BsdfSample {
    /// The direction (shading frame).
    pub l: Vec3,
    /// `f · cos θ / pdf` (zero when the direction is below the surface).
    pub weight: Vec3,
    /// The mixture's pdf.
    pub pdf: f32,
}

/// Samples a direction for view `v` from three uniform numbers.
pub fn sample(m: &SurfaceMaterial, v: Vec3, u0: f32, u1: f32, u2: f32) -> BsdfSample {
    let l = if u0 < specular_probability(m, v) {
        reflect(-v, ggx_sample_vndf(v, m.alpha(), u1, u2))
    } else {
        cosine_sample_hemisphere(u1, u2)
    };
    let p = pdf(m, v, l);
    let weight = if p > 0.0 { eval(m, v, l) / p } else { Vec3::ZERO };
    BsdfSample { l, weight, pdf: p }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    //! The white furnace: with a white base colour, the directional albedo
    //! `∫ f cos dω` is estimated twice, by the BSDF's own importance sampling
    //! (`E[weight]`) and by uniform hemisphere sampling (`E[f cos / (1/2π)]`);
    //! the two estimates must agree within 5 combined standard errors (both
    //! unbiased for the same integral: sample, pdf and eval are consistent), and
    //! the albedo may not exceed 1 by more than 5 standard errors (energy
    //! conservation). Smith's single-scattering model loses energy at high
    //! roughness, so the albedo is not 1.
    use super::*;
    use raykit_device::sampling::Pcg;

    fn estimate(n: usize, mut f: impl FnMut() -> f64) -> (f64, f64) {
        let (mut sum, mut sum_sq) = (0.0, 0.0);
        for _ in 0..n {
            let x = f();
            sum += x;
            sum_sq += x * x;
        }
        let mean = sum / n as f64;
        (mean, ((sum_sq / n as f64 - mean * mean).max(0.0) / n as f64).sqrt())
    }

    #[test]
    fn white_furnace() {
        let n = 200_000;
        for (i, &(metallic, roughness)) in [
            (0.0f32, 0.05f32),
            (0.0, 0.2),
            (0.0, 0.5),
            (0.0, 1.0),
            (1.0, 0.1),
            (1.0, 0.3),
            (1.0, 0.5),
            (1.0, 1.0),
            (0.5, 0.3),
        ]
        .iter()
        .enumerate()
        {
            let m = SurfaceMaterial { base_color: Vec3::ONE, metallic, roughness };
            for &cos_v in &[0.95f32, 0.5, 0.15] {
                let v = Vec3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
                let mut rng = Pcg::new(i as u32, (cos_v * 100.0) as u32);
                let (importance, se_i) = estimate(n, || {
                    let s = sample(&m, v, rng.next_f32(), rng.next_f32(), rng.next_f32());
                    assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0, "{s:?}");
                    s.weight.x as f64
                });
                let (uniform, se_u) = estimate(n, || {
                    let z = rng.next_f32();
                    let r = (1.0 - z * z).max(0.0).sqrt();
                    let phi = 2.0 * PI * rng.next_f32();
                    let l = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                    eval(&m, v, l).x as f64 * 2.0 * std::f64::consts::PI
                });
                let se = (se_i * se_i + se_u * se_u).sqrt();
                // Uniform sampling cannot resolve lobes narrower than this with these
                // samples (it rarely lands in them, and its standard error is then
                // underestimated): sharper lobes are checked for energy only.
                let resolvable = roughness >= 0.2;
                assert!(
                    !resolvable || (importance - uniform).abs() < 5.0 * se,
                    "metallic {metallic} roughness {roughness} cos {cos_v}: importance {importance} ± {se_i}, uniform {uniform} ± {se_u}"
                );
                assert!(importance < 1.0 + 5.0 * se_i, "albedo {importance} ± {se_i} over 1");
                // Smooth white surfaces seen from above reflect nearly all (rough GGX loses
                // much to single scattering: 0.31 at roughness 1 seen from above).
                assert!(
                    roughness > 0.1 || cos_v < 0.5 || importance > 0.9,
                    "metallic {metallic} roughness {roughness} cos {cos_v}: albedo {importance}"
                );
            }
        }
    }

    #[test]
    fn the_diffuse_lobe_is_lambert_weighted_by_fresnel() {
        let m = SurfaceMaterial { base_color: Vec3::new(0.5, 0.25, 1.0), metallic: 0.0, roughness: 1.0 };
        let (v, l) = (Vec3::Z, Vec3::new(0.6, 0.0, 0.8));
        // The specular lobe alone: the same material with a black base colour.
        let spec = eval(&SurfaceMaterial { base_color: Vec3::ZERO, ..m }, v, l);
        let f0 = Vec3::splat(0.04);
        let want = (Vec3::ONE - fresnel(f0, v.z)) * (Vec3::ONE - fresnel(f0, l.z)) * m.base_color / PI * l.z;
        assert!((eval(&m, v, l) - spec - want).abs().max_element() < 1e-6);
        // A metal has no diffuse lobe.
        let metal = SurfaceMaterial { metallic: 1.0, ..m };
        assert_eq!(
            eval(&metal, v, l),
            eval(&SurfaceMaterial { metallic: 1.0, base_color: m.base_color, roughness: 1.0 }, v, l)
        );
        assert_eq!(eval(&m, v, Vec3::new(0.0, 0.6, -0.8)), Vec3::ZERO);
    }
}
