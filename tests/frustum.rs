//! Frustum caches as a script author meets them: a splatted particle lands in the cell of the
//! pixel and depth slice the camera sees it in, an orthographic frustum (a box) reproduces a
//! linear field, a frustum cache comes back from a VDB file as the same field, and mistakes are
//! errors at the call.

mod common;

use common::{lines_of, numbers, run_source};

const CAMERA: &str = "camera cam = camera((0, 0, 5), (0, 0, 0), (0, 1, 0), 60);\n";

/// The pinhole projection worked by hand for that camera (eye at z = 5 looking down -z, 60°
/// across): the pixel and depth slice of a point, for an image of `width × height` pixels and
/// `depth` slices from `near` to `far`.
fn projected(p: [f64; 3], width: f64, height: f64, depth: f64, near: f64, far: f64) -> [usize; 3] {
    let distance = 5.0 - p[2];
    let tan_across = 30f64.to_radians().tan();
    let tan_up = tan_across * height / width;
    let i = (0.5 * width * (1.0 + p[0] / distance / tan_across)).floor();
    let j = (0.5 * height * (1.0 - p[1] / distance / tan_up)).floor();
    let k = ((distance - near) / (far - near) * depth).floor();
    [i as usize, j as usize, k as usize]
}

/// The world centre of cell `(i, j, k)` of that frustum.
fn centre(cell: [usize; 3], width: f64, height: f64, depth: f64, near: f64, far: f64) -> [f64; 3] {
    let distance = near + (far - near) * (cell[2] as f64 + 0.5) / depth;
    let tan_across = 30f64.to_radians().tan();
    let tan_up = tan_across * height / width;
    let x = (2.0 * (cell[0] as f64 + 0.5) / width - 1.0) * tan_across * distance;
    let y = (1.0 - 2.0 * (cell[1] as f64 + 0.5) / height) * tan_up * distance;
    [x, y, 5.0 - distance]
}

#[test]
fn a_splatted_particle_lands_in_the_cell_the_camera_projects_it_to() {
    let (width, height, depth, near, far) = (40.0, 30.0, 20.0, 1.0, 9.0);
    let points = [[0.7, -0.4, 1.3], [-1.1, 0.9, -2.0], [0.05, 0.02, 3.2]];
    for p in points {
        let cell = projected(p, width, height, depth, near, far);
        let neighbours = [
            [cell[0] + 1, cell[1], cell[2]],
            [cell[0], cell[1] + 1, cell[2]],
            [cell[0], cell[1], cell[2] + 1],
            [cell[0] - 1, cell[1], cell[2]],
        ];
        let probes: String = std::iter::once(cell)
            .chain(neighbours)
            .map(|c| {
                let [x, y, z] = centre(c, width, height, depth, near, far);
                format!("print(probe(cacheread(c), ({x:e}, {y:e}, {z:e})));\n")
            })
            .collect();
        let script = format!(
            "{CAMERA}scalarcache c = frustumcache(cam, {near}, {far}, {width}, {height}, {depth});\n\
             splat(c, particles({{({}, {}, {})}}), kernel = \"nearest\");\n{probes}",
            p[0], p[1], p[2]
        );
        let lines = lines_of(run_source("splat.felt", &script));
        // Read at the cells' centres, up to the rounding of locating a centre.
        let values: Vec<f64> = lines
            .iter()
            .map(|l| (numbers(l)[0] * 1e9).round() / 1e9)
            .collect();
        assert_eq!(
            values,
            vec![1.0, 0.0, 0.0, 0.0, 0.0],
            "{p:?} in cell {cell:?}"
        );
    }
}

#[test]
fn a_trilinear_splat_keeps_its_total_and_reads_back_at_the_particle() {
    // One particle at a cell centre: all of it in that cell, read back whole there.
    let (width, height, depth, near, far) = (16.0, 12.0, 10.0, 2.0, 8.0);
    let [x, y, z] = centre([5, 7, 3], width, height, depth, near, far);
    let script = format!(
        "{CAMERA}scalarcache c = frustumcache(cam, {near}, {far}, {width}, {height}, {depth}, padding = 2);\n\
         particles p = addattr(particles({{({x:e}, {y:e}, {z:e})}}), \"mass\", {{2.5}});\n\
         splat(c, p, \"mass\");\n\
         print(probe(cacheread(c), ({x:e}, {y:e}, {z:e})));\n"
    );
    let lines = lines_of(run_source("trilinear.felt", &script));
    let value = numbers(&lines[0])[0];
    assert!((value - 2.5).abs() < 1e-5, "{value}");
}

#[test]
fn an_orthographic_frustum_is_a_box_that_reproduces_a_linear_field() {
    let script = "camera cam = camera((0, 0, 5), (0, 0, 0), (0, 1, 0), 60, ortho = 4);\n\
         scalarcache c = frustumcache(cam, 1, 9, 20, 10, 8);\n\
         cachewrite(c, scalarfield(1) + 2 * dot(identity(), (1, 0.5, -0.25)));\n\
         print(probe(cacheread(c), (0.3, -0.2, 1.1)));\n\
         print(probe(cacheread(c), (-1.7, 0.9, -3.2)));\n\
         print(probe(cacheread(c), (1.9, 0, 0)));\n";
    let lines = lines_of(run_source("ortho.felt", script));
    let expected = [
        1.0 + 2.0 * (0.3 - 0.1 - 0.275),
        1.0 + 2.0 * (-1.7 + 0.45 + 0.8),
        1.0 + 2.0 * 1.9,
    ];
    for (line, want) in lines.iter().zip(expected) {
        let got = numbers(line)[0];
        assert!((got - want).abs() < 1e-5, "{got} against {want}");
    }
}

#[test]
fn a_frustum_vector_cache_holds_colours_splatted_and_written() {
    // A colour splatted at a cell centre reads back there; a written vectorfield is read back
    // at its cells' centres through an orthographic frustum, where the map is affine.
    let (width, height, depth, near, far) = (16.0, 12.0, 10.0, 2.0, 8.0);
    let [x, y, z] = centre([3, 9, 6], width, height, depth, near, far);
    let script = format!(
        "{CAMERA}vectorcache c = frustumvectorcache(cam, {near}, {far}, {width}, {height}, {depth});\n\
         particles p = addattr(particles({{({x:e}, {y:e}, {z:e})}}), \"Cd\", (0.25, 0.5, 1));\n\
         splat(c, p, \"Cd\");\n\
         print(probe(cacheread(c), ({x:e}, {y:e}, {z:e})));\n\
         camera flat = camera((0, 0, 5), (0, 0, 0), (0, 1, 0), 60, ortho = 4);\n\
         vectorcache v = frustumvectorcache(flat, 1, 9, 20, 10, 8, background = (0, 0, 7));\n\
         cachewrite(v, identity() * 2);\n\
         print(probe(cacheread(v), (0.3, -0.2, 1.1)));\n\
         print(probe(cacheread(v), (0, 0, 20)));\n"
    );
    let lines = lines_of(run_source("colour.felt", &script));
    let expected = [[0.25, 0.5, 1.0], [0.6, -0.4, 2.2], [0.0, 0.0, 7.0]];
    for (line, want) in lines.iter().zip(expected) {
        let got = numbers(line);
        for c in 0..3 {
            assert!((got[c] - want[c]).abs() < 1e-5, "{line} against {want:?}");
        }
    }
}

#[test]
fn a_frustum_cache_saved_to_a_vdb_file_loads_back_as_the_same_field() {
    // Read at world points inside, near the padded edges and outside the frustum, through the
    // cache in memory and through the file: the same cells and the same world-to-cell map.
    let points = [
        "(0.3, -0.2, 1.1)",
        "(-2.2, 1.1, -2.9)",
        "(1.7, 0.4, 0.0)",
        "(0.01, 0.02, 3.95)",
        "(0, 0, 20)",
        "(9, 0, 0)",
    ];
    let probes: String = points
        .iter()
        .map(|p| format!("print(probe(cacheread(c), {p}));\nprint(probe(back, {p}));\nprint(probe(cacheread(v), {p}));\nprint(probe(vback, {p}));\n"))
        .collect();
    let script = format!(
        "{CAMERA}scalarcache c = frustumcache(cam, 1, 9, 24, 16, 12, background = 0.5, padding = 2);\n\
         cachewrite(c, scalarfield(1) + dot(identity(), (0.3, 0.2, -0.1)) + perlin(3));\n\
         cachesave(c, \"fog.vdb\");\n\
         scalarfield back = cacheload(\"fog.vdb\", \"density\");\n\
         vectorcache v = frustumvectorcache(cam, 2, 6, 10, 7, 5);\n\
         cachewrite(v, identity() * 2);\n\
         cachesave(v, \"fog.vdb#vel\");\n\
         vectorfield vback = cacheloadvector(\"fog.vdb\", \"vel\");\n{probes}"
    );
    let lines = lines_of(run_source("saved.felt", &script));
    assert_eq!(lines.len(), 4 * points.len());
    for pair in lines.chunks(2) {
        let (memory, file) = (numbers(&pair[0]), numbers(&pair[1]));
        for (a, b) in memory.iter().zip(&file) {
            assert!((a - b).abs() <= 1e-9 * a.abs().max(1.0), "{pair:?}");
        }
    }
    // Outside the frustum both read the background.
    assert_eq!(numbers(&lines[17])[0], 0.5);
}

#[test]
fn frustum_mistakes_are_errors_at_the_call() {
    let cases = [
        (
            "scalarcache c = frustumcache(cam, 0, 9, 8, 8, 8);",
            "near distance must be positive, got 0",
        ),
        (
            "scalarcache c = frustumcache(cam, 2, 1, 8, 8, 8);",
            "far distance must be beyond its near distance 2, got 1",
        ),
        (
            "scalarcache c = frustumcache(cam, 1, 9, 0, 8, 8);",
            "width must be a positive whole number",
        ),
        (
            "scalarcache c = frustumcache(cam, 1, 9, 8, 8, 8, padding = -1);",
            "padding must be zero or more",
        ),
        (
            "scalarcache c = frustumcache(cam, 1, 9, 100000, 100000, 100000);",
            "over the memory budget",
        ),
        (
            "scalarcache c = frustumcache(cam, 1, 9, 9223372036854775807, 1, 1, padding = 9223372036854775807);",
            "over the memory budget",
        ),
        (
            "scalarcache c = frustumcache(cam, 1, 9, 8, 8, 8);\ncachewrite(c, scalarfield(1));\ncachesave(c, \"out.vdb\");\nscalarfield f = cacheload(\"out.vdb\", \"density\", outside = \"extrapolate\");",
            "cacheload with outside = \"extrapolate\" cannot take a frustum cache",
        ),
        (
            "scalarcache c = frustumcache(cam, 1, 9, 8, 8, 8);\ncachewrite(c, scalarfield(1));\nscalarfield f = cacheread(c, outside = \"extrapolate\");",
            "cannot take a frustum cache",
        ),
        (
            "scalarcache c = frustumcache(cam, 1, 9, 8, 8, 8);\nflamesplat(c, particles({(0, 0, 0)}), {flame(\"linear\")}, {1}, {(1, 1, 1)}, 10, 1);",
            "flamesplat cannot take a frustum cache",
        ),
    ];
    for (call, phrase) in cases {
        let outcome = run_source("broken.felt", &format!("{CAMERA}{call}\n"));
        assert!(!outcome.ok, "{call}");
        assert!(
            outcome
                .diagnostics
                .iter()
                .any(|d| d.message.contains(phrase)),
            "{call}: {}",
            outcome.rendered
        );
        // The diagnostic points at the last line, the call that was wrong.
        let line = 1 + call.lines().count();
        assert!(
            outcome.rendered.contains(&format!("broken.felt:{line}:")),
            "{call}: {}",
            outcome.rendered
        );
    }
}
