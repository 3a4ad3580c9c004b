//! Renders whose answer is known in closed form.

use super::*;
use crate::space::FnField;

#[test]
fn slab_alpha_is_beer_lambert_and_exact_at_any_step() {
    // The slab fills the marched box, so every ray crosses thickness L = 0.8 of density 1.5.
    let (rho, kappa, thickness) = (1.5, 1.25, 0.8);
    let density = slab(1, DVec3::splat(rho), -0.4, 0.4);
    let expected = 1.0 - (-kappa * rho * thickness).exp();
    for step in [0.001, 0.07, 0.3] {
        let settings = RenderSettings {
            kappa: DVec3::splat(kappa),
            step: Some(step),
            ..small(8, 8)
        };
        let image = render(&scene(&density, vec![]), &settings).unwrap();
        for p in &image.rgba {
            assert!(
                (p[3] as f64 - expected).abs() < 1e-5,
                "step {step}: {} vs {expected}",
                p[3]
            );
            assert_eq!(&p[..3], &[0.0, 0.0, 0.0]);
        }
    }
}

#[test]
fn lit_and_emitting_slabs_match_their_closed_forms() {
    let (rho, kappa, thickness) = (1.5, 1.25, 0.8);
    let density = slab(1, DVec3::splat(rho), -0.4, 0.4);
    // Emission E per unit length, no light: C = E·(1 − e^{−κρL})/(κρ), exactly at any step.
    let glow = DVec3::new(2.0, 1.0, 0.5);
    let emission = slab(3, glow, -0.4, 0.4);
    let mut emitting = scene(&density, vec![]);
    emitting.emission = Some(&emission);
    let settings = RenderSettings {
        kappa: DVec3::splat(kappa),
        step: Some(0.05),
        ..small(4, 4)
    };
    let image = render(&emitting, &settings).unwrap();
    let expected = glow * (1.0 - (-kappa * rho * thickness).exp()) / (kappa * rho);
    for p in &image.rgba {
        for c in 0..3 {
            assert!(
                (p[c] as f64 - expected[c]).abs() < 1e-5,
                "{} vs {}",
                p[c],
                expected[c]
            );
        }
    }
    // A distant light shining along the view direction, colour C_d, isotropic phase: light
    // and view paths have equal length s, so C = C_d·L·ρ∫₀ᴸ e^{−2κρs} ds
    // = C_d·L·(1 − e^{−2κρL})/(2κ). Shadows marched per sample are exact for a slab; the
    // midpoint light sample makes the march second order in the step.
    let albedo = DVec3::new(0.9, 0.5, 0.2);
    let color = slab(3, albedo, -0.4, 0.4);
    let light = Light::distant(-DVec3::Z, DVec3::splat(3.0)).unwrap();
    let mut lit = scene(&density, vec![light]);
    lit.color = Some(&color);
    let expected = albedo * 3.0 * (1.0 - (-2.0 * kappa * rho * thickness).exp()) / (2.0 * kappa);
    let mut errors = Vec::new();
    for step in [0.004, 0.002] {
        let settings = RenderSettings {
            kappa: DVec3::splat(kappa),
            step: Some(step),
            shadows: Shadows::March,
            ..small(4, 4)
        };
        let image = render(&lit, &settings).unwrap();
        let p = image.rgba[5];
        errors.push((p[0] as f64 - expected.x).abs());
        for c in 0..3 {
            assert!((p[c] as f64 - expected[c]).abs() < 2e-5 * expected[c].max(1.0));
        }
    }
    // Second order: halving the step quarters the error (up to f32 output rounding).
    assert!(errors[1] < 0.3 * errors[0] + 2e-7, "{errors:?}");
}

#[test]
fn coarse_step_error_is_first_order_from_the_boundary_steps() {
    // A slab strictly inside the marched box: each boundary cuts a step, whose midpoint sample
    // then counts the whole step as inside or outside, an optical-depth error of up to κρΔs
    // per boundary. With the per-ray jitter uniform, that error averages to zero and its mean
    // size is proportional to Δs: first order, ratio 2 per halving. The thickness is
    // (8 + 1/3)·0.08, so the two boundaries keep the same relative phase (1/3 or 2/3, alike by
    // symmetry) at every step halved; at a whole number of steps their errors would cancel.
    let (rho, kappa) = (1.0, 1.0);
    let thickness = 0.08 * 25.0 / 3.0;
    let density = slab(1, DVec3::splat(rho), -0.37, -0.37 + thickness);
    let expected = 1.0 - (-kappa * rho * thickness).exp();
    let mut mean_abs = Vec::new();
    for step in [0.08, 0.04, 0.02] {
        let settings = RenderSettings {
            kappa: DVec3::splat(kappa),
            step: Some(step),
            bounds: Some(Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0))),
            ..small(64, 64)
        };
        let image = render(&scene(&density, vec![]), &settings).unwrap();
        let errors: Vec<f64> = image.rgba.iter().map(|p| p[3] as f64 - expected).collect();
        let abs = errors.iter().map(|e| e.abs()).sum::<f64>() / errors.len() as f64;
        let signed = errors.iter().sum::<f64>() / errors.len() as f64;
        // Unbiased: the mean error is a small fraction of the mean size of the error (the
        // residue is the curvature of 1 − e^{−τ}, second order).
        assert!(
            signed.abs() < 0.15 * abs,
            "step {step}: signed {signed}, abs {abs}"
        );
        mean_abs.push(abs);
    }
    for pair in mean_abs.windows(2) {
        let order = (pair[0] / pair[1]).log2();
        assert!(
            (0.85..1.15).contains(&order),
            "observed order {order} from {mean_abs:?}"
        );
    }
}

#[test]
fn zero_and_huge_extinction_are_finite_and_exact() {
    let rho = 2.0;
    let density = slab(1, DVec3::splat(rho), -0.25, 0.25);
    let light = Light::distant(DVec3::new(1.0, -1.0, 0.0), DVec3::splat(0.5)).unwrap();
    // κ = 0: nothing is absorbed, alpha 0, and every step scatters Δs·ρ·L: C = ρ·L·thickness.
    let settings = RenderSettings {
        kappa: DVec3::ZERO,
        step: Some(0.01),
        ..small(4, 4)
    };
    let image = render(&scene(&density, vec![light.clone()]), &settings).unwrap();
    for p in &image.rgba {
        assert_eq!(p[3], 0.0);
        assert!((p[0] as f64 - rho * 0.5 * 0.5).abs() < 1e-6, "{}", p[0]);
    }
    // κρΔs = 1e4: the first step is opaque; alpha exactly 1 and the colour is the ambient
    // light over κ: (1 − ΔT)/κ with ΔT = 0.
    let kappa = 1e4 / (rho * 0.5);
    let settings = RenderSettings {
        kappa: DVec3::splat(kappa),
        step: Some(0.5),
        ambient: DVec3::splat(2.0),
        ..small(4, 4)
    };
    let image = render(&scene(&density, vec![light]), &settings).unwrap();
    for p in &image.rgba {
        assert_eq!(p[3], 1.0);
        assert!((p[0] as f64 - 2.0 / kappa).abs() < 1e-9, "{}", p[0]);
        assert!(p.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn constant_half_holdout_halves_colour_and_alpha() {
    let density = slab(1, DVec3::splat(1.0), -0.4, 0.4);
    let emission = slab(3, DVec3::new(1.0, 0.5, 0.25), -0.4, 0.4);
    let holdout = FnField::new(1, |_p: DVec3, out: &mut [f64]| out[0] = 0.5);
    let light = Light::distant(DVec3::new(0.3, -1.0, -0.2), DVec3::ONE).unwrap();
    let mut plain = scene(&density, vec![light]);
    plain.emission = Some(&emission);
    let settings = RenderSettings {
        kappa: DVec3::new(2.0, 1.0, 0.5),
        step: Some(0.02),
        ..small(6, 6)
    };
    let without = render(&plain, &settings).unwrap();
    plain.holdout = Some(&holdout);
    let with = render(&plain, &settings).unwrap();
    for (a, b) in without.rgba.iter().zip(&with.rgba) {
        for c in 0..4 {
            assert!(a[c] > 0.01);
            assert!(
                (b[c] - 0.5 * a[c]).abs() < 1e-6 * a[c].max(1.0),
                "{} vs {}",
                b[c],
                a[c]
            );
        }
    }
}

#[test]
fn point_light_falls_off_with_distance_squared_on_a_thin_slab() {
    // κ = 0 isolates the light: a slab of thickness δ scatters ρ·δ·I/r² towards the camera,
    // r the distance from the light at (0, 0, 1) to the pixel's point of the slab.
    let (rho, delta, strength) = (2.0, 0.01, 1.5);
    let density = slab(1, DVec3::splat(rho), -0.5 * delta, 0.5 * delta);
    let light = Light::point(DVec3::new(0.0, 0.0, 1.0), DVec3::splat(strength)).unwrap();
    let settings = RenderSettings {
        kappa: DVec3::ZERO,
        step: Some(0.001),
        ..small(4, 4)
    };
    let image = render(&scene(&density, vec![light]), &settings).unwrap();
    for (i, p) in image.rgba.iter().enumerate() {
        let x = -0.5 + ((i % 4) as f64 + 0.5) / 4.0;
        let y = 0.5 - ((i / 4) as f64 + 0.5) / 4.0;
        let expected = rho * delta * strength / (x * x + y * y + 1.0);
        assert!(
            (p[1] as f64 - expected).abs() < 1e-4 * expected,
            "{} vs {expected}",
            p[1]
        );
    }
}

#[test]
fn aovs_add_up_to_the_beauty() {
    let density = slab(1, DVec3::splat(1.0), -0.3, 0.3);
    let emission = slab(3, DVec3::new(0.2, 0.1, 0.0), -0.3, 0.3);
    let lights = vec![
        Light::distant(DVec3::new(0.2, -1.0, -0.1), DVec3::new(1.0, 0.8, 0.6)).unwrap(),
        Light::point(DVec3::new(0.0, 2.0, 1.0), DVec3::splat(3.0)).unwrap(),
    ];
    let mut sc = scene(&density, lights);
    sc.emission = Some(&emission);
    let settings = RenderSettings {
        step: Some(0.02),
        aovs: Aovs {
            depth: true,
            transmittance: true,
            emission: true,
            lights: true,
            ..Aovs::default()
        },
        ..small(5, 5)
    };
    let image = render(&sc, &settings).unwrap();
    let names: Vec<&str> = image.aovs.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(
        names,
        [
            "depth.Z",
            "transmittance.Y",
            "emission.R",
            "emission.G",
            "emission.B",
            "light0.R",
            "light0.G",
            "light0.B",
            "light1.R",
            "light1.G",
            "light1.B"
        ]
    );
    let aov = |name: &str| image.aov(name).unwrap();
    for (i, p) in image.rgba.iter().enumerate() {
        for (c, channel) in ["R", "G", "B"].iter().enumerate() {
            let parts = aov(&format!("emission.{channel}"))[i]
                + aov(&format!("light0.{channel}"))[i]
                + aov(&format!("light1.{channel}"))[i];
            assert!(
                (parts - p[c]).abs() < 1e-5 * p[c].max(1.0),
                "{parts} vs {}",
                p[c]
            );
        }
        assert!((aov("transmittance.Y")[i] - (1.0 - p[3])).abs() < 1e-6);
        // A symmetric slab from z = 0.3 to -0.3 seen from z = 5: the opacity-weighted depth
        // lies in front of its middle, 4.7 + (1/κρ − L/(e^{κρL} − 1)) = 4.7 + 0.2702.
        let depth = aov("depth.Z")[i] as f64;
        assert!(
            (depth - (4.7 + 1.0 - 0.6 / (0.6f64.exp() - 1.0))).abs() < 1e-3,
            "{depth}"
        );
    }
}

#[test]
fn albedo_slab_lit_from_behind_the_camera_matches_single_scattering() {
    // A homogeneous slab of density ρ and thickness L with extinction σt = κρ and scattering
    // σs = albedo·tint·κρ, lit by a distant light of irradiance E travelling along the view
    // direction. The point at depth s is reached by the light through depth s and seen through
    // depth s, and scatters at θ = π, so
    //   C = ∫₀ᴸ σs·p(π)·E·e^{−2κρs} ds = albedo·tint·p(π)·E·(1 − e^{−2κρL})/2,
    // with p per steradian: 1/4π isotropic; Henyey–Greenstein (1 − g²)/(4π(1 + 2g + g²)^{3/2})
    // = (1 − g)/(4π(1 + g)²) at cosθ = −1.
    //
    // The march's error: a step of optical thickness x starting at depth τ₀ adds
    // e^{−τ₀}(1 − e^{−x})·e^{−(τ₀ + x/2)} (camera transmittance, exact step opacity, light
    // column at the midpoint, exact with marched shadows) where the integral gives
    // e^{−2τ₀}(1 − e^{−2x})/2. Their ratio is 1/cosh(x/2), in [1 − x²/8, 1], so the pixel lies
    // in [C·(1 − (κρΔs)²/8), C] up to the f32 image's rounding.
    let (rho, kappa, thickness, irradiance, albedo) = (1.5, 1.25, 0.8, 3.0, 0.8);
    let density = slab(1, DVec3::splat(rho), -0.4, 0.4);
    let tint = DVec3::new(1.0, 0.5, 0.25);
    let color = slab(3, tint, -0.4, 0.4);
    let light = Light::distant(-DVec3::Z, DVec3::splat(irradiance)).unwrap();
    let mut lit = scene(&density, vec![light]);
    lit.color = Some(&color);
    let four_pi = 4.0 * std::f64::consts::PI;
    let beer = 1.0 - (-2.0 * kappa * rho * thickness).exp();
    for (phase, p) in [
        (Phase::Isotropic, 1.0 / four_pi),
        (
            Phase::HenyeyGreenstein { g: 0.3 },
            0.7 / (four_pi * 1.3 * 1.3),
        ),
    ] {
        let expected = tint * (albedo * p * irradiance * beer / 2.0);
        let mut errors = Vec::new();
        for step in [0.1, 0.05] {
            let settings = RenderSettings {
                kappa: DVec3::splat(kappa),
                step: Some(step),
                shadows: Shadows::March,
                phase,
                albedo: Some(albedo),
                indirect: None,
                ..small(4, 4)
            };
            let image = render(&lit, &settings).unwrap();
            let x = kappa * rho * step;
            for pixel in &image.rgba {
                for c in 0..3 {
                    let (got, exact) = (pixel[c] as f64, expected[c]);
                    let rounding = 1e-6 * exact;
                    assert!(
                        got <= exact + rounding && got >= exact * (1.0 - x * x / 8.0) - rounding,
                        "{phase:?}, step {step}, channel {c}: {got} vs {exact}"
                    );
                }
            }
            errors.push(expected.x - image.rgba[5][0] as f64);
        }
        // Second order: halving the step quarters the error.
        assert!(
            errors[0] > 0.0 && errors[1] < 0.35 * errors[0],
            "{errors:?}"
        );
    }
    // Whatever κ, an opaque slab shows albedo·p·E/2: the extinction sets how deep the light
    // goes, not how bright the medium is (the colour model's C_d·E/2κ dims as κ grows).
    // The ray stops at transmittance 1e-3, leaving out e^{−2τ} < 1e-6 of the light.
    let (kappa, step) = (400.0, 1e-4);
    let thick = RenderSettings {
        kappa: DVec3::splat(kappa),
        step: Some(step),
        shadows: Shadows::March,
        albedo: Some(albedo),
        ..small(2, 2)
    };
    let image = render(&lit, &thick).unwrap();
    let opaque = albedo * irradiance / (2.0 * four_pi);
    let x = kappa * rho * step;
    let got = image.rgba[0][0] as f64;
    assert!(
        got <= opaque * (1.0 + 1e-6) && got >= opaque * (1.0 - x * x / 8.0 - 2e-6),
        "{got} vs {opaque}"
    );
}
