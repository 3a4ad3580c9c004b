//! Frustum caches in VDB files, each checked by a second route: the file's transform through
//! OpenVDB's `applyMap` as `openvdb/math/Maps.h` writes it (applied here to the numbers parsed
//! from the file's bytes), a round trip through a file back to the same cells and maps, and,
//! with `FELT_PEER_TESTS=1`, OpenVDB itself (pyopenvdb) reading felt's file and writing one
//! for felt to read.

use super::Frustum;
use super::tests::{random_frustum, view};
use crate::base::test_random::SplitMix;
use crate::grid::cache::Cache;
use crate::grid::vdb::{self, Compression, FrustumMap, VdbGrid, VdbValues};
use crate::grid::vdb_cache::{self, DEFAULT_VECTOR_TYPE, GridClass, GridOptions};
use glam::{DMat4, DVec3};
use std::path::Path;

fn options() -> GridOptions {
    GridOptions {
        name: "density".into(),
        class: GridClass::FogVolume,
        vector_type: DEFAULT_VECTOR_TYPE.into(),
        creator: "felt test".into(),
    }
}

/// A cache over the frustum's cells holding a different value in every cell.
fn numbered_cache(frustum: &Frustum, random: &mut SplitMix) -> Cache {
    let domain = frustum.index_domain().unwrap();
    let count = domain.cell_count();
    let values = (0..count).map(|_| random.range(0.5, 9.5) as f32).collect();
    Cache::from_dense(domain, 1, vec![values], vec![0.0]).unwrap()
}

/// A perspective frustum with padding, non-square pixels and a tilted view.
fn tilted() -> Frustum {
    let v = view(
        DVec3::new(0.3, 1.2, 4.0),
        DVec3::new(-0.5, 0.4, -1.0),
        50.0,
        1.7,
        None,
    );
    Frustum::new(v, 0.4, 7.5, [13, 9, 6], 2, 1).unwrap()
}

/// An orthographic frustum with square pixels: a box of cubes across.
fn square_box() -> Frustum {
    let v = view(DVec3::new(1.0, 2.0, 3.0), DVec3::ZERO, 0.0, 1.5, Some(3.0));
    Frustum::new(v, 0.5, 4.0, [12, 8, 5], 1, 1).unwrap()
}

/// The transform of the first grid of a VDB file, parsed from its bytes as OpenVDB's
/// `Transform::read` reads it: the frustum's box, taper and depth, and the second map's 4×4
/// matrix, row-major, applied to row vectors.
fn frustum_in_file(bytes: &[u8]) -> ([f64; 8], [[f64; 4]; 4]) {
    let name = b"NonlinearFrustumMap";
    let at = bytes
        .windows(name.len())
        .position(|w| w == name)
        .expect("the file holds a frustum map")
        + name.len();
    let f64_at = |i: usize| f64::from_le_bytes(bytes[i..i + 8].try_into().unwrap());
    let numbers: [f64; 8] = std::array::from_fn(|n| f64_at(at + 8 * n));
    let second = at + 64;
    let length = u32::from_le_bytes(bytes[second..second + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[second + 4..second + 4 + length], b"AffineMap");
    let matrix = second + 4 + length;
    let rows = std::array::from_fn(|r| std::array::from_fn(|c| f64_at(matrix + 8 * (4 * r + c))));
    (numbers, rows)
}

/// OpenVDB's `NonlinearFrustumMap::applyMap` (Maps.h): `applyFrustumMap`, then the second map.
fn apply_map(numbers: &[f64; 8], rows: &[[f64; 4]; 4], ijk: [f64; 3]) -> DVec3 {
    let [min_x, min_y, min_z, max_x, max_y, max_z, taper, depth] = *numbers;
    let (lx, ly, lz) = (max_x - min_x, max_y - min_y, max_z - min_z);
    let gamma = (1.0 / taper - 1.0) / depth;
    let mut x = ijk[0] - min_x - 0.5 * lx;
    let mut y = ijk[1] - min_y - 0.5 * ly;
    let z = (ijk[2] - min_z) * (depth / lz);
    let scale = (gamma * z + 1.0) / lx;
    x *= scale;
    y *= scale;
    let v = [x, y, z, 1.0];
    DVec3::from_array(std::array::from_fn(|c| {
        (0..4).map(|r| v[r] * rows[r][c]).sum::<f64>()
    }))
}

fn saved(frustum: &Frustum, cache: &Cache) -> Vec<u8> {
    let grid = vdb_cache::grid_placed(cache, &options(), &frustum.vdb_placement()).unwrap();
    vdb::write_bytes(&[grid], Compression::Zip).unwrap()
}

fn near(a: DVec3, b: DVec3, relative: f64) -> bool {
    (a - b).length() <= relative * b.length().max(1.0)
}

#[test]
fn openvdbs_frustum_map_puts_every_voxel_at_its_cells_centre() {
    let mut random = SplitMix(41);
    let mut checked = 0;
    for case in 0..40 {
        let frustum = if case == 0 {
            tilted()
        } else {
            random_frustum(&mut random)
        };
        if frustum.view.orthographic {
            continue;
        }
        let bytes = saved(&frustum, &numbered_cache(&frustum, &mut random));
        let (numbers, rows) = frustum_in_file(&bytes);
        let [nx, ny, nz] = frustum.cells();
        let pad = frustum.padding as f64;
        for n in 0..nx * ny * nz {
            let (i, j, k) = (n % nx, n / nx % ny, n / (nx * ny));
            // The voxel of cell (i, j, k) is (i − padding, j − padding, k).
            let voxel = [i as f64 - pad, j as f64 - pad, k as f64];
            let openvdb = apply_map(&numbers, &rows, voxel);
            let centre = DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5);
            let felt = frustum.index_to_world(centre);
            assert!(
                near(openvdb, felt, 1e-9),
                "case {case}, cell ({i}, {j}, {k}): OpenVDB puts it at {openvdb}, felt at {felt}"
            );
        }
        checked += 1;
    }
    assert!(checked > 20, "only {checked} perspective frustums");
}

#[test]
fn a_frustum_cache_comes_back_from_a_vdb_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frustum.vdb");
    let mut random = SplitMix(7);
    for case in 0..30 {
        let frustum = match case {
            0 => tilted(),
            1 => square_box(),
            _ => random_frustum(&mut random),
        };
        let square = frustum.view.half_width / frustum.pixels[0] as f64
            == frustum.view.half_height / frustum.pixels[1] as f64;
        if frustum.view.orthographic && !square {
            // Written as a box of cells wider than high, which a cache's domain cannot hold.
            continue;
        }
        let cache = numbered_cache(&frustum, &mut random);
        std::fs::write(&path, saved(&frustum, &cache)).unwrap();
        let (loaded, check, back) = vdb_cache::load(&path, "density", 1).unwrap();
        assert_eq!(check.non_finite, 0);
        let [nx, ny, nz] = frustum.cells();
        assert_eq!(loaded.resolution(), [nx, ny, nz], "case {case}");
        for n in 0..nx * ny * nz {
            let (i, j, k) = (n % nx, n / nx % ny, n / (nx * ny));
            assert_eq!(
                loaded.value_at_cell(i, j, k).map(|v| v[0].to_bits()),
                cache.value_at_cell(i, j, k).map(|v| v[0].to_bits()),
                "case {case}, cell ({i}, {j}, {k})"
            );
        }
        let Some(back) = back else {
            // A box comes back as an ordinary cache at the same place.
            assert!(frustum.view.orthographic, "case {case}");
            let domain = loaded.domain();
            let first = domain.origin + domain.rotation * (domain.cell * 0.5);
            let felt = frustum.index_to_world(DVec3::splat(0.5));
            assert!(near(first, felt, 1e-9), "case {case}: {first} != {felt}");
            continue;
        };
        assert!(!frustum.view.orthographic, "case {case}");
        assert_eq!(back.cells(), frustum.cells(), "case {case}");
        assert_eq!(back.padding, frustum.padding, "case {case}");
        let bounds = frustum.bounds();
        for _ in 0..200 {
            let p = bounds.min + (bounds.max - bounds.min) * random.vector(-0.2, 1.2);
            let (want, got) = (frustum.world_to_index(p), back.world_to_index(p));
            assert!(
                near(got, want, 1e-9),
                "case {case}: {p} maps to cell point {got}, not {want}"
            );
        }
    }
}

/// A one-leaf grid with OpenVDB's frustum map `map` and second map `second`, as a file.
fn file_with_frustum(dir: &Path, map: FrustumMap, second: DMat4) -> std::path::PathBuf {
    let mut grid = VdbGrid::new(
        "density",
        vdb::FOG_VOLUME,
        VdbValues::Float,
        [0.0; 3],
        second,
    );
    grid.frustum = Some(map);
    let grid = grid
        .with_values_from(
            [0; 3],
            [3; 3],
            vdb::Activity::AwayFromBackground(0.0),
            |_, out| out[0] = 1.0,
        )
        .unwrap();
    let path = dir.join("theirs.vdb");
    vdb::write_file(&path, &[grid], Compression::Zip).unwrap();
    path
}

#[test]
fn a_frustum_felt_cannot_represent_is_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let good = FrustumMap {
        bbox_min: DVec3::splat(-0.5),
        bbox_max: DVec3::new(15.5, 7.5, 9.5),
        taper: 0.5,
        depth: 2.0,
    };
    let scale = DMat4::from_scale(DVec3::splat(0.1));
    let (_, _, frustum) =
        vdb_cache::load(&file_with_frustum(dir.path(), good, scale), "density", 1).unwrap();
    assert_eq!(frustum.unwrap().cells(), [16, 8, 10]);
    // A box from voxel to voxel, as OpenVDB's camera frustums are, gains its far faces' voxels,
    // each where OpenVDB puts it.
    let corners = FrustumMap {
        bbox_min: DVec3::ZERO,
        bbox_max: DVec3::new(16.0, 8.0, 10.0),
        ..good
    };
    let rotated = DMat4::from_rotation_translation(
        glam::DQuat::from_rotation_y(0.7),
        DVec3::new(1.0, -2.0, 3.0),
    ) * scale;
    let (_, _, frustum) = vdb_cache::load(
        &file_with_frustum(dir.path(), corners, rotated),
        "density",
        1,
    )
    .unwrap();
    let frustum = frustum.unwrap();
    assert_eq!(frustum.cells(), [17, 9, 11]);
    let numbers = [0.0, 0.0, 0.0, 16.0, 8.0, 10.0, 0.5, 2.0];
    let rows = std::array::from_fn(|r| rotated.col(r).to_array());
    for voxel in [[0, 0, 0], [16, 8, 10], [3, 7, 2], [9, 0, 10]] {
        let openvdb = apply_map(&numbers, &rows, voxel.map(f64::from));
        let felt = frustum.index_to_world(DVec3::from_array(voxel.map(|c| c as f64 + 0.5)));
        assert!(
            near(openvdb, felt, 1e-9),
            "{voxel:?}: {openvdb} against {felt}"
        );
    }
    let sheared = DMat4::from_cols_array(&[
        1.0, 0.0, 0.0, 0.0, 0.3, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ]);
    let off_axis = FrustumMap {
        bbox_min: DVec3::splat(0.25),
        ..good
    };
    let cases = [
        (good, sheared, "shears space"),
        (
            off_axis,
            scale,
            "neither on a voxel nor halfway between two",
        ),
        (FrustumMap { taper: 2.0, ..good }, scale, "near face wider"),
        (
            FrustumMap {
                bbox_min: DVec3::new(-0.5, -0.5, 0.2),
                bbox_max: DVec3::new(15.5, 7.5, 0.8),
                ..good
            },
            scale,
            "holds no whole voxel",
        ),
    ];
    for (map, second, words) in cases {
        let path = file_with_frustum(dir.path(), map, second);
        let message = vdb_cache::load(&path, "density", 1).unwrap_err().message;
        assert!(
            message.contains("grid 'density' has a frustum transform felt cannot represent")
                && message.contains(words),
            "{message}"
        );
    }
}

#[test]
fn voxels_beyond_a_frustums_box_are_counted_in_the_warning() {
    let dir = tempfile::tempdir().unwrap();
    // The file's voxels fill [0, 3]³; the box holds x up to 2 only.
    let map = FrustumMap {
        bbox_min: DVec3::splat(-0.5),
        bbox_max: DVec3::new(2.5, 7.5, 9.5),
        taper: 0.5,
        depth: 2.0,
    };
    let path = file_with_frustum(dir.path(), map, DMat4::from_scale(DVec3::splat(0.1)));
    let (loaded, check, _) = vdb_cache::load(&path, "density", 1).unwrap();
    assert_eq!(loaded.resolution(), [3, 8, 10]);
    assert_eq!(check.beyond_frustum, 16);
    let warning = check.warning(&path, "density").unwrap();
    assert!(
        warning.ends_with("holds 16 voxels beyond its frustum's index box, which are not read"),
        "{warning}"
    );
}

/// Prints, for the voxels listed in a file, OpenVDB's world point and value of the first grid
/// of a VDB file, after its transform's type; with a third argument, first writes that file:
/// a grid with a frustum transform made by OpenVDB, a value at each listed voxel.
const PEER: &str = r#"
import sys
import pyopenvdb as vdb
voxels = [tuple(int(c) for c in line.split()) for line in open(sys.argv[2])]
if len(sys.argv) > 3:
    g = vdb.FloatGrid(0.0)
    g.name = "density"
    g.transform = vdb.createFrustumTransform((0, 0, 0), (15, 7, 9), 0.5, 2.0, 0.1)
    a = g.getAccessor()
    for n, ijk in enumerate(voxels):
        a.setValueOn(ijk, 1.0 + n)
    vdb.write(sys.argv[1], grids=[g])
g = vdb.readAll(sys.argv[1])[0][0]
print(g.transform.typeName)
a = g.getConstAccessor()
for ijk in voxels:
    w = g.transform.indexToWorld(ijk)
    print(" ".join(repr(float(c)) for c in w), repr(float(a.getValue(ijk))))
"#;

fn peer_enabled() -> bool {
    if std::env::var("FELT_PEER_TESTS").as_deref() == Ok("1") {
        return true;
    }
    eprintln!("skipped: set FELT_PEER_TESTS=1 to check frustum VDB files with pyopenvdb");
    false
}

/// OpenVDB's transform type, then its world point and value at each voxel.
fn openvdb_reads(file: &Path, voxels: &[[i32; 3]], write: bool) -> (String, Vec<(DVec3, f32)>) {
    let list = file.with_extension("voxels");
    let lines: Vec<String> = voxels
        .iter()
        .map(|v| format!("{} {} {}", v[0], v[1], v[2]))
        .collect();
    std::fs::write(&list, lines.join("\n")).unwrap();
    let mut args = vec!["-c", PEER, file.to_str().unwrap(), list.to_str().unwrap()];
    if write {
        args.push("write");
    }
    let output = std::process::Command::new("/usr/bin/python3")
        .args(&args)
        .output()
        .expect("runs /usr/bin/python3");
    let stdout = String::from_utf8(output.stdout).unwrap();
    assert!(
        output.status.success(),
        "pyopenvdb failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    let mut lines = stdout.lines();
    let kind = lines.next().unwrap().to_string();
    let points = lines
        .map(|line| {
            let n: Vec<f64> = line.split(' ').map(|c| c.parse().unwrap()).collect();
            (DVec3::new(n[0], n[1], n[2]), n[3] as f32)
        })
        .collect();
    (kind, points)
}

#[test]
fn openvdb_reads_felts_frustum_and_felt_reads_openvdbs() {
    if !peer_enabled() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let frustum = tilted();
    let cache = numbered_cache(&frustum, &mut SplitMix(3));
    let ours = dir.path().join("ours.vdb");
    std::fs::write(&ours, saved(&frustum, &cache)).unwrap();
    let cells = [[0, 0, 0], [16, 12, 5], [2, 2, 0], [7, 3, 4], [14, 0, 2]];
    let voxels: Vec<[i32; 3]> = cells.iter().map(|c| [c[0] - 2, c[1] - 2, c[2]]).collect();
    let (kind, read) = openvdb_reads(&ours, &voxels, false);
    assert_eq!(kind, "NonlinearFrustumMap");
    for (cell, (world, value)) in cells.iter().zip(read) {
        let centre = DVec3::from_array(cell.map(|c| c as f64 + 0.5));
        let felt = frustum.index_to_world(centre);
        assert!(
            near(world, felt, 1e-9),
            "cell {cell:?}: OpenVDB {world}, felt {felt}"
        );
        let [i, j, k] = cell.map(|c| c as usize);
        assert_eq!(
            Some(&[value][..]),
            cache.value_at_cell(i, j, k),
            "cell {cell:?}"
        );
    }

    let theirs = dir.path().join("theirs.vdb");
    let voxels = [[0, 0, 0], [15, 7, 9], [3, 5, 1], [8, 0, 6]];
    let (kind, read) = openvdb_reads(&theirs, &voxels, true);
    assert_eq!(kind, "NonlinearFrustumMap");
    let (loaded, _, frustum) = vdb_cache::load(&theirs, "density", 1).unwrap();
    let frustum = frustum.expect("a frustum");
    assert_eq!(frustum.cells(), [16, 8, 10]);
    for (n, (voxel, (world, value))) in voxels.iter().zip(read).enumerate() {
        let centre = DVec3::from_array(voxel.map(|c| c as f64 + 0.5));
        let felt = frustum.index_to_world(centre);
        assert!(
            near(world, felt, 1e-9),
            "voxel {voxel:?}: OpenVDB {world}, felt {felt}"
        );
        assert_eq!(value, 1.0 + n as f32);
        let [i, j, k] = voxel.map(|c| c as usize);
        assert_eq!(loaded.value_at_cell(i, j, k), Some(&[value][..]));
    }
}
