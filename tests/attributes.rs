//! Shape attributes and attribute transfer (FELT chapter 4.3): attributes read, set, warped,
//! saved and loaded; transfer through a warp reproduces what it should; bad inputs are
//! diagnostics.

mod common;

use common::{lines_of, numbers};

#[test]
fn a_linear_attribute_transfers_through_an_exact_warp() {
    // The warp from a sphere of radius 0.6 onto the unit sphere is radial, X(x) = x/|x|, and
    // one nacelle step with exact distances finds it. The reference carries u = x, so each
    // object vertex should read X(v).x = v.x/|v|, up to the chordal error of the reference's
    // flat triangles: (π/48)²/8 ≈ 5e-4 of the radius for 48 rings and 96 segments.
    let out = lines_of(common::run_source(
        "transfer.felt",
        r#"
        shape reference = setpointattr(uvsphere((0, 0, 0), 1.0, 48, 96), "u", identity().x);
        scalarfield Lo = sphere((0, 0, 0), 0.6);
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.08);
        shape obj = ls2shape(Lo, d);
        vectorfield X = nacelle(Lo, sphere((0, 0, 0), 1.0), 1);
        shape moved = transferattr(obj, reference, X, "u");
        float[] u = pointattrfloat(moved, "u");
        vector[] p = pointattr(moved, "P");
        float worst = 0;
        float spread = 0;
        for (int i = 0; i < size(u); i++) {
            worst = max(worst, abs(u[i] - p[i].x / length(p[i])));
            spread = max(spread, abs(u[i]));
        }
        print(size(u), worst, spread);
        // Texture coordinates transfer too, and the positions are the object's.
        shape textured = transferattr(obj, reference, X, "uv");
        print(pointattrs(textured), vertices(textured) == vertices(obj));
        "#,
    ));
    let v = numbers(&out[0]);
    assert!(v[0] > 300.0, "{}", out[0]);
    assert!(v[1] < 1e-3, "{}", out[0]);
    assert!(v[2] > 0.99, "the attribute spans the sphere: {}", out[0]);
    assert_eq!(out[1], r#"{"uv"} true"#);
}

#[test]
fn a_shape_transferred_onto_itself_is_unchanged() {
    let out = lines_of(common::run_source(
        "self.felt",
        r#"
        domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.1);
        shape s = ls2shape(torus((0, 0, 0), 0.6, 0.25), d);
        s = setpointattr(s, "heat", sin(7.0 * identity().x) + identity().y * identity().z);
        s = setpointattr(s, "wind", curlnoise(2.0, 5));
        shape t = transferattr(s, s, identity(), "heat");
        t = transferattr(t, s, identity(), "wind");
        float[] a = pointattrfloat(s, "heat");
        float[] b = pointattrfloat(t, "heat");
        vector[] va = pointattr(s, "wind");
        vector[] vb = pointattr(t, "wind");
        int different = 0;
        for (int i = 0; i < size(a); i++) {
            if (a[i] != b[i] || va[i] != vb[i]) { different++; }
        }
        print(size(a), different);
        "#,
    ));
    let v = numbers(&out[0]);
    assert!(v[0] > 100.0, "{}", out[0]);
    assert_eq!(v[1], 0.0, "{}", out[0]);
}

#[test]
fn warping_moves_vertices_and_turns_normals() {
    // x → (2x, y, z) turns the unit sphere's normal n into S⁻¹n / |S⁻¹n|, S = diag(2, 1, 1).
    let out = lines_of(common::run_source(
        "warp.felt",
        r#"
        shape s = uvsphere((0, 0, 0), 1.0, 8, 16);
        shape w = warpshape(s, (2.0 * identity().x, identity().y, identity().z));
        vector[] p = pointattr(w, "P");
        vector[] n = pointattr(w, "N");
        float worst = 0;
        for (int i = 0; i < size(n); i++) {
            vector q = (p[i].x / 2.0, p[i].y, p[i].z);
            vector m = normalize((q.x / 2.0, q.y, q.z));
            worst = max(worst, length(n[i] - m));
        }
        print(worst, volume(w) / volume(s));
        "#,
    ));
    let v = numbers(&out[0]);
    assert!(v[0] < 1e-12, "{}", out[0]);
    assert!((v[1] - 2.0).abs() < 1e-12, "{}", out[0]);
}

#[test]
fn attributes_survive_saving_and_loading() {
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("s.obj");
    let ply = dir.path().join("s.ply");
    let out = lines_of(common::run_source(
        "files.felt",
        &format!(
            r#"
            func bool same(vector[] a, vector[] b) {{
                if (size(a) != size(b)) {{ return false; }}
                for (int i = 0; i < size(a); i++) {{ if (a[i] != b[i]) {{ return false; }} }}
                return true;
            }}
            func bool samefloat(float[] a, float[] b) {{
                if (size(a) != size(b)) {{ return false; }}
                for (int i = 0; i < size(a); i++) {{ if (a[i] != b[i]) {{ return false; }} }}
                return true;
            }}
            shape s = setpointattr(uvsphere((0.5, 0, 0), 0.7, 6, 12), "heat", identity().y);
            s = setpointattr(s, "wind", (identity().z, 1.0, -identity().x));
            saveshape(s, "{obj}");
            saveshape(s, "{ply}");
            shape a = loadshape("{obj}");
            shape b = loadshape("{ply}");
            print(pointattrs(a), pointattrs(b));
            print(same(pointattr(a, "uv"), pointattr(s, "uv")), same(pointattr(a, "N"), pointattr(s, "N")),
                  same(pointattr(a, "P"), pointattr(s, "P")), vertices(a) == vertices(s));
            print(same(pointattr(b, "uv"), pointattr(s, "uv")), same(pointattr(b, "wind"), pointattr(s, "wind")),
                  samefloat(pointattrfloat(b, "heat"), pointattrfloat(s, "heat")));
            "#,
            obj = obj.display(),
            ply = ply.display()
        ),
    ));
    assert_eq!(out[0], r#"{"N", "uv"} {"N", "heat", "uv", "wind"}"#);
    assert_eq!(out[1], "true true true true");
    assert_eq!(out[2], "true true true");
}

#[test]
fn bad_attribute_inputs_are_diagnostics() {
    let dir = tempfile::tempdir().unwrap();
    // Three triangles on one edge: not a manifold.
    let fin = dir.path().join("fin.obj");
    std::fs::write(
        &fin,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
    )
    .unwrap();
    let setup = format!(
        r#"domain d((-1, -1, -1), (2, 2, 2), (0, 0, 0), 0.25);
        shape s = ls2shape(sphere((0, 0, 0), 0.6), d);
        shape fin = setpointattr(loadshape("{}"), "u", identity().x);
        shape empty;
        "#,
        fin.display()
    );
    for (body, message) in [
        ("print(pointattr(s, \"uv\"));", "no vertex attribute 'uv'"),
        (
            "print(pointattrfloat(uvsphere((0, 0, 0), 1.0, 4, 8), \"uv\"));",
            "is a vector attribute",
        ),
        (
            "shape t = setpointattr(s, \"u\", {1.0, 2.0});",
            "one value per vertex",
        ),
        (
            "shape t = transferattr(s, empty, identity(), \"u\");",
            "no vertex attribute 'u'",
        ),
        (
            "shape t = transferattr(s, setpointattr(empty, \"u\", 1.0), identity(), \"u\");",
            "no triangles",
        ),
        (
            "shape t = transferattr(s, fin, identity(), \"u\");",
            "not a manifold",
        ),
        ("shape t = uvsphere((0, 0, 0), 1.0, 1, 8);", "rings"),
        (
            "shape t = warpshape(s, identity() / (identity().x - identity().x));",
            "not finite",
        ),
    ] {
        let outcome = common::run_source("bad.felt", &format!("{setup}\n{body}"));
        assert!(!outcome.ok, "{body}");
        assert!(
            outcome.rendered.contains(message),
            "{body}: {}",
            outcome.rendered
        );
        assert!(
            outcome.rendered.contains("bad.felt:"),
            "{}",
            outcome.rendered
        );
    }
}
