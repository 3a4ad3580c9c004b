//! Modeling: the chapter's scripts run as printed, level-set projection lands on the zero set,
//! noise keeps its statistics far from the origin, cumulo stays finite for any billow, curl
//! noise is divergence-free.

mod common;

use std::path::Path;

use common::{lines_of, numbers};

#[test]
fn chapter_scripts_run_as_printed() {
    let run = |name: &str| {
        lines_of(common::run_script(
            Path::new(&format!("tests/scripts/chapter/{name}")),
            &[],
        ))
    };
    assert_eq!(run("cumulo_procedural.felt"), ["true true true"]);
    assert_eq!(run("cumulo_cached.felt"), ["true 0.0"]);
    assert_eq!(run("noise_layers.felt"), ["3", "true"]);
    assert_eq!(run("knife.felt"), ["1 1", "true true true", "true"]);
}

#[test]
fn levelset_surface_lands_on_the_zero_set() {
    let out = lines_of(common::run_source(
        "surface.felt",
        r#"
        scalarfield sph = sphere((0.1, 0, 0), 0.5);
        scalarfield tor = torus((0, 0, 0), 0.6, 0.2);
        scalarfield bumpy = sphere((0, 0, 0), 0.6) + 0.08 * perlin(3.0);
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.1);
        print(stats(abs(compose(sph, levelsetsurface(sph, 1))), d));
        print(stats(abs(compose(tor, levelsetsurface(tor, 1))), d));
        // Within 0.15 of the surface (where displacement shaders read the projection).
        scalarfield band = mask(0.15 - abs(bumpy));
        print(stats(band * abs(compose(bumpy, levelsetsurface(bumpy, 4))), d));
        print(probe(levelsetsurface(sph, 3), (0.1, 0, 0)));
        print(probe(levelsetsurface(tor, 3), (0, 0, 0)));
        "#,
    ));
    // Exact signed distances: one Newton step lands on the surface to rounding.
    assert!(numbers(&out[0])[1] < 1e-12, "{}", out[0]);
    assert!(numbers(&out[1])[1] < 1e-12, "{}", out[1]);
    // A noise-displaced sphere: four steps bring every point within 0.15 of the surface to
    // within 1e-6 of the zero set (the documented tolerance).
    let bumpy = numbers(&out[2]);
    assert!(bumpy[1] < 1e-6, "{}", out[2]);
    // Where the gradient vanishes (the sphere's centre, the torus's axis) points stay put.
    assert_eq!(numbers(&out[3]), [0.1, 0.0, 0.0]);
    assert_eq!(numbers(&out[4]), [0.0, 0.0, 0.0]);
}

#[test]
fn noise_statistics_do_not_change_far_from_the_origin() {
    let out = lines_of(common::run_source(
        "far.felt",
        r#"
        scalarfield n = perlin(1.0, 7);
        domain near((0, 0, 0), (6, 6, 6), (0, 0, 0), 0.1);
        domain far((1e5, -1e5, 1e5), (6, 6, 6), (0, 0, 0), 0.1);
        print(stats(n, near), stats(n * n, near), stats(length(grad(n)), near));
        print(stats(n, far), stats(n * n, far), stats(length(grad(n)), far));
        "#,
    ));
    let (near, far) = (numbers(&out[0]), numbers(&out[1]));
    // (min, max, mean) of n, of n², of |∇n|.
    assert!(
        (near[2] - far[2]).abs() < 0.02,
        "mean {} vs {}",
        near[2],
        far[2]
    );
    assert!(
        (near[5] / far[5] - 1.0).abs() < 0.1,
        "variance {} vs {}",
        near[5],
        far[5]
    );
    assert!(
        (near[7] / far[7] - 1.0).abs() < 0.1,
        "max slope {} vs {}",
        near[7],
        far[7]
    );
    assert!(far[1] > 0.5 && far[0] < -0.5, "range {far:?}");
}

#[test]
fn cumulo_is_finite_for_any_billow_and_billow_zero_clears_nothing() {
    let out = lines_of(common::run_source(
        "billow.felt",
        r#"
        scalarfield base = sphere((0, 0, 0), 0.5);
        scalarfield[] layers = noiselayers(perlin(), 6, scalarfield(2.0), scalarfield(2.0), scalarfield(0.5));
        for (int i = 0; i < 6; i++) { layers[i] = layers[i] * 0.1; }
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.125);
        float[] billows = {0.0, 0.33, 1.0, 2.0, 4.0};
        for (int b = 0; b < size(billows); b++) {
            scalarfield cloud = cumulo(base, billowlayers(layers, scalarfield(billows[b]), scalarfield(1.0)), 1);
            print(stats(cloud, d));
        }
        scalarfield plain = cumulo(base, layers, 1);
        scalarfield unbillowed = cumulo(base, billowlayers(layers, scalarfield(0.0), scalarfield(1.0)), 1);
        vector p = (0.3, 0.4, -0.2);
        print(probe(plain, p) == probe(unbillowed, p), stats(plain - unbillowed, d));
        "#,
    ));
    for line in &out[..5] {
        assert!(numbers(line).iter().all(|v| v.is_finite()), "{line}");
    }
    assert_eq!(out[5], "true (0.0, 0.0, 0.0)");
}

#[test]
fn curl_noise_is_divergence_free() {
    let out = lines_of(common::run_source(
        "curl.felt",
        r#"
        vectorfield u = curlnoise(2.5, 3);
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.1);
        print(stats(div(u), d), stats(length(u), d));
        "#,
    ));
    let v = numbers(&out[0]);
    // Exact derivatives: the divergence is rounding error against speeds of order one.
    assert!(v[0].abs() < 1e-12 && v[1].abs() < 1e-12, "{}", out[0]);
    assert!(v[4] > 0.5, "{}", out[0]);
}

#[test]
fn knives_cut_a_sphere_into_pieces_that_add_up() {
    let run = |res: usize, reversed: bool| {
        let order = if reversed {
            "{k[2], k[1], k[0]}"
        } else {
            "{k[0], k[1], k[2]}"
        };
        let out = lines_of(common::run_source(
            "knives.felt",
            &format!(
                r#"
                scalarfield ball = sphere((0, 0, 0), 1.0);
                scalarfield[] k = {{flatknife((0.1, 0, 0), (1, 0.3, 0)), flatknife((0, 0.2, 0), (0.2, 1, 0.1)),
                                   flatknife((0, 0, -0.3), (0.3, -0.2, 1))}};
                scalarfield[] cuts = cutall(ball, {order});
                domain d((-1.1, -1.1, -1.1), (2.2, 2.2, 2.2), (0, 0, 0), 2.2 / {res});
                float total = 0;
                int nonempty = 0;
                for (int i = 0; i < size(cuts); i++) {{
                    shape s = ls2shape(cuts[i], d);
                    if (triangles(s) > 0) {{ nonempty++; }}
                    print(volume(s));
                    total += volume(s);
                }}
                print(size(cuts), nonempty, total, volume(ls2shape(ball, d)));
                "#
            ),
        ));
        let last = numbers(out.last().unwrap());
        let mut volumes: Vec<f64> = out[..out.len() - 1].iter().map(|l| numbers(l)[0]).collect();
        volumes.sort_by(f64::total_cmp);
        (last, volumes)
    };
    let (coarse, volumes) = run(24, false);
    let (fine, _) = run(48, false);
    // 2^3 level sets, all non-empty for these three planes through the ball.
    assert_eq!((coarse[0], coarse[1]), (8.0, 8.0));
    // The pieces add up to the ball up to a first-order error at the cut edges: halving the
    // cell halves the shortfall.
    let (short_coarse, short_fine) = (coarse[3] - coarse[2], fine[3] - fine[2]);
    assert!(
        short_coarse > 0.0 && short_fine < 0.65 * short_coarse,
        "{coarse:?} {fine:?}"
    );
    assert!(short_fine < 0.1 * fine[3], "{fine:?}");
    // The order of the knives does not change the pieces: the zero sets are the same, and
    // only the level sets' values away from them differ, which moves the meshed surfaces by
    // a fraction of a cell (volumes agree to well under the cut-edge error above).
    let (_, reversed) = run(24, true);
    for (a, b) in volumes.iter().zip(&reversed) {
        assert!(
            (a - b).abs() < 0.03 * short_coarse.max(0.1) + 0.01,
            "{volumes:?} vs {reversed:?}"
        );
    }
}

#[test]
fn meshing_and_distance_round_trip_within_a_cell() {
    let out = lines_of(common::run_source(
        "roundtrip.felt",
        r#"
        scalarfield ls = softunion(sphere((-0.3, 0, 0), 0.5), torus((0.3, 0, 0), 0.4, 0.15), 0.1);
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.05);
        shape s = ls2shape(ls, d);
        scalarfield back = shape2ls(s, d);
        // Within a band of two cells around the surface.
        scalarfield band = mask(0.1 - abs(ls));
        print(stats(band * abs(back - ls), d));
        print(vertices(s) > 1000, triangles(s) > 2000, size(pieces(s)));
        "#,
    ));
    assert!(numbers(&out[0])[1] < 0.05, "{}", out[0]);
    assert_eq!(out[1], "true true 1");
}

#[test]
fn knife_order_does_not_change_which_side_a_point_is_on() {
    let out = lines_of(common::run_source(
        "order.felt",
        r#"
        scalarfield ball = sphere((0, 0, 0), 1.0);
        scalarfield a = flatknife((0.1, 0, 0), (1, 0.3, 0));
        scalarfield b = flatknife((0, 0.2, 0), (0.2, 1, 0.1));
        scalarfield[] ab = cutall(ball, {a, b});
        scalarfield[] ba = cutall(ball, {b, a});
        domain d((-1.2, -1.2, -1.2), (2.4, 2.4, 2.4), (0, 0, 0), 0.05);
        // Piece (a+, b-) is index 1 one way and index 2 the other.
        print(stats(abs(mask(ab[0]) - mask(ba[0])), d), stats(abs(mask(ab[1]) - mask(ba[2])), d),
              stats(abs(mask(ab[2]) - mask(ba[1])), d), stats(abs(mask(ab[3]) - mask(ba[3])), d));
        "#,
    ));
    let v = numbers(&out[0]);
    assert!(v.iter().all(|x| *x == 0.0), "{}", out[0]);
}

#[test]
fn a_noise_solid_cut_through_its_zeros_gives_pieces_that_add_up() {
    // Simplex noise is exactly zero at many points of a regular lattice, some of them sample
    // points here; a sample evaluated twice in different blocks rounded to either side of
    // zero, and the mesher lost a crossing between two slabs. The pieces on either side of
    // the plane x = 0, kept whatever their size, must enclose the uncut solid's volume up
    // to the cut's first-order error at the crease, which halves with the cell.
    let shortfall = |cell: f64| {
        let out = lines_of(common::run_source(
            "cut.felt",
            &format!(
                r#"
                domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), {cell});
                shape[] p = cutpieces(simplex(), {{identity().x}}, d, 0.0);
                float total = 0;
                for (int i = 0; i < size(p); i++) {{ total += volume(p[i]); }}
                print(size(p), total, volume(ls2shape(simplex(), d)));
                "#
            ),
        ));
        let [count, total, whole] = numbers(&out[0])[..] else {
            panic!("{out:?}");
        };
        assert!(count >= 2.0, "{cell}: {out:?}");
        assert!(whole > 0.5, "{cell}: {out:?}");
        (whole - total) / whole
    };
    let errors: Vec<f64> = [0.25, 0.1, 0.05].map(shortfall).to_vec();
    assert!(errors.iter().all(|e| e.abs() < 0.1), "{errors:?}");
    assert!(errors[2].abs() < errors[0].abs(), "{errors:?}");
}
