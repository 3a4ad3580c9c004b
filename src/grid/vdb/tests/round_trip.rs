//! Writing and reading back, and building grids from values.

use super::super::half::round_to_half;
use super::super::*;
use super::fixture;
use glam::{DMat4, DQuat, DVec3};

const REWRITTEN: [&str; 9] = [
    "fog.vdb",
    "sphere.vdb",
    "vec3.vdb",
    "masks.vdb",
    "masks_raw.vdb",
    "half.vdb",
    "transforms.vdb",
    "translation_map.vdb",
    "instance.vdb",
];

/// Metadata the writer regenerates (statistics) and so may differ after a rewrite.
fn lasting_metadata(grid: &VdbGrid) -> Vec<(String, VdbMeta)> {
    grid.metadata
        .iter()
        .filter(|(k, _)| !k.starts_with("file_"))
        .cloned()
        .collect()
}

fn assert_same_grid(a: &VdbGrid, b: &VdbGrid, context: &str) {
    assert_eq!(a.name, b.name, "{context}");
    assert_eq!(a.class, b.class, "{context}");
    assert_eq!(a.value_type, b.value_type, "{context}");
    assert_eq!(a.background, b.background, "{context}");
    assert_eq!(a.index_to_world, b.index_to_world, "{context}");
    assert_eq!(a.saved_as_half, b.saved_as_half, "{context}");
    assert_eq!(a.tiles, b.tiles, "{context}");
    assert!(a.leaves == b.leaves, "{context}: leaves differ");
    assert_eq!(lasting_metadata(a), lasting_metadata(b), "{context}");
}

#[test]
fn fixtures_survive_a_rewrite() {
    for name in REWRITTEN {
        let grids = read_file(&fixture(name)).unwrap();
        for compression in [Compression::Zip, Compression::None] {
            let bytes = write_bytes(&grids, compression).unwrap();
            let again = read_bytes(&bytes).unwrap_or_else(|e| panic!("{name}: {}", e.message));
            assert_eq!(again.len(), grids.len());
            for (a, b) in grids.iter().zip(&again) {
                assert_same_grid(a, b, &format!("{name} {compression:?}"));
            }
            assert_eq!(
                write_bytes(&again, compression).unwrap(),
                bytes,
                "{name}: not deterministic"
            );
        }
    }
}

#[test]
fn zip_makes_smaller_files() {
    let size = |grids: &[VdbGrid], compression| write_bytes(grids, compression).unwrap().len();
    let sphere = read_file(&fixture("sphere.vdb")).unwrap();
    assert!(size(&sphere, Compression::Zip) < size(&sphere, Compression::None));
    // A leaf of one repeated value packs far better.
    let leaf = VdbLeaf {
        origin: [0, 0, 0],
        values: vec![0.5; LEAF_VOXELS],
        active: [0x5555_5555_5555_5555; 8],
    };
    let grid = VdbGrid {
        leaves: vec![leaf],
        ..VdbGrid::new("g", FOG_VOLUME, VdbValues::Float, [0.0; 3], DMat4::IDENTITY)
    };
    let grids = [grid];
    assert!(size(&grids, Compression::Zip) + 900 < size(&grids, Compression::None));
}

fn sphere_distance(ijk: [i32; 3], centre: DVec3, radius: f64, voxel: f64) -> f32 {
    let p = DVec3::new(ijk[0] as f64, ijk[1] as f64, ijk[2] as f64) * voxel;
    ((p - centre).length() - radius) as f32
}

fn sphere_grid() -> VdbGrid {
    let (voxel, radius, centre) = (0.1, 2.0, DVec3::new(0.3, -0.2, 0.1));
    let half_width = 3.0 * voxel as f32;
    VdbGrid::new(
        "surface",
        LEVEL_SET,
        VdbValues::Float,
        [half_width, 0.0, 0.0],
        DMat4::from_scale(DVec3::splat(voxel)),
    )
    .with_values_from(
        [-30, -30, -30],
        [30, 30, 30],
        Activity::NarrowBand,
        |ijk, out| out[0] = sphere_distance(ijk, centre, radius, voxel),
    )
    .unwrap()
}

#[test]
fn a_built_level_set_holds_the_distance_in_its_band_and_signs_elsewhere() {
    let grid = sphere_grid();
    let (voxel, radius, centre) = (0.1, 2.0, DVec3::new(0.3, -0.2, 0.1));
    let half_width = grid.background[0];
    let mut active = 0u64;
    for x in -35..=35 {
        for y in (-35..=35).step_by(3) {
            for z in -35..=35 {
                let d = sphere_distance([x, y, z], centre, radius, voxel);
                let inside_box = [x, y, z].iter().all(|c| c.abs() <= 30);
                let (value, is_active) = grid.probe([x, y, z]);
                if inside_box && d.abs() < half_width {
                    assert_eq!((value[0], is_active), (d, true), "{x} {y} {z}");
                    active += 1;
                } else if inside_box {
                    assert_eq!(
                        (value[0], is_active),
                        (half_width.copysign(d), false),
                        "{x} {y} {z}"
                    );
                } else {
                    assert_eq!((value[0], is_active), (half_width, false), "{x} {y} {z}");
                }
            }
        }
    }
    assert!(active > 1000);
    // Whole 8³ blocks of the interior became inactive −background tiles; blocks wholly
    // outside the band hold only the background and are not stored at all.
    assert!(
        grid.tiles
            .iter()
            .all(|t| t.size == 8 && !t.active && t.value[0] == -half_width)
    );
    assert!(!grid.tiles.is_empty());
    let back =
        read_bytes(&write_bytes(std::slice::from_ref(&grid), Compression::Zip).unwrap()).unwrap();
    assert_same_grid(&grid, &back[0], "built sphere");
}

#[test]
fn uniform_regions_merge_into_larger_tiles() {
    // A fog box covering two whole 128³ regions and a partial third.
    let grid = VdbGrid::new(
        "box",
        FOG_VOLUME,
        VdbValues::Float,
        [0.0; 3],
        DMat4::IDENTITY,
    )
    .with_values_from(
        [0, 0, 0],
        [255, 127, 135],
        Activity::AwayFromBackground(0.0),
        |_, out| out[0] = 0.5,
    )
    .unwrap();
    let big: Vec<_> = grid.tiles.iter().filter(|t| t.size == 128).collect();
    assert_eq!(big.len(), 2);
    assert!(grid.leaves.is_empty());
    assert_eq!(grid.active_voxel_count(), 256 * 128 * 136);
    assert_eq!(grid.active_bounds(), Some(([0, 0, 0], [255, 127, 135])));
    assert_eq!(grid.probe([200, 100, 135]), ([0.5, 0.0, 0.0], true));
    assert_eq!(grid.probe([200, 100, 136]), ([0.0; 3], false));
}

#[test]
fn dense_arrays_and_functions_build_the_same_grid() {
    let dims = [11usize, 9, 20];
    let origin = [-5, 3, -12];
    let value = |ijk: [i32; 3], out: &mut [f32]| {
        let s = (ijk[0] * 3 + ijk[1] * 5 - ijk[2]) as f32;
        out.copy_from_slice(&[s.sin().max(0.0), 0.25 * s, 1.0]);
    };
    let mut dense = Vec::new();
    for x in 0..dims[0] as i32 {
        for y in 0..dims[1] as i32 {
            for z in 0..dims[2] as i32 {
                let mut v = [0.0; 3];
                value([origin[0] + x, origin[1] + y, origin[2] + z], &mut v);
                dense.extend_from_slice(&v);
            }
        }
    }
    let header = VdbGrid::new(
        "v",
        UNKNOWN_CLASS,
        VdbValues::Vec3,
        [0.0, 0.0, 1.0],
        DMat4::IDENTITY,
    );
    let from_dense = header
        .clone()
        .with_dense_values(origin, dims, &dense, Activity::AwayFromBackground(1e-6))
        .unwrap();
    let max = [0, 1, 2].map(|a| origin[a] + dims[a] as i32 - 1);
    let from_fn = header
        .with_values_from(origin, max, Activity::AwayFromBackground(1e-6), value)
        .unwrap();
    assert_eq!(from_dense, from_fn);
    let mut v = [0.0; 3];
    value([0, 5, 0], &mut v);
    assert_eq!(from_dense.value_at([0, 5, 0]), v);
    let wrong = VdbGrid::new(
        "v",
        UNKNOWN_CLASS,
        VdbValues::Vec3,
        [0.0; 3],
        DMat4::IDENTITY,
    )
    .with_dense_values(origin, dims, &dense[1..], Activity::NarrowBand);
    assert!(wrong.is_err());
}

#[test]
fn half_grids_round_trip_through_half_rounding() {
    let mut grid = VdbGrid::new(
        "h",
        FOG_VOLUME,
        VdbValues::Float,
        [0.1, 0.0, 0.0],
        DMat4::IDENTITY,
    )
    .with_values_from(
        [0, 0, 0],
        [20, 3, 9],
        Activity::AwayFromBackground(0.0),
        |ijk, out| {
            out[0] = if ijk[0] % 4 == 0 {
                0.1
            } else {
                0.123_456_7 * ijk[0] as f32 - 0.3 * ijk[2] as f32
            }
        },
    )
    .unwrap();
    grid.saved_as_half = true;
    let back = &read_bytes(&write_bytes(std::slice::from_ref(&grid), Compression::Zip).unwrap())
        .unwrap()[0];
    assert!(back.saved_as_half);
    assert_eq!(back.background[0], round_to_half(0.1));
    for x in -1..22 {
        for z in -1..11 {
            let (value, active) = grid.probe([x, 2, z]);
            let (read, read_active) = back.probe([x, 2, z]);
            assert_eq!(read[0], round_to_half(value[0]), "{x} {z}");
            assert_eq!(read_active, active);
        }
    }
}

#[test]
fn names_are_made_unique_and_read_back_plain() {
    let grid = |name: &str| {
        VdbGrid::new(
            name,
            UNKNOWN_CLASS,
            VdbValues::Float,
            [1.0, 0.0, 0.0],
            DMat4::IDENTITY,
        )
    };
    let grids = [grid("a"), grid(""), grid("a"), grid("b")];
    let back = read_bytes(&write_bytes(&grids, Compression::None).unwrap()).unwrap();
    let names: Vec<&str> = back.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["a", "", "a", "b"]);
    assert_eq!(
        read_grid_bytes(&write_bytes(&grids, Compression::None).unwrap(), "b")
            .unwrap()
            .name,
        "b"
    );
}

#[test]
fn transforms_choose_the_simplest_map_and_read_back_exactly() {
    let rotation = DMat4::from_quat(DQuat::from_rotation_z(0.3) * DQuat::from_rotation_x(-1.1));
    let matrices = [
        DMat4::from_scale(DVec3::splat(0.25)),
        DMat4::from_translation(DVec3::new(1.0, -2.0, 0.5)) * DMat4::from_scale(DVec3::splat(0.5)),
        DMat4::from_scale(DVec3::new(0.5, -0.25, 2.0)),
        DMat4::from_translation(DVec3::new(3.0, 0.0, -1.0))
            * DMat4::from_scale(DVec3::new(1.0, 2.0, 3.0)),
        DMat4::from_translation(DVec3::new(-7.0, 0.1, 2.0))
            * rotation
            * DMat4::from_scale(DVec3::new(0.1, 0.2, 0.3)),
    ];
    let maps = [
        "UniformScaleMap",
        "UniformScaleTranslateMap",
        "ScaleMap",
        "ScaleTranslateMap",
        "AffineMap",
    ];
    for (matrix, map) in matrices.into_iter().zip(maps) {
        let grid = VdbGrid::new("t", UNKNOWN_CLASS, VdbValues::Float, [0.0; 3], matrix);
        let bytes = write_bytes(&[grid], Compression::None).unwrap();
        let found = bytes
            .windows(map.len() + 4)
            .any(|w| w[4..] == *map.as_bytes() && w[..4] == (map.len() as u32).to_le_bytes());
        assert!(found, "{map}");
        assert_eq!(
            read_bytes(&bytes).unwrap()[0].index_to_world,
            matrix,
            "{map}"
        );
    }
    let flat = VdbGrid::new(
        "t",
        UNKNOWN_CLASS,
        VdbValues::Float,
        [0.0; 3],
        DMat4::from_scale(DVec3::new(1.0, 0.0, 1.0)),
    );
    assert!(
        write_bytes(&[flat], Compression::Zip)
            .unwrap_err()
            .message
            .contains("degenerate")
    );
}

#[test]
fn inconsistent_grids_are_refused() {
    let base = VdbGrid::new("g", FOG_VOLUME, VdbValues::Float, [0.0; 3], DMat4::IDENTITY);
    let leaf = VdbLeaf {
        origin: [8, 0, 0],
        values: vec![0.5; LEAF_VOXELS],
        active: [u64::MAX; 8],
    };
    let tile = |origin, size| VdbTile {
        origin,
        size,
        value: [1.0, 0.0, 0.0],
        active: true,
    };
    let cases: Vec<(Vec<VdbLeaf>, Vec<VdbTile>, &str)> = vec![
        (vec![leaf.clone()], vec![tile([8, 0, 0], 8)], "overlapping"),
        (
            vec![leaf.clone()],
            vec![tile([0, 0, 0], 128)],
            "overlapping",
        ),
        (
            vec![leaf.clone()],
            vec![tile([0, 0, 0], 4096)],
            "overlapping",
        ),
        (vec![leaf.clone(), leaf.clone()], vec![], "overlapping"),
        (
            vec![VdbLeaf {
                origin: [4, 0, 0],
                ..leaf.clone()
            }],
            vec![],
            "aligned",
        ),
        (
            vec![VdbLeaf {
                values: vec![0.0; 10],
                ..leaf.clone()
            }],
            vec![],
            "values",
        ),
        (vec![], vec![tile([0, 0, 0], 16)], "size"),
        (vec![], vec![tile([8, 0, 0], 128)], "aligned"),
    ];
    for (leaves, tiles, words) in cases {
        let grid = VdbGrid {
            leaves,
            tiles,
            ..base.clone()
        };
        let failure = write_bytes(&[grid], Compression::Zip).unwrap_err();
        assert!(failure.message.contains(words), "{}", failure.message);
    }
}

#[test]
fn files_are_replaced_whole() {
    let directory = tempfile::tempdir().unwrap();
    let path = directory.path().join("out.vdb");
    let grid = sphere_grid();
    write_file(&path, std::slice::from_ref(&grid), Compression::Zip).unwrap();
    write_file(&path, std::slice::from_ref(&grid), Compression::None).unwrap();
    assert_same_grid(&read_file(&path).unwrap()[0], &grid, "file");
    assert_eq!(
        std::fs::read_dir(directory.path()).unwrap().count(),
        1,
        "no temporary left behind"
    );
    // Missing folders are made; a file where a folder should be is an error.
    let missing = directory.path().join("no/such/dir/out.vdb");
    write_file(&missing, std::slice::from_ref(&grid), Compression::Zip).unwrap();
    assert!(missing.exists());
    let blocked = directory.path().join("out.vdb/inside.vdb");
    assert!(
        write_file(&blocked, &[grid], Compression::Zip)
            .unwrap_err()
            .message
            .contains("is not a folder")
    );
}
