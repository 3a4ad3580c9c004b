//! OBJ and PLY: exact round trips, and files written by hand whose meshes are known.

use super::*;

fn sample_mesh() -> Mesh {
    // Coordinates with full f64 mantissas, tiny and huge exponents, and a negative zero.
    let mut mesh = marching_cubes(
        &ball(DVec3::new(0.1, 0.2, -0.3), 0.55),
        &cube_domain(DVec3::ZERO, 1.0, 12),
    )
    .unwrap();
    mesh.positions.push(DVec3::new(1e-300, -2.5e300, -0.0));
    mesh.positions
        .push(DVec3::new(std::f64::consts::PI, 1.0 / 3.0, 7e-8));
    let n = mesh.positions.len() as u32;
    mesh.triangles.push([n - 2, n - 1, 0]);
    mesh
}

#[test]
fn obj_and_ply_round_trips_are_exact() {
    let mesh = sample_mesh();
    let directory = tempfile::tempdir().unwrap();
    for name in ["shape.obj", "shape.ply", "SHAPE.PLY"] {
        let path = directory.path().join(name);
        save_mesh(&mesh, &path).unwrap();
        let back = load_mesh(&path).unwrap();
        assert_eq!(back.triangles, mesh.triangles, "{name}");
        for (a, b) in back.positions.iter().zip(&mesh.positions) {
            assert_eq!(
                a.to_array().map(f64::to_bits),
                b.to_array().map(f64::to_bits),
                "{name}"
            );
        }
        assert_eq!(back.positions.len(), mesh.positions.len());
    }
    // Saving again over an existing file replaces it whole.
    let path = directory.path().join("shape.obj");
    let small = box_mesh(DVec3::ZERO, DVec3::ONE);
    save_mesh(&small, &path).unwrap();
    assert_eq!(load_mesh(&path).unwrap(), small);
}

#[test]
fn obj_reads_polygons_negative_indices_and_corner_forms() {
    let text = b"# a unit square pyramid\r\n\
        mtllib pyramid.mtl\n\
        o pyramid\n\
        v 0 0 0\nv 1 0 0\nv 1 1 0 1.0\nv 0 1 0 0.5 0.5 0.5\n\
        vt 0 0\nvn 0 0 1\n\
        g base\n\
        usemtl stone\n\
        f 1/1/1 4/1/1 3/1/1 2/1/1\n\
        v 0.5 0.5 1e0\n\
        s off\n\
        f -5 -4 -1\n\
        f 2//1 3//1 5//1\n\
        f 3/1 4/1 5/1\n\
        f -2 -5 -1\n\
        l 1 2\n";
    let mesh = parse_obj(text).unwrap();
    assert_eq!(mesh.positions.len(), 5);
    assert_eq!(mesh.positions[4], DVec3::new(0.5, 0.5, 1.0));
    assert_eq!(
        mesh.triangles,
        vec![
            [0, 3, 2],
            [0, 2, 1],
            [0, 1, 4],
            [1, 2, 4],
            [2, 3, 4],
            [3, 0, 4]
        ]
    );
    assert!(mesh.is_closed());
    assert!((mesh.volume() - 1.0 / 3.0).abs() < 1e-15);
}

/// The same tetrahedron as ASCII PLY, with extra properties and elements to step over.
const TETRA_ASCII: &str = "ply\r\nformat ascii 1.0\ncomment made by hand\n\
    element vertex 4\nproperty float x\nproperty uchar red\nproperty double y\nproperty int z\n\
    property list uchar float weights\n\
    element face 2\nproperty list uchar int vertex_indices\nproperty ushort material\n\
    element edge 1\nproperty int vertex1\nproperty int vertex2\n\
    end_header\n\
    0 255 0 0 0\n1 0 0 0 2 0.5 0.25\n0 7 1 0 1 1.5\n0 9 0 1 0\n\
    3 0 2 1 4\n4 0 1 3 2 5\n\
    0 1\n";

fn tetra_expected() -> Mesh {
    Mesh {
        positions: vec![
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, 0.0),
            DVec3::new(0.0, 1.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
        ],
        triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2]],
        attributes: Default::default(),
    }
}

#[test]
fn ply_ascii_reads_what_it_needs_and_steps_over_the_rest() {
    let mut mesh = parse_ply(TETRA_ASCII.as_bytes()).unwrap();
    // Scalar vertex properties other than x, y, z are kept as attributes.
    assert_eq!(
        mesh.attributes.remove("red"),
        Some(Attribute::Float(vec![255.0, 0.0, 7.0, 9.0]))
    );
    assert_eq!(mesh, tetra_expected());
}

/// Big-endian binary PLY with float coordinates, an int list count and short indices.
fn tetra_big_endian() -> Vec<u8> {
    let mut bytes = b"ply\nformat binary_big_endian 1.0\n\
        element vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar flag\n\
        element face 2\nproperty list int short vertex_indices\n\
        end_header\n"
        .to_vec();
    for p in tetra_expected().positions {
        for c in [p.x, p.y, p.z] {
            bytes.extend_from_slice(&(c as f32).to_be_bytes());
        }
        bytes.push(1);
    }
    for face in [&[0i16, 2, 1][..], &[0, 1, 3, 2]] {
        bytes.extend_from_slice(&(face.len() as i32).to_be_bytes());
        for v in face {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
    }
    bytes
}

#[test]
fn ply_binary_big_endian_reads_any_integer_types() {
    let mut mesh = parse_ply(&tetra_big_endian()).unwrap();
    assert_eq!(
        mesh.attributes.remove("flag"),
        Some(Attribute::Float(vec![1.0; 4]))
    );
    assert_eq!(mesh, tetra_expected());
}

#[test]
fn written_ply_is_binary_little_endian_with_doubles() {
    let bytes = write_ply(&tetra_expected()).unwrap();
    let text = String::from_utf8_lossy(&bytes);
    assert!(text.starts_with("ply\nformat binary_little_endian 1.0\n"));
    assert!(text.contains("property double x\n"));
    let header = text.find("end_header\n").unwrap() + "end_header\n".len();
    // 4 vertices of 24 bytes, 3 faces of 1 + 12 bytes.
    assert_eq!(bytes.len() - header, 4 * 24 + 3 * 13);
    assert_eq!(
        f64::from_le_bytes(bytes[header + 24..header + 32].try_into().unwrap()),
        1.0
    );
}

#[test]
fn unknown_extensions_and_missing_files_are_failures() {
    let mesh = tetra_expected();
    let directory = tempfile::tempdir().unwrap();
    let stl = directory.path().join("shape.stl");
    let failure = save_mesh(&mesh, &stl).unwrap_err();
    assert!(failure.help.unwrap().contains(".obj or .ply"));
    assert!(!stl.exists());
    let missing = load_mesh(&directory.path().join("missing.obj")).unwrap_err();
    assert!(missing.message.contains("cannot read"));
    let mut bad = mesh;
    bad.positions[0].x = f64::INFINITY;
    assert!(save_mesh(&bad, &directory.path().join("bad.obj")).is_err());
}

#[test]
fn files_whose_content_is_not_their_extension_are_refused() {
    let directory = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let path = directory.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let message = |path: &std::path::Path| load_mesh(path).unwrap_err();
    // A VDB file renamed .obj used to load as an empty shape.
    let vdb = crate::grid::vdb::write_bytes(
        &[crate::grid::vdb::VdbGrid::new(
            "density",
            crate::grid::vdb::FOG_VOLUME,
            crate::grid::vdb::VdbValues::Float,
            [0.0; 3],
            glam::DMat4::IDENTITY,
        )],
        crate::grid::vdb::Compression::Zip,
    )
    .unwrap();
    for name in ["h1.obj", "h1.ply"] {
        let path = write(name, &vdb);
        let failure = message(&path);
        let kind = if name.ends_with("obj") {
            "an OBJ"
        } else {
            "a PLY"
        };
        assert_eq!(
            failure.message,
            format!("{}: this is a VDB file, not {kind} mesh", path.display())
        );
        assert!(failure.help.unwrap().contains("cacheload"));
    }
    let ply = write_ply(&tetra_expected()).unwrap();
    let failure = message(&write("tetra.obj", &ply));
    assert!(
        failure
            .message
            .ends_with("this is a PLY mesh, not an OBJ mesh"),
        "{}",
        failure.message
    );
    assert!(failure.help.unwrap().contains(".ply"));
    let obj = write_obj(&tetra_expected()).unwrap();
    let failure = message(&write("tetra.ply", &obj));
    assert!(
        failure
            .message
            .ends_with("this is not a PLY file: it does not start with 'ply' (it is a text file)"),
        "{}",
        failure.message
    );
    // Binary bytes with no vertices or faces are not an OBJ mesh; an empty text file still is
    // an empty one.
    let failure = message(&write(
        "noise.obj",
        &[0x00, 0x9f, 0x92, 0x96, b'\n', 0x01, 0x02],
    ));
    assert!(
        failure
            .message
            .ends_with("this is not an OBJ mesh: it holds binary data and no vertices or faces"),
        "{}",
        failure.message
    );
    let empty = load_mesh(&write("empty.obj", b"# nothing yet\n")).unwrap();
    assert!(empty.positions.is_empty() && empty.triangles.is_empty());
    // A text OBJ with a stray Latin-1 comment still reads.
    let mut latin = b"# caf\xe9\n".to_vec();
    latin.extend_from_slice(&obj);
    assert_eq!(
        load_mesh(&write("latin.obj", &latin)).unwrap(),
        tetra_expected()
    );
}

#[test]
fn every_encoding_of_one_mesh_reads_the_same() {
    let files = super::files_for_mutation();
    let meshes: Vec<Mesh> = files
        .iter()
        .map(|(name, bytes)| {
            if name.ends_with("obj") {
                parse_obj(bytes)
            } else {
                parse_ply(bytes)
            }
            .unwrap()
        })
        .collect();
    assert!(meshes[0].is_closed() && !meshes[0].triangles.is_empty());
    for (mesh, (name, _)) in meshes.iter().zip(&files) {
        assert_eq!(mesh, &meshes[0], "{name}");
    }
}
