//! Resolving calls against the real builtins' signatures: which form is chosen, and how a
//! call that fits none is explained. Here, beside the registry, because the checker's
//! resolver is tested with the interpreter's builtins.

use crate::check::resolve::*;
use crate::check::types::Type;
use crate::interp::registry::registry;

fn mismatch(builtin: &str, types: &[Type], names: &[Option<&str>]) -> (String, Culprit, String) {
    let builtin = registry().get(builtin).unwrap();
    let names: Vec<Option<String>> = names.iter().map(|n| n.map(String::from)).collect();
    match resolve(builtin, types, &names) {
        Resolution::Mismatch {
            message, at, help, ..
        } => (message, at, help.unwrap_or_default()),
        Resolution::Match { .. } => panic!("resolved"),
    }
}

#[test]
fn a_keyword_given_twice_is_named_whatever_the_forms() {
    let render = registry().get("render").unwrap();
    assert!(render.signatures.len() > 1);
    let (message, at, _) = mismatch(
        "render",
        &[Type::Str, Type::ScalarField, Type::ScalarField],
        &[None, Some("density"), Some("density")],
    );
    assert_eq!(message, "argument `density` of `render` is given twice");
    assert_eq!(at, Culprit::Arg(2));
}

#[test]
fn an_unknown_keyword_is_named_with_the_one_meant() {
    let types = [Type::Str, Type::ScalarField, Type::Camera, Type::Int];
    let (message, at, help) = mismatch(
        "render",
        &types,
        &[None, None, Some("camera"), Some("samples")],
    );
    assert_eq!(
        message,
        "`render` has no argument `samples`; did you mean `spp`?"
    );
    assert_eq!(at, Culprit::Keyword(3));
    assert!(help.contains("spp"), "{help}");
    assert!(!help.contains("->"), "no form is listed: {help}");
    let (message, _, _) = mismatch(
        "render",
        &types,
        &[None, None, Some("camera"), Some("stpe")],
    );
    assert_eq!(
        message,
        "`render` has no argument `stpe`; did you mean `step`?"
    );
    let (message, _, _) = mismatch(
        "render",
        &types,
        &[None, None, Some("camera"), Some("zzzzzz")],
    );
    assert_eq!(message, "`render` has no argument `zzzzzz`");
}

#[test]
fn the_form_that_almost_fits_is_the_one_shown() {
    // Three forms of `clamp`-like arity; the vector argument fits no form, and the float
    // form fails on it alone.
    let (message, at, help) = mismatch(
        "clamp",
        &[Type::Float, Type::Float, Type::Vector],
        &[None, None, None],
    );
    assert_eq!(
        message,
        "argument `hi` of `clamp` must be float, found vector"
    );
    assert_eq!(at, Culprit::Arg(2));
    assert_eq!(
        help,
        "the closest of its 2 forms is `clamp(float x, float lo, float hi) -> float`"
    );
    // A field in first place: only the field form is one argument off.
    let (message, _, help) = mismatch(
        "clamp",
        &[Type::ScalarField, Type::Float, Type::Vector],
        &[None, None, None],
    );
    assert_eq!(
        message,
        "argument `hi` of `clamp` must be scalarfield, found vector"
    );
    assert!(help.contains("clamp(scalarfield x"), "{help}");
}

#[test]
fn a_missing_argument_is_named() {
    let (message, at, _) = mismatch("clamp", &[Type::Float, Type::Float], &[None, None]);
    assert_eq!(message, "`clamp` is missing its argument `hi` (float)");
    assert_eq!(at, Culprit::Call);
    let (message, _, _) = mismatch(
        "render",
        &[Type::Str, Type::ScalarField],
        &[None, Some("density")],
    );
    assert_eq!(
        message,
        "`render` is missing its argument `camera` (camera)"
    );
}

#[test]
fn a_positional_and_a_keyword_for_the_same_parameter_is_named() {
    let (message, at, _) = mismatch(
        "clamp",
        &[Type::Float, Type::Float, Type::Float, Type::Float],
        &[None, None, None, Some("lo")],
    );
    assert_eq!(
        message,
        "argument `lo` of `clamp` is given twice, by position and by keyword"
    );
    assert_eq!(at, Culprit::Arg(3));
}

#[test]
fn a_choice_outside_its_set_is_named_with_the_set() {
    let render = registry().get("render").unwrap();
    let shadows =
        &render.signatures[0].params[render.signatures[0].param_index("shadows").unwrap()];
    assert!(check_choice(shadows, "march").is_ok());
    let failure = check_choice(shadows, "mrach").unwrap_err();
    assert_eq!(
        failure.message,
        "unknown shadows mode \"mrach\"; did you mean \"march\"?"
    );
    assert_eq!(
        failure.help.as_deref(),
        Some("`shadows` takes \"cache\", \"march\" or \"sweep\"")
    );
}
