//! Blackbody colours against independent integrations and published chromaticities.

use super::*;

fn chromaticity(t: f64) -> (f64, f64) {
    let v = xyz(t);
    let sum = v.x + v.y + v.z;
    (v.x / sum, v.y / sum)
}

/// CIE illuminant A is by definition a Planckian radiator at 2856 K; CIE 15:2004 table T.3
/// publishes its chromaticity as x, y = 0.44757, 0.40745.
#[test]
fn illuminant_a_chromaticity_is_the_published_one() {
    let (x, y) = chromaticity(2856.0);
    assert!(
        (x - 0.44757).abs() < 1e-4 && (y - 0.40745).abs() < 1e-4,
        "{x} {y}"
    );
}

/// Values computed with the colour-science Python package 0.4.7 (`colour.sd_blackbody` on
/// 360–830 nm at 1 nm, summed against its own 1 nm CIE 1931 table by
/// `colour.sd_to_XYZ(method="Integration", k=1)`, then its BT.709 matrix): a different table
/// resolution and quadrature from felt's 5 nm trapezoid. Columns: T, x, y, linear Rec.709
/// normalised to Y = 1, and Y in W·sr⁻¹·m⁻².
const COLOUR_SCIENCE: [(f64, [f64; 2], [f64; 3], f64); 9] = [
    (
        800.0,
        [0.681336, 0.317930],
        [5.406996, -0.201065, -0.082318],
        1.183865e-05,
    ),
    (
        1000.0,
        [0.652753, 0.344460],
        [4.600238, 0.039582, -0.090005],
        3.932575e-03,
    ),
    (
        1500.0,
        [0.585721, 0.393120],
        [3.264599, 0.434099, -0.064201],
        1.132983e+01,
    ),
    (
        1900.0,
        [0.537781, 0.411201],
        [2.639385, 0.613519, -0.000084],
        3.538352e+02,
    ),
    (
        2856.0,
        [0.447539, 0.407429],
        [1.845154, 0.826099, 0.233378],
        2.891202e+04,
    ),
    (
        4000.0,
        [0.380442, 0.376749],
        [1.414015, 0.924003, 0.533401],
        3.701034e+05,
    ),
    (
        6504.0,
        [0.313465, 0.323569],
        [1.043062, 0.983605, 1.035580],
        4.509545e+06,
    ),
    (
        10000.0,
        [0.280634, 0.288289],
        [0.871965, 0.994596, 1.430659],
        1.941412e+07,
    ),
    (
        12000.0,
        [0.271785, 0.277564],
        [0.826560, 0.994374, 1.566587],
        3.139571e+07,
    ),
];

#[test]
fn colours_match_an_independent_integration() {
    for (t, xy, rgb, y) in COLOUR_SCIENCE {
        let (x1, y1) = chromaticity(t);
        assert!(
            (x1 - xy[0]).abs() < 1e-4 && (y1 - xy[1]).abs() < 1e-4,
            "{t} K: {x1} {y1}"
        );
        let ours = blackbody(t, true);
        let error = (ours - DVec3::from_array(rgb)).abs().max_element();
        assert!(error < 1e-3 * rgb[0], "{t} K: {ours} vs {rgb:?}");
        let absolute = blackbody(t, false);
        assert!(
            (xyz(t).y / y - 1.0).abs() < 1e-3,
            "{t} K: Y {} vs {y}",
            xyz(t).y
        );
        assert!((absolute - ours * xyz(t).y).length() <= 1e-12 * absolute.length());
    }
}

/// colour-science's `RGB_COLOURSPACES["ITU-R BT.709"].matrix_XYZ_to_RGB`.
#[test]
fn rec709_matrix_is_the_one_derived_from_the_primaries() {
    let expected = [
        [3.240969941904522, -1.537383177570094, -0.49861076029300344],
        [-0.9692436362808798, 1.8759675015077206, 0.04155505740717563],
        [
            0.05563007969699364,
            -0.20397695888897655,
            1.0569715142428786,
        ],
    ];
    let m = xyz_to_rec709();
    for (r, row) in expected.iter().enumerate() {
        for (c, &v) in row.iter().enumerate() {
            assert!((m.col(c)[r] - v).abs() < 1e-12, "{r} {c}: {}", m.col(c)[r]);
        }
    }
}

/// The field table against the exact integration, at temperatures between its nodes over the
/// whole glowing range: the worst error is the figure the module documentation quotes.
#[test]
fn table_is_within_1e5_of_the_exact_colour() {
    let (normal, absolute) = (BlackbodyTable::shared(true), BlackbodyTable::shared(false));
    let (mut worst, mut worst_relative) = (0.0f64, 0.0f64);
    let mut t = COLDEST;
    while t < 2e5 {
        let exact = blackbody(t, true);
        worst = worst.max((normal.at(t).0 - exact).abs().max_element());
        let y = xyz(t).y;
        let relative = (absolute.at(t).0 - exact * y).abs().max_element() / y;
        worst_relative = worst_relative.max(relative);
        t *= 1.000_37;
    }
    assert!(worst < 1e-5, "largest error {worst}");
    assert!(
        worst_relative < 1e-5,
        "largest relative error {worst_relative}"
    );
}

#[test]
fn cold_negative_and_undefined_temperatures_are_black() {
    for t in [
        799.9,
        300.0,
        0.0,
        -5.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ] {
        for normalize in [true, false] {
            assert_eq!(blackbody(t, normalize), DVec3::ZERO, "{t}");
            assert_eq!(
                BlackbodyTable::shared(normalize).at(t),
                (DVec3::ZERO, DVec3::ZERO)
            );
        }
    }
    let hottest = blackbody(1e300, false);
    assert!(hottest.is_finite() && hottest == blackbody(HOTTEST, false));
}

/// The table's derivative in T against central differences of its own values.
#[test]
fn derivative_matches_differences() {
    for normalize in [true, false] {
        let table = BlackbodyTable::shared(normalize);
        for t in [900.0, 1733.3, 5000.5, 40_000.7] {
            let h = t * 1e-7;
            let difference = (table.at(t + h).0 - table.at(t - h).0) / (2.0 * h);
            let derivative = table.at(t).1;
            let scale = difference.abs().max_element();
            assert!(
                (derivative - difference).abs().max_element() < 1e-4 * scale,
                "{t} K: {derivative} vs {difference}"
            );
        }
    }
}

/// Every value read inside a region lies in the range the table reports for it.
#[test]
fn ranges_hold_the_values_inside() {
    for normalize in [true, false] {
        let table = BlackbodyTable::shared(normalize);
        for (lo, hi) in [
            (500.0, 900.0),
            (1000.0, 1400.0),
            (3000.0, 30000.0),
            (900.0, 901.0),
        ] {
            let region = Aabb::new(DVec3::new(lo, 0.0, 0.0), DVec3::new(hi, 0.0, 0.0));
            let range = table.range(&region);
            for k in 0..=200 {
                let t = lo + (hi - lo) * k as f64 / 200.0;
                let v = table.at(t).0;
                for (c, &(low, high)) in range.iter().enumerate() {
                    let slack = 1e-12 * high.abs().max(low.abs());
                    assert!(
                        v[c] >= low - slack && v[c] <= high + slack,
                        "{t} K channel {c}: {} outside ({low}, {high})",
                        v[c]
                    );
                }
            }
        }
    }
}
