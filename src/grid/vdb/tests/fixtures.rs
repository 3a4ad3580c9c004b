//! felt's reader against files written by OpenVDB, checked against what pyopenvdb and
//! vdb_print read from the same files (`expected.txt`, made by `make_fixtures.py`).

use super::super::*;
use super::fixture;
use glam::DVec3;
use std::collections::HashMap;

#[derive(Default, Debug)]
struct ExpectedGrid {
    name: String,
    class: String,
    value_type: String,
    half: bool,
    background: Vec<f32>,
    active_voxels: u64,
    leaves: usize,
    bounds: Option<([i32; 3], [i32; 3])>,
    world: Vec<([i32; 3], DVec3)>,
    probes: Vec<([i32; 3], bool, Vec<f32>)>,
}

#[derive(Default, Debug)]
struct ExpectedFile {
    grids: Vec<ExpectedGrid>,
    error: Option<String>,
    /// (name, value type, active voxels) as vdb_print listed them.
    printed: Vec<(String, String, u64)>,
}

fn numbers<T: std::str::FromStr>(field: &str) -> Vec<T>
where
    T::Err: std::fmt::Debug,
{
    field
        .split(' ')
        .map(|n| n.parse().expect("number in expected.txt"))
        .collect()
}

fn coord(field: &str) -> [i32; 3] {
    let n: Vec<i32> = numbers(field);
    [n[0], n[1], n[2]]
}

/// Values in expected.txt are `f32`s printed as the shortest decimal of their `f64` widening,
/// so parsing to `f64` and narrowing recovers them exactly.
fn values(field: &str) -> Vec<f32> {
    numbers::<f64>(field)
        .into_iter()
        .map(|v| v as f32)
        .collect()
}

fn expected() -> Vec<(String, ExpectedFile)> {
    let text = std::fs::read_to_string(fixture("expected.txt")).expect("expected.txt");
    let mut files: Vec<(String, ExpectedFile)> = Vec::new();
    for line in text
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
    {
        let fields: Vec<&str> = line.split('\t').collect();
        if fields[0] == "file" {
            files.push((fields[1].to_string(), ExpectedFile::default()));
            continue;
        }
        let file = &mut files.last_mut().expect("a file line first").1;
        match fields[0] {
            "grid" => file.grids.push(ExpectedGrid {
                name: fields[1].into(),
                class: fields[2].into(),
                value_type: fields[3].into(),
                half: fields[4] == "1",
                background: values(fields[5]),
                ..Default::default()
            }),
            "error" => file.error = Some(fields[1].into()),
            "printed" => file.printed.push((
                fields[1].into(),
                fields[2].into(),
                fields[3].parse().unwrap(),
            )),
            kind => {
                let grid = file.grids.last_mut().expect("a grid line first");
                match kind {
                    "count" => {
                        grid.active_voxels = fields[1].parse().unwrap();
                        grid.leaves = fields[2].parse().unwrap();
                    }
                    "bbox" if fields[1] == "empty" => grid.bounds = None,
                    "bbox" => grid.bounds = Some((coord(fields[1]), coord(fields[2]))),
                    "world" => {
                        let xyz = numbers::<f64>(fields[2]);
                        grid.world
                            .push((coord(fields[1]), DVec3::new(xyz[0], xyz[1], xyz[2])));
                    }
                    "probe" => {
                        grid.probes
                            .push((coord(fields[1]), fields[2] == "1", values(fields[3])))
                    }
                    other => panic!("unknown record {other}"),
                }
            }
        }
    }
    files
}

fn check_grid(file: &str, grid: &VdbGrid, expected: &ExpectedGrid) {
    let at = format!("{file} grid '{}'", expected.name);
    assert_eq!(grid.class, expected.class, "{at}");
    let value_type = match grid.value_type {
        VdbValues::Float => "float",
        VdbValues::Vec3 => "vec3s",
    };
    assert_eq!(value_type, expected.value_type, "{at}");
    assert_eq!(grid.saved_as_half, expected.half, "{at}");
    let components = grid.components();
    assert_eq!(
        &grid.background[..components],
        &expected.background[..],
        "{at} background"
    );
    assert_eq!(
        grid.active_voxel_count(),
        expected.active_voxels,
        "{at} active voxels"
    );
    assert_eq!(grid.leaves.len(), expected.leaves, "{at} leaves");
    assert_eq!(grid.active_bounds(), expected.bounds, "{at} bounds");
    for (ijk, world) in &expected.world {
        let ours =
            grid.index_to_world_point(DVec3::new(ijk[0] as f64, ijk[1] as f64, ijk[2] as f64));
        let tolerance = 1e-12 * world.length().max(1.0);
        assert!(
            (ours - *world).length() <= tolerance,
            "{at} {ijk:?}: {ours} vs {world}"
        );
    }
    for (ijk, active, value) in &expected.probes {
        let (ours, ours_active) = grid.probe(*ijk);
        assert_eq!(&ours[..components], &value[..], "{at} value at {ijk:?}");
        assert_eq!(ours_active, *active, "{at} state at {ijk:?}");
    }
}

#[test]
fn every_fixture_reads_as_openvdb_reads_it() {
    let files = expected();
    assert!(
        files.len() >= 15,
        "expected.txt lists {} files",
        files.len()
    );
    for (name, expected) in &files {
        let result = read_file(&fixture(name));
        if let Some(error) = &expected.error {
            let failure = result.expect_err(name);
            assert!(
                failure.message.contains(error.as_str()),
                "{name}: {}",
                failure.message
            );
            continue;
        }
        let grids = result.unwrap_or_else(|e| panic!("{name}: {}", e.message));
        assert_eq!(grids.len(), expected.grids.len(), "{name}");
        // pyopenvdb lists grids sorted by name (keeping file order among equal names).
        let mut seen: HashMap<&str, usize> = HashMap::new();
        for want in &expected.grids {
            let occurrence = seen.entry(want.name.as_str()).or_default();
            let grid = grids
                .iter()
                .filter(|g| g.name == want.name)
                .nth(*occurrence)
                .unwrap_or_else(|| panic!("{name}: no grid '{}'", want.name));
            *occurrence += 1;
            check_grid(name, grid, want);
        }
    }
}

#[test]
fn level_set_interior_reads_minus_background() {
    let grid = read_grid(&fixture("sphere.vdb"), "sphere").unwrap();
    let background = grid.background[0];
    // The centre lies in an inactive interior tile, far from any leaf.
    assert_eq!(grid.probe([40, 40, 40]), ([-background, 0.0, 0.0], false));
    assert!(
        grid.tiles
            .iter()
            .any(|t| !t.active && t.value[0] == -background && t.size == 8)
    );
    // Inside a leaf, inactive voxels on the inside are −background and outside +background.
    let mut inside = 0;
    let mut outside = 0;
    for leaf in &grid.leaves {
        for offset in (0..LEAF_VOXELS).filter(|&o| !leaf.is_active(o)) {
            let v = leaf.values[offset];
            assert!(v == background || v == -background, "{v}");
            if v < 0.0 { inside += 1 } else { outside += 1 }
        }
    }
    assert!(inside > 100 && outside > 100, "{inside} {outside}");
}

#[test]
fn types_felt_converts_and_refuses() {
    let expected = expected();
    let (_, types) = expected.iter().find(|(n, _)| n == "types.vdb").unwrap();
    let path = fixture("types.vdb");
    for (name, value_type, voxels) in &types.printed {
        let result = read_grid(&path, name);
        match value_type.as_str() {
            "bool" => {
                let failure = result.unwrap_err();
                assert!(
                    failure.message.contains("unsupported grid type"),
                    "{}",
                    failure.message
                );
                assert!(
                    failure.message.contains(name.as_str()),
                    "{}",
                    failure.message
                );
            }
            stored => {
                let grid = result.unwrap_or_else(|e| panic!("{name}: {}", e.message));
                assert_eq!(grid.stored_type, stored);
                assert_eq!(grid.active_voxel_count(), *voxels, "{name}");
                let components = if stored.starts_with("vec3") { 3 } else { 1 };
                assert_eq!(grid.components(), components);
                assert_eq!(grid.background, [0.0; 3]);
            }
        }
    }
    let missing = read_grid(&path, "temperature").unwrap_err();
    assert!(
        missing.message.contains("'dens'") && missing.message.contains("'u'"),
        "{}",
        missing.message
    );
}

#[test]
fn instances_share_their_parent_tree() {
    let grids = read_file(&fixture("instance.vdb")).unwrap();
    let names: Vec<&str> = grids.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["a", "b", "a"]);
    assert_eq!(grids[1].leaves, grids[0].leaves);
    assert_eq!(grids[1].voxel_size(), DVec3::splat(2.0));
    // Asking for the instance alone still brings its parent's tree.
    let alone = read_grid(&fixture("instance.vdb"), "b").unwrap();
    assert_eq!(alone.leaves, grids[0].leaves);
}

#[test]
fn transforms_become_the_matching_matrix() {
    for (file, name) in [
        ("transforms.vdb", "affine"),
        ("translation_map.vdb", "translation"),
        ("unitary_map.vdb", "unitary"),
    ] {
        let grid = read_grid(&fixture(file), name).unwrap();
        // A world point maps back to its index through the inverse.
        let ijk = DVec3::new(3.0, -2.0, 5.0);
        let world = grid.index_to_world_point(ijk);
        let back = grid.index_to_world.inverse().transform_point3(world);
        assert!((back - ijk).length() < 1e-12, "{name}");
    }
}
