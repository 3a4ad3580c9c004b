//! The surface AOVs against closed forms: the opacity-weighted depth of a homogeneous slab, the
//! normal of a density that grows along x, and the screen motion of a medium moving at a
//! constant velocity under an orthographic camera.

use super::*;
use crate::render::settings::Aovs;

fn with_aovs(aovs: Aovs) -> RenderSettings {
    RenderSettings {
        aovs,
        step: Some(0.002),
        ..small(8, 8)
    }
}

#[test]
fn position_is_the_opacity_weighted_mean_point_of_a_slab() {
    let (rho, kappa, thickness) = (1.5, 1.25, 0.8);
    let density = slab(1, DVec3::splat(rho), -0.4, 0.4);
    let settings = RenderSettings {
        kappa: DVec3::splat(kappa),
        ..with_aovs(Aovs {
            position: true,
            ..Aovs::default()
        })
    };
    let image = render(&scene(&density, vec![]), &settings).unwrap();
    // ∫ z dα over the slab, entered at z = 0.4: the mean distance in is
    // 1/σ − L·e^{−σL}/(1 − e^{−σL}) with σ = κρ.
    let sigma = kappa * rho;
    let absorbed = 1.0 - (-sigma * thickness).exp();
    let mean_in = 1.0 / sigma - thickness * (-sigma * thickness).exp() / absorbed;
    let (xs, ys, zs) = (
        image.aov("position.X").unwrap(),
        image.aov("position.Y").unwrap(),
        image.aov("position.Z").unwrap(),
    );
    for (i, &z) in zs.iter().enumerate() {
        assert!(
            (z as f64 - (0.4 - mean_in)).abs() < 1e-4,
            "{z} vs {}",
            0.4 - mean_in
        );
        // The orthographic window is one unit wide: the point lies in its pixel's column/row.
        let (px, py) = ((i % 8) as f32, (i / 8) as f32);
        assert!(xs[i] >= -0.5 + px / 8.0 && xs[i] <= -0.5 + (px + 1.0) / 8.0);
        assert!(ys[i] <= 0.5 - py / 8.0 && ys[i] >= 0.5 - (py + 1.0) / 8.0);
    }
}

#[test]
fn the_normal_points_where_the_density_falls() {
    // ρ = 1 + x everywhere, marched only inside the box: ∇ρ = (1, 0, 0), so every normal is
    // (−1, 0, 0), exactly under central differences.
    let density = FnField::new(1, |p: DVec3, out: &mut [f64]| out[0] = 1.0 + p.x).with_bounds(
        Aabb::new(DVec3::new(-1.0, -1.0, -0.4), DVec3::new(1.0, 1.0, 0.4)),
    );
    let settings = with_aovs(Aovs {
        normal: true,
        ..Aovs::default()
    });
    let image = render(&scene(&density, vec![]), &settings).unwrap();
    for (c, expected) in [("X", -1.0), ("Y", 0.0), ("Z", 0.0)] {
        for v in image.aov(&format!("normal.{c}")).unwrap() {
            assert!((*v - expected).abs() < 1e-6, "normal.{c}: {v}");
        }
    }
}

#[test]
fn motion_is_the_velocity_on_screen_in_pixels_with_v_up() {
    let density = slab(1, DVec3::ONE, -0.4, 0.4);
    let drift = DVec3::new(0.1, 0.05, 0.0);
    let velocity = FnField::new(3, move |_: DVec3, out: &mut [f64]| {
        out.copy_from_slice(&drift.to_array());
    })
    .with_bounds(Aabb::new(DVec3::splat(-2.0), DVec3::splat(2.0)))
    .with_range(0.0, 0.1);
    let mut moving = scene(&density, vec![]);
    moving.velocity = Some(&velocity);
    let settings = with_aovs(Aovs {
        motion: true,
        ..Aovs::default()
    });
    let image = render(&moving, &settings).unwrap();
    // One world unit is 8 pixels across the 1-unit orthographic window; +y is up on screen.
    let (u, v) = (
        image.aov("forward.u").unwrap(),
        image.aov("forward.v").unwrap(),
    );
    for i in 0..64 {
        assert!((u[i] - 0.8).abs() < 1e-5, "u {}", u[i]);
        assert!((v[i] - 0.4).abs() < 1e-5, "v {}", v[i]);
    }
}

#[test]
fn where_nothing_shows_the_surface_aovs_are_zero() {
    let density = slab(1, DVec3::ZERO, -0.4, 0.4);
    let settings = with_aovs(Aovs {
        position: true,
        normal: true,
        ..Aovs::default()
    });
    let image = render(&scene(&density, vec![]), &settings).unwrap();
    for name in ["position.X", "position.Z", "normal.X", "normal.Y"] {
        assert!(image.aov(name).unwrap().iter().all(|v| *v == 0.0), "{name}");
    }
}

#[test]
fn the_path_tracer_refuses_the_surface_aovs() {
    let settings = RenderSettings {
        integrator: crate::render::settings::Integrator::Path,
        ..with_aovs(Aovs {
            normal: true,
            ..Aovs::default()
        })
    };
    let message = settings.validate().unwrap_err().to_string();
    assert!(message.contains("belongs to the march"), "{message}");
}
