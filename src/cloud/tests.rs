use super::automaton::{CloudState, Wind};
use super::bits::Planes;
use super::region::{Probabilities, Probability, ellipsoid_profile};
use super::smooth::{SmoothedCloud, Smoothing};
use crate::grid::cache::Cache;
use crate::space::FieldSampler;
use crate::space::domain::Domain;
use glam::DVec3;
use std::sync::Arc;

fn domain(n: [usize; 3]) -> Domain {
    let lengths = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
    Domain::with_cells(DVec3::ZERO, lengths, DVec3::ZERO, 1.0, 1.0).unwrap()
}

fn empty(n: [usize; 3], seed: u64) -> CloudState {
    CloudState::initial(domain(n), n, seed, &Probabilities::none())
}

fn random_state(n: [usize; 3], seed: u64, hum: f64, act: f64, cld: f64) -> CloudState {
    let p = Probabilities {
        hum: Probability::uniform(hum),
        act: Probability::uniform(act),
        ext: Probability::uniform(cld),
    };
    CloudState::initial(domain(n), n, seed, &p)
}

fn set(state: &mut CloudState, plane: usize, [i, j, k]: [usize; 3], value: bool) {
    let planes = state.planes;
    let target = match plane {
        0 => &mut state.hum,
        1 => &mut state.act,
        _ => &mut state.cld,
    };
    let plane: &mut Vec<u64> = std::sync::Arc::make_mut(target);
    planes.set(plane, i, j, k, value);
}

fn get(state: &CloudState, plane: usize, [i, j, k]: [usize; 3]) -> bool {
    let p = match plane {
        0 => &state.hum,
        1 => &state.act,
        _ => &state.cld,
    };
    state.planes.get(p, i, j, k)
}

pub(super) fn each_cell(n: [usize; 3]) -> impl Iterator<Item = [usize; 3]> {
    (0..n[2]).flat_map(move |k| (0..n[1]).flat_map(move |j| (0..n[0]).map(move |i| [i, j, k])))
}

#[test]
fn growth_rules_match_the_source_for_every_state_and_neighbourhood() {
    // The neighbourhood of eq. 2.4 in the source's coordinates (i, j horizontal, k up), and
    // one offset that is *not* in it, (0, 0, +2): 12 cells around the centre. Every
    // (hum, act, cld) of the centre with every pattern of act on those 12 cells.
    let source: [[i64; 3]; 11] = [
        [1, 0, 0],
        [0, 1, 0],
        [0, 0, 1],
        [-1, 0, 0],
        [0, -1, 0],
        [0, 0, -1],
        [-2, 0, 0],
        [2, 0, 0],
        [0, -2, 0],
        [0, 2, 0],
        [0, 0, -2],
    ];
    let mut offsets: Vec<[i64; 3]> = source.to_vec();
    offsets.push([0, 0, 2]);
    // felt's y is up: source (i, j, k) is felt (x, z, y).
    let to_felt = |[i, j, k]: [i64; 3]| [i, k, j];
    let n = [5, 5, 5];
    let centre = [2usize, 2, 2];
    let base = empty(n, 1);
    for pattern in 0u32..1 << offsets.len() {
        for own in 0u32..8 {
            let (hum, act, cld) = (own & 1 == 1, own & 2 == 2, own & 4 == 4);
            let mut s = base.clone();
            set(&mut s, 0, centre, hum);
            set(&mut s, 1, centre, act);
            set(&mut s, 2, centre, cld);
            for (b, o) in offsets.iter().enumerate() {
                if pattern >> b & 1 == 1 {
                    let f = to_felt(*o);
                    let at = [0, 1, 2].map(|a| (centre[a] as i64 + f[a]) as usize);
                    set(&mut s, 1, at, true);
                }
            }
            let next = s.step(&Probabilities::none(), &Wind::CALM);
            // Eq. 2.4: any of the 11 source neighbours; the 12th offset never counts.
            let f = (0..source.len()).any(|b| pattern >> b & 1 == 1);
            let expected = (hum && !act, !act && hum && f, cld || act);
            let got = (
                get(&next, 0, centre),
                get(&next, 1, centre),
                get(&next, 2, centre),
            );
            assert_eq!(
                got, expected,
                "pattern {pattern:012b}, hum {hum} act {act} cld {cld}"
            );
        }
    }
}

#[test]
fn without_probabilities_the_rules_are_deterministic_and_clouds_stay() {
    let n = [70, 6, 9];
    let start = random_state(n, 11, 0.4, 0.05, 0.2);
    let mut other = start.clone();
    other.seed = 987_654;
    let (mut a, mut b) = (start.clone(), other);
    for _ in 0..12 {
        let next = a.step(&Probabilities::none(), &Wind::CALM);
        for (now, then) in next.cld.iter().zip(a.cld.iter()) {
            assert_eq!(now & then, *then, "a cloud bit disappeared");
        }
        b = b.step(&Probabilities::none(), &Wind::CALM);
        assert_eq!((&next.hum, &next.act, &next.cld), (&b.hum, &b.act, &b.cld));
        a = next;
    }
    assert!(
        a.counts()[2] > start.counts()[2],
        "clouds should have grown"
    );
}

#[test]
fn a_cloud_bit_appears_only_where_act_was_set_the_step_before() {
    let n = [67, 7, 10];
    let p = Probabilities {
        hum: Probability::uniform(0.3),
        act: Probability::uniform(0.05),
        ext: Probability::uniform(0.2),
    };
    for wind in [
        Wind::CALM,
        Wind {
            bottom: [1.0, -1.0],
            top: [3.5, 0.5],
            wrap: true,
        },
    ] {
        let mut s = random_state(n, 5, 0.4, 0.05, 0.1);
        for _ in 0..8 {
            let next = s.step(&p, &wind);
            for [i, j, k] in each_cell(n) {
                if !get(&next, 2, [i, j, k]) {
                    continue;
                }
                // Where this cell was before the wind moved it.
                let [sx, sz] = wind.shift(j, n[1], s.step);
                let from = [
                    (i as i64 - sx).rem_euclid(n[0] as i64) as usize,
                    j,
                    (k as i64 - sz).rem_euclid(n[2] as i64) as usize,
                ];
                assert!(
                    get(&s, 2, from) || get(&s, 1, from),
                    "cld at {:?} without cld or act at {from:?}",
                    [i, j, k]
                );
            }
            s = next;
        }
    }
}

#[test]
fn certain_extinction_empties_and_certain_regeneration_fills() {
    let n = [65, 4, 6];
    let s = random_state(n, 3, 0.5, 0.3, 0.6);
    let cells = (n[0] * n[1] * n[2]) as u64;
    let ext = Probabilities {
        ext: Probability::uniform(1.0),
        ..Probabilities::none()
    };
    assert_eq!(s.step(&ext, &Wind::CALM).counts()[2], 0);
    let regen = Probabilities {
        hum: Probability::uniform(1.0),
        act: Probability::uniform(1.0),
        ext: Probability::uniform(0.0),
    };
    let full = s.step(&regen, &Wind::CALM).counts();
    assert_eq!((full[0], full[1]), (cells, cells));
    // And a probability of one half fires about half the time (65·4·6 = 1560 draws).
    let half = Probabilities {
        hum: Probability::uniform(0.5),
        ..Probabilities::none()
    };
    let from_dry = empty(n, 9).step(&half, &Wind::CALM).counts()[0] as f64 / cells as f64;
    assert!(
        (from_dry - 0.5).abs() < 4.0 * (0.25 / cells as f64).sqrt(),
        "{from_dry}"
    );
}

#[test]
fn wind_moves_a_cell_by_its_layers_shift_per_step() {
    let n = [130, 3, 12];
    // Layer speeds (cells per step): bottom (2, -1), middle (1.25, 0), top (0.5, 1).
    let wind = |wrap| Wind {
        bottom: [2.0, -1.0],
        top: [0.5, 1.0],
        wrap,
    };
    for (layer, per_step) in [(0usize, [2.0, -1.0]), (1, [1.25, 0.0]), (2, [0.5, 1.0])] {
        for wrap in [false, true] {
            let mut s = empty(n, 1);
            let start = [60i64, layer as i64, 6];
            set(&mut s, 2, [60, layer, 6], true);
            for step in 1..=8i64 {
                s = s.step(&Probabilities::none(), &wind(wrap));
                // After `step` steps a speed v has moved ⌊step·v⌋ cells.
                let moved = per_step.map(|v: f64| (step as f64 * v).floor() as i64);
                let at = [start[0] + moved[0], start[1], start[2] + moved[1]];
                let inside = (0..n[0] as i64).contains(&at[0]) && (0..n[2] as i64).contains(&at[2]);
                let at = [
                    at[0].rem_euclid(n[0] as i64) as usize,
                    layer,
                    at[2].rem_euclid(n[2] as i64) as usize,
                ];
                let expect_present = wrap || inside;
                assert_eq!(
                    s.counts()[2],
                    u64::from(expect_present),
                    "layer {layer} step {step}"
                );
                if expect_present {
                    assert!(get(&s, 2, at), "layer {layer} step {step}: not at {at:?}");
                }
            }
        }
    }
    // A cell near the +x edge: clipped it leaves, wrapped it comes in at the other side.
    for wrap in [false, true] {
        let mut s = empty(n, 1);
        set(&mut s, 2, [129, 0, 6], true);
        s = s.step(&Probabilities::none(), &wind(wrap));
        assert_eq!(s.counts()[2], u64::from(wrap));
        if wrap {
            assert!(get(&s, 2, [1, 0, 5]));
        }
    }
}

#[test]
fn same_seed_gives_the_same_frames_on_one_and_two_threads() {
    let n = [96, 8, 20];
    let regions: Vec<f32> = each_cell(n)
        .map(|[i, j, k]| {
            ellipsoid_profile(
                [i as f64, j as f64, k as f64],
                [48.0, 3.0, 10.0],
                [40.0, 5.0, 9.0],
            ) as f32
        })
        .collect();
    let planes = Planes::new(n);
    let p = Probabilities {
        hum: Probability::from_cells(
            &planes,
            &regions.iter().map(|v| 0.2 * v).collect::<Vec<_>>(),
        ),
        act: Probability::from_cells(
            &planes,
            &regions.iter().map(|v| 0.01 * v).collect::<Vec<_>>(),
        ),
        ext: Probability::from_cells(
            &planes,
            &regions.iter().map(|v| 0.1 * (1.0 - v)).collect::<Vec<_>>(),
        ),
    };
    let wind = Wind {
        bottom: [0.5, 0.0],
        top: [1.5, 0.25],
        wrap: false,
    };
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut s = random_state(n, 42, 0.3, 0.002, 0.0);
            let mut frames = Vec::new();
            for _ in 0..10 {
                s = s.step(&p, &wind);
                let density = SmoothedCloud::new(
                    s.domain.clone(),
                    s.planes,
                    s.cloud_frames(2),
                    Smoothing {
                        radius: 1,
                        window: 1,
                    },
                );
                let sum: f64 = each_cell(n).map(|[i, j, k]| density.at_cell(i, j, k)).sum();
                frames.push((
                    (*s.hum).clone(),
                    (*s.act).clone(),
                    (*s.cld).clone(),
                    sum.to_bits(),
                ));
            }
            frames
        })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert!(
        one.last().unwrap().2.iter().any(|w| *w != 0),
        "no clouds formed"
    );
    // A frame recomputed alone from its predecessor is the same frame.
}

#[test]
fn a_frame_is_recomputed_from_its_predecessor_alone() {
    let n = [64, 4, 8];
    let p = Probabilities {
        hum: Probability::uniform(0.1),
        act: Probability::uniform(0.01),
        ext: Probability::uniform(0.05),
    };
    let mut s = random_state(n, 7, 0.4, 0.01, 0.0);
    for _ in 0..5 {
        s = s.step(&p, &Wind::CALM);
    }
    // Only the bits, the step number and the seed carry over.
    let copy = CloudState {
        history: Vec::new(),
        ..s.clone()
    };
    let (a, b) = (s.step(&p, &Wind::CALM), copy.step(&p, &Wind::CALM));
    assert_eq!((&a.hum, &a.act, &a.cld), (&b.hum, &b.act, &b.cld));
}

#[test]
fn smoothing_follows_its_weights() {
    let n = [9, 9, 9];
    let mut s = empty(n, 1);
    set(&mut s, 2, [4, 4, 4], true);
    let d = SmoothedCloud::new(
        s.domain.clone(),
        s.planes,
        s.cloud_frames(1),
        Smoothing {
            radius: 1,
            window: 0,
        },
    );
    // Tent weights 1, 2, 1 along each axis: the window sums to 4³ = 64.
    assert_eq!(d.at_cell(4, 4, 4), 8.0 / 64.0);
    assert_eq!(d.at_cell(5, 4, 4), 4.0 / 64.0);
    assert_eq!(d.at_cell(5, 3, 5), 1.0 / 64.0);
    assert_eq!(d.at_cell(6, 4, 4), 0.0);
    // A field full of cloud is 1 inside, whatever the radius and window.
    let full = random_state(n, 1, 0.0, 0.0, 1.0);
    let stepped = full.step(&Probabilities::none(), &Wind::CALM);
    for (radius, window) in [(1, 0), (2, 1), (3, 1)] {
        let d = SmoothedCloud::new(
            full.domain.clone(),
            full.planes,
            stepped.cloud_frames(window + 1),
            Smoothing { radius, window },
        );
        assert!((d.at_cell(4, 4, 4) - 1.0).abs() < 1e-12);
    }
    // Over time: the newest frame weighs 2, the one before 1 (window 1).
    let later = s.step(
        &Probabilities {
            ext: Probability::uniform(1.0),
            ..Probabilities::none()
        },
        &Wind::CALM,
    );
    let d = SmoothedCloud::new(
        later.domain.clone(),
        later.planes,
        later.cloud_frames(2),
        Smoothing {
            radius: 1,
            window: 1,
        },
    );
    assert_eq!(d.at_cell(4, 4, 4), 8.0 / (64.0 * 3.0));
    // Ranges: certainly zero far from the cloud, possibly non-zero over it.
    use crate::space::Aabb;
    let far = Aabb::new(DVec3::ZERO, DVec3::splat(1.9));
    assert_eq!(d.range(&far), vec![(0.0, 0.0)]);
    let near = Aabb::new(DVec3::splat(3.1), DVec3::splat(3.9));
    assert_eq!(d.range(&near), vec![(0.0, 1.0)]);
}

#[test]
fn row_shifts_match_a_cell_by_cell_shift() {
    for nx in [1usize, 5, 63, 64, 65, 130] {
        let planes = Planes::new([nx, 1, 1]);
        let mut row = vec![0u64; planes.words];
        let bits: Vec<bool> = (0..nx).map(|i| (i * 7 + 3) % 5 < 2).collect();
        for (i, b) in bits.iter().enumerate() {
            planes.set(&mut row, i, 0, 0, *b);
        }
        for s in [-131i64, -65, -64, -3, -1, 0, 1, 2, 63, 64, 66, 200] {
            for wrap in [false, true] {
                let mut out = vec![0u64; planes.words];
                planes.shift_row(&row, s, wrap, &mut out);
                for x in 0..nx {
                    let from = x as i64 - s;
                    let expected = if wrap {
                        bits[from.rem_euclid(nx as i64) as usize]
                    } else {
                        (0..nx as i64).contains(&from) && bits[from as usize]
                    };
                    assert_eq!(
                        planes.get(&out, x, 0, 0),
                        expected,
                        "nx {nx} s {s} wrap {wrap} x {x}"
                    );
                }
                assert_eq!(out[planes.words - 1] & !planes.mask(planes.words - 1), 0);
            }
        }
    }
}

#[test]
fn smoothing_a_box_equals_smoothing_cell_by_cell() {
    let n = [70, 9, 11];
    let mut s = random_state(n, 4, 0.0, 0.0, 0.3);
    for _ in 0..3 {
        s = s.step(
            &Probabilities {
                ext: Probability::uniform(0.5),
                ..Probabilities::none()
            },
            &Wind::CALM,
        );
    }
    // Windows of up to 15 bits over all frames take one table lookup per cell; (3, 2) and
    // (2, 3) are wider and take one per frame.
    for (radius, window) in [(0, 0), (1, 1), (2, 2), (3, 1), (3, 2), (2, 3)] {
        let d = SmoothedCloud::new(
            s.domain.clone(),
            s.planes,
            s.cloud_frames(window + 1),
            Smoothing { radius, window },
        );
        // A box at the far edge, and the whole domain (rows longer than one word's chunk).
        for (lo, hi) in [([60, 2, 0], [70, 9, 6]), ([0, 0, 0], n)] {
            let (mut out, mut sums) = (Vec::new(), super::smooth::Sums::default());
            d.fill_box(lo, hi, &mut out, &mut sums);
            let mut at = 0;
            for k in lo[2]..hi[2] {
                for j in lo[1]..hi[1] {
                    for i in lo[0]..hi[0] {
                        assert_eq!(
                            out[at].to_bits(),
                            d.at_cell(i, j, k).to_bits(),
                            "r {radius} cell {i} {j} {k}"
                        );
                        at += 1;
                    }
                }
            }
        }
    }
}

#[test]
fn a_cache_of_the_smoothed_cloud_holds_its_cells_values() {
    let n = [70, 9, 11];
    let s = random_state(n, 5, 0.0, 0.0, 0.2);
    let d = Arc::new(SmoothedCloud::new(
        s.domain.clone(),
        s.planes,
        s.cloud_frames(2),
        Smoothing {
            radius: 2,
            window: 1,
        },
    ));
    let cache = Cache::from_source(
        s.domain.clone(),
        1,
        d.clone(),
        vec![0.0],
        "clouddensity",
        "test".into(),
    )
    .unwrap();
    cache.fill_all();
    let mut filled = 0;
    for k in 0..n[2] {
        for j in 0..n[1] {
            for i in 0..n[0] {
                let stored = cache.value_at_cell(i, j, k).expect("inside")[0];
                let expected = d.at_cell(i, j, k) as f32;
                assert_eq!(stored.to_bits(), expected.to_bits(), "cell {i} {j} {k}");
                filled += (stored > 0.0) as usize;
            }
        }
    }
    assert!(filled > 100, "the test cloud has density ({filled} cells)");
}
