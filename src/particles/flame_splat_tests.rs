//! Tests of splatting a flame as it is made. The reference is the stored route, written
//! independently of the fused one: `chaos::generate` stores every dot, and `splat` bins and
//! adds them.

use super::chaos::{self, Map, Settings};
use super::flame_splat::{SplatInto, splat_flame};
use super::guide::{self, Guide};
use super::splat::{Deposit, Kernel, SplatReport, splat};
use super::tests::in_pool;
use super::{Particles, flame};
use crate::field::{CompiledField, Field, MathFn};
use crate::grid::cache::Cache;
use crate::space::FieldSampler;
use crate::space::domain::Domain;
use glam::DVec3;

/// Three flame maps (linear, swirl, spherical) with 3D pre-transforms, so dots fill a volume.
fn maps() -> Vec<CompiledField> {
    let pre = [
        [0.5, 0.0, 0.1, 0.5, 0.0, 0.5, 0.0, 0.3, 0.1, 0.0, 0.5, 0.0],
        [0.6, 0.3, 0.0, -0.2, -0.3, 0.6, 0.1, 0.1, 0.0, 0.2, 0.6, 0.1],
        [
            0.8, 0.1, 0.0, -0.1, 0.1, 0.8, 0.0, -0.2, 0.0, 0.0, 0.8, -0.3,
        ],
    ];
    ["linear", "swirl", "spherical"]
        .iter()
        .zip(pre)
        .map(|(name, c)| {
            let affine = flame::affine_from_coefficients(&c).unwrap();
            CompiledField::prepared(&flame::flame(name, &[], Some(affine), None).unwrap()).unwrap()
        })
        .collect()
}

fn settings<'a>(fields: &'a [CompiledField], color: Option<&'a CompiledField>) -> Settings<'a> {
    let colors = [
        DVec3::new(1.0, 0.6, 0.3),
        DVec3::new(0.3, 0.5, 1.0),
        DVec3::new(0.9, 0.9, 1.0),
    ];
    Settings {
        maps: fields
            .iter()
            .zip([1.0, 1.0, 0.5])
            .zip(colors)
            .map(|((f, weight), color)| Map {
                field: f as &dyn FieldSampler,
                weight,
                color,
            })
            .collect(),
        displace: None,
        amount: 0.0,
        color: color.map(|c| c as &dyn FieldSampler),
        iterations: 200,
        skip: 10,
    }
}

fn guides() -> Vec<Guide> {
    let mut set = Particles::new(vec![[0.0; 3], [0.4, -0.2, 0.1]]);
    set.set("scale", super::Values::Float(vec![1.0, 0.5]))
        .unwrap();
    guide::guides(&set).unwrap()
}

/// A domain of 20 cells on a side (three bricks, the last partial) that cuts through the
/// flame, so some dots fall outside and many stencils cross brick faces.
fn domain() -> Domain {
    Domain::with_cells(
        DVec3::new(-1.0, -0.9, -0.8),
        DVec3::splat(1.6),
        DVec3::ZERO,
        0.08,
        0.08,
    )
    .unwrap()
}

fn bits(cache: &Cache) -> Vec<([usize; 3], Vec<u32>)> {
    cache
        .cells()
        .map(|(c, v)| (c, v.iter().map(|x| x.to_bits()).collect()))
        .collect()
}

fn into<'a>(
    domain: &'a Domain,
    kernel: Kernel,
    background: &'a [f64],
    previous: Option<&'a Cache>,
) -> SplatInto<'a> {
    SplatInto {
        domain,
        kernel,
        background,
        previous,
    }
}

const DOTS: usize = 30_000;

/// The stored route: the dots, then their count and colour splatted.
fn stored(
    fields: &[CompiledField],
    kernel: Kernel,
    previous: Option<&Cache>,
) -> (Cache, Cache, SplatReport) {
    let d = domain();
    let (dots, _) = chaos::generate(&guides(), DOTS, 5, &settings(fields, None)).unwrap();
    let (count, report) = splat(&dots, Deposit::One, kernel, &d, &[0.25], previous).unwrap();
    let colors = dots.vectors("Cd").unwrap();
    let (color, _) = splat(&dots, Deposit::Vector(colors), kernel, &d, &[0.0; 3], None).unwrap();
    (count, color, report)
}

/// The fused route with the same arguments.
fn fused(
    fields: &[CompiledField],
    kernel: Kernel,
    previous: Option<&Cache>,
) -> (Cache, Cache, SplatReport) {
    let d = domain();
    let (mut caches, _) = splat_flame(
        &guides(),
        DOTS,
        5,
        &settings(fields, None),
        Some(&into(&d, kernel, &[0.25], previous)),
        Some(&into(&d, kernel, &[0.0; 3], None)),
    )
    .unwrap();
    let (color, _) = caches.pop().unwrap();
    let (count, report) = caches.pop().unwrap();
    (count, color, report)
}

#[test]
fn the_count_equals_the_stored_splat_bit_for_bit_and_the_colour_to_rounding() {
    let fields = maps();
    for kernel in [Kernel::Trilinear, Kernel::Nearest] {
        // Onto an earlier state, so kept and added bricks are both checked.
        let earlier = splat(
            &Particles::new(vec![[0.1, 0.1, 0.1], [-0.95, 0.65, 0.75]]),
            Deposit::One,
            Kernel::Nearest,
            &domain(),
            &[0.25],
            None,
        )
        .unwrap()
        .0;
        let (count, color, report) = stored(&fields, kernel, Some(&earlier));
        let (fused_count, fused_color, fused_report) = fused(&fields, kernel, Some(&earlier));
        assert!(
            report.outside > 100 && report.splatted > 10_000,
            "{report:?}"
        );
        assert_eq!(
            (fused_report.splatted, fused_report.outside),
            (report.splatted, report.outside)
        );
        // The fused total is the integer sum itself: exactly the dots inside.
        assert_eq!(fused_report.total[0], report.splatted as f64);
        assert_eq!(bits(&fused_count), bits(&count), "{kernel:?}");
        // Without a colour cache the count has a table of its own: the same bits.
        let d = domain();
        let (alone, _) = splat_flame(
            &guides(),
            DOTS,
            5,
            &settings(&fields, None),
            Some(&into(&d, kernel, &[0.25], Some(&earlier))),
            None,
        )
        .unwrap();
        assert_eq!(bits(&alone[0].0), bits(&count), "{kernel:?}");
        let cells: Vec<_> = color.cells().collect();
        let fused_cells: Vec<_> = fused_color.cells().collect();
        assert_eq!(cells.len(), fused_cells.len());
        let mut differ = 0;
        for ((at, a), (fused_at, b)) in cells.iter().zip(&fused_cells) {
            assert_eq!(at, fused_at);
            for c in 0..3 {
                let tolerance = 1e-6 * a[c].abs().max(1.0);
                assert!((a[c] - b[c]).abs() <= tolerance, "{at:?}: {a:?} {b:?}");
                differ += (a[c] != b[c]) as usize;
            }
        }
        // Only the fixed-point scale differs, so almost every cell is the same float.
        assert!(
            differ * 20 < cells.len() * 3,
            "{differ} of {}",
            cells.len() * 3
        );
    }
}

#[test]
fn the_fused_splat_is_bit_identical_for_any_thread_count() {
    let fields = maps();
    let one = in_pool(1, || fused(&fields, Kernel::Trilinear, None));
    for threads in [2, 3] {
        let many = in_pool(threads, || fused(&fields, Kernel::Trilinear, None));
        assert_eq!(bits(&many.0), bits(&one.0));
        assert_eq!(bits(&many.1), bits(&one.1));
        assert_eq!(many.2, one.2);
    }
}

#[test]
fn a_colour_field_is_bounded_by_its_range_or_refused() {
    let fields = maps();
    let d = domain();
    // sin is bounded: the fused splat takes its range and matches the stored colours.
    let tint = Field::identity().math_each(MathFn::Sin).unwrap();
    let tint = CompiledField::prepared(&tint).unwrap();
    let (dots, _) = chaos::generate(&guides(), DOTS, 5, &settings(&fields, Some(&tint))).unwrap();
    let (color, _) = splat(
        &dots,
        Deposit::Vector(dots.vectors("Cd").unwrap()),
        Kernel::Trilinear,
        &d,
        &[0.0; 3],
        None,
    )
    .unwrap();
    let (caches, _) = splat_flame(
        &guides(),
        DOTS,
        5,
        &settings(&fields, Some(&tint)),
        None,
        Some(&into(&d, Kernel::Trilinear, &[0.0; 3], None)),
    )
    .unwrap();
    assert_eq!(caches.len(), 1);
    for ((_, a), (_, b)) in color.cells().zip(caches[0].0.cells()) {
        for c in 0..3 {
            assert!((a[c] - b[c]).abs() <= 1e-6 * a[c].abs().max(1.0));
        }
    }
    // The identity field has no finite range: refused, with the stored route as the help.
    let unbounded = CompiledField::prepared(&Field::identity()).unwrap();
    let failure = splat_flame(
        &guides(),
        100,
        5,
        &settings(&fields, Some(&unbounded)),
        None,
        Some(&into(&d, Kernel::Trilinear, &[0.0; 3], None)),
    )
    .unwrap_err();
    assert!(
        failure.message.contains("not finite"),
        "{}",
        failure.message
    );
}

#[test]
fn a_flame_splat_over_the_memory_budget_is_a_failure() {
    let fields = maps();
    let d = Domain::with_cells(
        DVec3::splat(-2.0),
        DVec3::splat(4.0),
        DVec3::ZERO,
        0.01,
        0.01,
    )
    .unwrap();
    let engine = crate::engine::Engine::with_memory_limit(4 << 20);
    let _entered = engine.enter();
    let failure = splat_flame(
        &guides(),
        DOTS,
        5,
        &settings(&fields, None),
        Some(&into(&d, Kernel::Trilinear, &[0.0], None)),
        None,
    )
    .unwrap_err();
    assert!(failure.message.contains("memory"), "{}", failure.message);
}
