//! `cachesave` → `cacheload` over many random domains: every domain felt accepts comes back
//! with the same cells, values, transform and bounds; and grids far out or holding NaN load
//! as they should.

use super::*;
use crate::grid::vdb::VdbLeaf;

use crate::base::test_random::SplitMix as Random;

fn options(name: &str, class: GridClass) -> GridOptions {
    GridOptions {
        name: name.to_string(),
        class,
        vector_type: DEFAULT_VECTOR_TYPE.to_string(),
        creator: "felt test".to_string(),
    }
}

/// A cache over `domain` with random values, a quarter of them the background and a shell of
/// background one cell deep on the low faces (so leaves alone would not give the box back).
fn random_cache(random: &mut Random, domain: Domain, width: usize) -> Cache {
    let cells = domain.cell_count();
    let background: Vec<f64> = (0..width).map(|_| random.range(-1.0, 1.0)).collect();
    let res = domain.resolution.unwrap();
    let data: Vec<Vec<f32>> = (0..width)
        .map(|c| {
            (0..cells)
                .map(|n| {
                    let (i, j, k) = (n % res[0], n / res[0] % res[1], n / (res[0] * res[1]));
                    let shell = i == 0 || j == 0 || k == 0;
                    if shell || random.next().is_multiple_of(4) {
                        background[c] as f32
                    } else {
                        random.range(-10.0, 10.0) as f32
                    }
                })
                .collect()
        })
        .collect();
    Cache::from_dense(domain, width, data, background).unwrap()
}

fn close(a: DVec3, b: DVec3, tolerance: f64, what: &str, case: usize) {
    assert!(
        (a - b).abs().max_element() <= tolerance,
        "case {case}: {what} {a} came back as {b}"
    );
}

#[test]
fn every_domain_comes_back_from_a_vdb_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut random = Random(16);
    for case in 0..60 {
        let cell = random.range(0.01, 2.0);
        let cell_z = if case % 3 == 0 {
            random.range(0.01, 2.0)
        } else {
            cell
        };
        // Lengths that are rarely whole cells: the domain rounds them.
        let counts = random.vector(1.0, 20.0);
        let lengths = counts * DVec3::new(cell, cell, cell_z);
        let origin = random.vector(-100.0, 100.0);
        let orientation = match case % 4 {
            0 => DVec3::ZERO,
            1 => DVec3::new(0.0, 0.0, random.range(-3.1, 3.1)),
            _ => random.vector(-2.0, 2.0),
        };
        let domain = Domain::with_cells(origin, lengths, orientation, cell, cell_z).unwrap();
        let width = if case % 2 == 0 { 1 } else { 3 };
        let cache = random_cache(&mut random, domain.clone(), width);
        let name = if width == 1 { "density" } else { "vel" };
        let class = if width == 1 {
            GridClass::FogVolume
        } else {
            GridClass::Unknown
        };
        let path = dir.path().join(format!("case{case}.vdb"));
        save(
            &path,
            grid_of(&cache, &options(name, class)).unwrap(),
            false,
            &[],
        )
        .unwrap();
        let (loaded, check, _) = load(&path, name, width).unwrap();
        assert_eq!(check.non_finite, 0);
        assert_eq!(loaded.resolution(), cache.resolution(), "case {case}");
        let res = cache.resolution();
        for i in 0..res[0] {
            for j in 0..res[1] {
                for k in 0..res[2] {
                    assert_eq!(
                        loaded.value_at_cell(i, j, k),
                        cache.value_at_cell(i, j, k),
                        "case {case}: cell ({i}, {j}, {k})"
                    );
                }
            }
        }
        let back = loaded.domain();
        let scale = origin.abs().max_element() + lengths.max_element();
        close(back.origin, domain.origin, 1e-12 * scale, "origin", case);
        close(
            back.cell,
            domain.cell,
            1e-12 * cell.max(cell_z),
            "cell",
            case,
        );
        close(back.lengths, domain.lengths, 1e-11 * scale, "lengths", case);
        for axis in 0..3 {
            close(
                back.rotation.col(axis),
                domain.rotation.col(axis),
                1e-12,
                "axis",
                case,
            );
        }
        let (was, is) = (domain.bounds(), back.bounds());
        close(is.min, was.min, 1e-11 * scale, "bounds min", case);
        close(is.max, was.max, 1e-11 * scale, "bounds max", case);
        let background: Vec<f64> = cache
            .background_values()
            .iter()
            .map(|&b| b as f32 as f64)
            .collect();
        assert_eq!(
            loaded.background_values(),
            background.as_slice(),
            "case {case}"
        );
    }
}

#[test]
fn a_level_set_is_stored_negative_inside_and_read_back_positive() {
    let dir = tempfile::tempdir().unwrap();
    let domain = Domain::with_cells(DVec3::ZERO, DVec3::splat(1.0), DVec3::ZERO, 0.1, 0.1).unwrap();
    let cells = domain.cell_count();
    // Inside the narrow band everywhere: |φ| < 0.5, the background's magnitude.
    let values: Vec<f32> = (0..cells)
        .map(|n| (n as f32 / cells as f32) * 0.8 - 0.4)
        .collect();
    let cache = Cache::from_dense(domain, 1, vec![values], vec![-0.5]).unwrap();
    let path = dir.path().join("sphere.vdb");
    let grid = grid_of(&cache, &options("surface", GridClass::LevelSet)).unwrap();
    save(&path, grid, false, &[]).unwrap();
    let raw = vdb::read_grid(&path, "surface").unwrap();
    assert_eq!(raw.class, vdb::LEVEL_SET);
    assert_eq!(raw.background[0], 0.5);
    assert_eq!(
        raw.value_at([3, 4, 5])[0],
        -cache.value_at_cell(3, 4, 5).unwrap()[0]
    );
    let (loaded, _, _) = load(&path, "surface", 1).unwrap();
    assert_eq!(loaded.value_at_cell(3, 4, 5), cache.value_at_cell(3, 4, 5));
    assert_eq!(loaded.background_values(), &[-0.5]);
    // A level set's outside must be negative in felt's convention.
    let inside_out = Cache::from_dense(
        Domain::with_cells(DVec3::ZERO, DVec3::ONE, DVec3::ZERO, 0.5, 0.5).unwrap(),
        1,
        vec![vec![0.0; 8]],
        vec![0.5],
    )
    .unwrap();
    let err = grid_of(&inside_out, &options("s", GridClass::LevelSet)).unwrap_err();
    assert!(err.message.contains("must be negative"), "{}", err.message);
}

#[test]
fn grids_saved_to_one_file_stay_together() {
    let dir = tempfile::tempdir().unwrap();
    let mut random = Random(7);
    let domain =
        Domain::with_cells(DVec3::ZERO, DVec3::splat(1.0), DVec3::ZERO, 0.25, 0.25).unwrap();
    let density = random_cache(&mut random, domain.clone(), 1);
    let temperature = random_cache(&mut random, domain.clone(), 1);
    let velocity = random_cache(&mut random, domain, 3);
    let path = dir.path().join("sim.vdb");
    let meta = [("shot".to_string(), VdbMeta::String("sh010".into()))];
    let fog = |name| options(name, GridClass::FogVolume);
    save(
        &path,
        grid_of(&density, &fog("density")).unwrap(),
        false,
        &meta,
    )
    .unwrap();
    save(
        &path,
        grid_of(&temperature, &fog("temperature")).unwrap(),
        true,
        &meta,
    )
    .unwrap();
    let vel = grid_of(&velocity, &options("vel", GridClass::Unknown)).unwrap();
    save(&path, vel, true, &meta).unwrap();
    // The same name again replaces that grid where it was.
    save(
        &path,
        grid_of(&temperature, &fog("density")).unwrap(),
        true,
        &meta,
    )
    .unwrap();
    let grids = vdb::read_file(&path).unwrap();
    let names: Vec<&str> = grids.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["density", "temperature", "vel"]);
    assert_eq!(
        grids[2].meta("vector_type"),
        Some(&VdbMeta::String(DEFAULT_VECTOR_TYPE.into()))
    );
    assert_eq!(
        grids[0].meta("creator"),
        Some(&VdbMeta::String("felt test".into()))
    );
    let (loaded, _, _) = load(&path, "density", 1).unwrap();
    assert_eq!(
        loaded.value_at_cell(2, 3, 1),
        temperature.value_at_cell(2, 3, 1)
    );
    let file_meta = vdb::read_file_metadata(&std::fs::read(&path).unwrap()).unwrap();
    assert_eq!(file_meta, meta.to_vec());
    // Without keep, the file holds the one grid.
    save(
        &path,
        grid_of(&density, &fog("density")).unwrap(),
        false,
        &[],
    )
    .unwrap();
    assert_eq!(vdb::read_file(&path).unwrap().len(), 1);
}

/// A file holding one scalar grid "density" with unit voxels and these leaves, each filled
/// with its value and all active.
fn file_with_leaves(dir: &Path, leaves: &[([i32; 3], f32)]) -> std::path::PathBuf {
    let mut grid = VdbGrid::new(
        "density",
        vdb::FOG_VOLUME,
        VdbValues::Float,
        [0.0; 3],
        DMat4::IDENTITY,
    );
    for &(origin, value) in leaves {
        grid.leaves.push(VdbLeaf {
            origin,
            values: vec![value; vdb::LEAF_VOXELS],
            active: [u64::MAX; 8],
        });
    }
    grid.sort_nodes();
    let path = dir.join("leaves.vdb");
    vdb::write_file(&path, &[grid], Compression::Zip).unwrap();
    path
}

#[test]
fn an_index_box_past_i32_is_too_large_not_negative() {
    let dir = tempfile::tempdir().unwrap();
    let far = 1 << 30;
    let path = file_with_leaves(dir.path(), &[([-far, 0, 0], 1.0), ([far, 0, 0], 2.0)]);
    let message = load(&path, "density", 1).unwrap_err().message;
    assert!(
        message.contains(
            "spans voxel indices [-1073741824, 0, 0] to [1073741831, 7, 7], a box of \
             2147483656 x 8 x 8 voxels"
        ) && message.contains("over the memory budget"),
        "{message}"
    );
    assert!(!message.contains("must be positive"), "{message}");
    // One leaf that far out is an ordinary small cache.
    let path = file_with_leaves(dir.path(), &[([far, -far, 0], 3.0)]);
    let (cache, check, _) = load(&path, "density", 1).unwrap();
    assert_eq!(cache.resolution(), [8, 8, 8]);
    assert_eq!(cache.value_at_cell(7, 7, 7), Some(&[3.0f32][..]));
    assert_eq!(check.warning(&path, "density"), None);
}

#[test]
fn non_finite_voxels_are_counted_on_load() {
    let dir = tempfile::tempdir().unwrap();
    let path = file_with_leaves(dir.path(), &[([0, 0, 0], f32::NAN), ([8, 0, 0], 1.0)]);
    let (_, check, _) = load(&path, "density", 1).unwrap();
    assert_eq!(
        check,
        LoadCheck {
            voxels: 1024,
            non_finite: 512,
            bad_background: false,
            beyond_frustum: 0,
        }
    );
    assert_eq!(
        check.warning(&path, "density").unwrap(),
        format!(
            "cacheload: grid 'density' of {} is NaN or infinite at 512 of its 1,024 voxels",
            path.display()
        )
    );
}
