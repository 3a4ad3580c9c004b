//! Attributes in files and on generated shapes: OBJ seams split into vertices, PLY properties
//! of any name, exact round trips, the uv sphere's measures, barycentric weights.

use super::*;
use crate::geometry::attributes::{NORMAL, TEXTURE};
use crate::geometry::transfer::barycentric;

fn vectors<'a>(mesh: &'a Mesh, name: &str) -> &'a [DVec3] {
    match mesh.attribute(name).unwrap() {
        Attribute::Vector(v) => v,
        other => panic!("{name} is {other:?}"),
    }
}

#[test]
fn an_obj_seam_becomes_two_vertices() {
    // Two triangles sharing the edge 1–2; vertex 2 has texture coordinate 1 in the first
    // triangle and 3 in the second (a seam), vertex 1 the same one in both.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
                vt 0 0\nvt 0.5 0\nvt 0 0.5\nvt 1 1\nvt 0.25 0.75\n\
                vn 0 0 1\n\
                f 1/1/1 2/2/1 3/3/1\nf 2/2/1 4/4/1 -2/-1/-1\n";
    let mesh = parse_obj(text.as_bytes()).unwrap();
    assert_eq!(mesh.positions.len(), 5);
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [1, 3, 4]]);
    assert_eq!(mesh.positions[4], mesh.positions[2]);
    let uv = vectors(&mesh, TEXTURE);
    assert_eq!(uv[2], DVec3::new(0.0, 0.5, 0.0));
    assert_eq!(uv[4], DVec3::new(0.25, 0.75, 0.0));
    assert!(vectors(&mesh, NORMAL).iter().all(|n| *n == DVec3::Z));
    // Written and read again: the same mesh, attributes and all.
    let again = parse_obj(&write_obj(&mesh).unwrap()).unwrap();
    assert_eq!(again, mesh);
}

#[test]
fn obj_attribute_indices_are_checked() {
    for (text, message) in [
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/2 2/1 3/1\n",
            "texture coordinate 2",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\n", "normal 1"),
        ("v 0 0 0\nvt\n", "texture coordinate needs one coordinate"),
    ] {
        let error = parse_obj(text.as_bytes()).unwrap_err();
        assert!(error.message.contains(message), "{}", error.message);
    }
}

#[test]
fn ply_properties_become_attributes_and_round_trip() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\n\
                property float x\nproperty float y\nproperty float z\n\
                property float nx\nproperty float ny\nproperty float nz\n\
                property float s\nproperty float t\n\
                property double temperature\nproperty uchar red\n\
                property float vel_x\nproperty float vel_y\nproperty float vel_z\n\
                element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                0 0 0 0 0 1 0 0 300 255 1 2 3\n\
                1 0 0 0 0 1 1 0 310 128 4 5 6\n\
                0 1 0 0 0 1 0 1 320 0 7 8 9\n\
                3 0 1 2\n";
    let mesh = parse_ply(text.as_bytes()).unwrap();
    let names: Vec<&str> = mesh.attributes.keys().map(|k| k.as_str()).collect();
    assert_eq!(names, ["N", "red", "temperature", "uv", "vel"]);
    assert_eq!(vectors(&mesh, TEXTURE)[2], DVec3::new(0.0, 1.0, 0.0));
    assert_eq!(vectors(&mesh, "vel")[1], DVec3::new(4.0, 5.0, 6.0));
    assert_eq!(
        mesh.attribute("temperature").unwrap(),
        &Attribute::Float(vec![300.0, 310.0, 320.0])
    );
    let again = parse_ply(&write_ply(&mesh).unwrap()).unwrap();
    assert_eq!(again, mesh);
}

#[test]
fn the_uv_sphere_is_closed_once_welded_and_outward() {
    let sphere = uv_sphere(DVec3::new(0.5, 0.0, 0.0), 2.0, 24, 48).unwrap();
    // Inscribed polyhedron: a little under the sphere's volume, converging as O(h²).
    let exact = 4.0 / 3.0 * std::f64::consts::PI * 8.0;
    let volume = sphere.volume();
    assert!(volume < exact && volume > 0.98 * exact, "{volume}");
    let first = crate::geometry::components::welded(&sphere.positions);
    let welded = Mesh::new(
        sphere.positions.clone(),
        sphere
            .triangles
            .iter()
            .map(|t| t.map(|v| first[v as usize]))
            .collect(),
    );
    assert!(welded.is_closed());
    assert_eq!(welded.euler_characteristic(), 2);
    // Every vertex is used, normals are unit and radial, u and v stay in [0, 1].
    let mut used = vec![false; sphere.positions.len()];
    for t in &sphere.triangles {
        for &v in t {
            used[v as usize] = true;
        }
    }
    assert!(used.iter().all(|&u| u));
    for (p, n) in sphere.positions.iter().zip(vectors(&sphere, NORMAL)) {
        assert!((*p - DVec3::new(0.5, 0.0, 0.0) - 2.0 * *n).length() < 1e-12);
    }
    assert!(
        vectors(&sphere, TEXTURE)
            .iter()
            .all(|t| (0.0..=1.0).contains(&t.x) && (0.0..=1.0).contains(&t.y))
    );
}

#[test]
fn barycentric_weights_reproduce_the_closest_point() {
    let t = [
        DVec3::ZERO,
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
    ];
    let at = |w: [f64; 3]| t[0] * w[0] + t[1] * w[1] + t[2] * w[2];
    // Above the face: the weights of the foot of the perpendicular.
    let w = barycentric(DVec3::new(0.5, 0.25, 3.0), &t);
    assert!(
        (at(w) - DVec3::new(0.5, 0.25, 0.0)).length() < 1e-15,
        "{w:?}"
    );
    assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    // Beyond an edge and beyond a corner.
    assert_eq!(barycentric(DVec3::new(1.0, -1.0, 0.0), &t), [0.5, 0.5, 0.0]);
    assert_eq!(
        barycentric(DVec3::new(-1.0, -1.0, 0.0), &t),
        [1.0, 0.0, 0.0]
    );
    // At each corner exactly that corner.
    for (k, corner) in t.iter().enumerate() {
        let mut expected = [0.0; 3];
        expected[k] = 1.0;
        assert_eq!(barycentric(*corner, &t), expected);
    }
}
