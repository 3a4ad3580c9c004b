//! The keyword table against the language reference, and the rules between keywords.

use super::*;
use crate::render::settings::{Adaptive, Shadows};
use crate::render::transmittance::TransmissivityMethod;

#[test]
fn every_row_has_a_distinct_name_and_a_meaning() {
    let mut names: Vec<&str> = KEYWORDS.iter().map(|k| k.name).collect();
    names.sort();
    names.dedup();
    assert_eq!(names.len(), KEYWORDS.len());
    assert!(
        KEYWORDS
            .iter()
            .all(|k| !k.doc.is_empty() && !k.default.is_empty())
    );
}

/// The reference's table is this table: a keyword added here and not there fails.
#[test]
fn the_language_reference_lists_every_keyword_with_its_default() {
    let reference = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/docs/language.md"));
    let table = markdown_table();
    assert!(
        reference.contains(&table),
        "docs/language.md should hold render's keyword table as generated:\n{table}"
    );
}

#[test]
fn rules_between_keywords_hold_whatever_the_call_order() {
    let given = |pairs: Vec<(&'static str, Setting)>| {
        RenderOptions::from_keywords(false, |k| {
            Ok(pairs
                .iter()
                .find(|(name, _)| *name == k.name)
                .map(|(_, v)| v.clone()))
        })
    };
    // shadowcell after shadows in the call or before it: the table's order decides.
    let cell = given(vec![
        ("shadowcell", Setting::Float(0.1)),
        ("shadows", Setting::Str("sweep".into())),
    ])
    .unwrap();
    assert_eq!(
        cell.settings.shadows,
        Shadows::Cache {
            cell_size: Some(0.1),
            method: TransmissivityMethod::Sweep
        }
    );
    let Err(err) = given(vec![
        ("shadowcell", Setting::Float(0.1)),
        ("shadows", Setting::Str("march".into())),
    ]) else {
        panic!("shadowcell with shadows = \"march\" was accepted");
    };
    assert!(err.message.contains("no meaning"), "{}", err.message);
    assert!(given(vec![("sky", Setting::Vector(DVec3::ONE))]).is_err());
    assert!(given(vec![("adaptive", Setting::Bool(true))]).is_err());
    let adaptive = given(vec![
        ("adaptive", Setting::Bool(true)),
        ("step", Setting::Float(0.02)),
    ])
    .unwrap();
    assert_eq!(adaptive.settings.adaptive, Some(Adaptive::around(0.02)));
    let off = given(vec![("adaptive", Setting::Bool(false))]).unwrap();
    assert_eq!(off.settings.adaptive, None);
    assert!(given(vec![("gamma", Setting::Float(2.0))]).is_err());
}
