//! A study's plan: the settings to run (the cross product of the sweeps), and for each the
//! reference setting it is compared with.
//!
//! The one key decision: a setting's reference is the setting itself with the `--reference`
//! values applied. With one sweep that is the usual single reference; with two, say a method
//! and a frame count, `--reference method=fine` compares every method at each frame count
//! with the fine method at that same frame count. A `--reference` may also name a param that
//! is not swept (a finer `res` for the reference alone). Everything is checked against the
//! script's `param` declarations before anything runs.

use crate::base::suggest;
use crate::check::types::Type;
use crate::interp::parse_override;

/// `NAME=VALUE` pairs, in the order they are passed to `felt run --set`.
pub type Assignments = Vec<(String, String)>;

/// One `--sweep NAME=v1,v2,...`.
#[derive(Clone, Debug, PartialEq)]
pub struct Sweep {
    pub name: String,
    pub values: Vec<String>,
}

/// One point of the study: a value for each sweep, in sweep order.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    pub values: Vec<String>,
}

#[derive(Clone, Debug)]
pub struct Plan {
    pub sweeps: Vec<Sweep>,
    /// `--set` values, passed to every run.
    pub fixed: Assignments,
    /// `--reference` values, applied on top of a setting to make its reference.
    pub reference: Assignments,
    pub settings: Vec<Setting>,
    /// The sweep the Pareto fronts trade: one front is drawn per setting of the others.
    pub trade: usize,
}

impl Plan {
    /// What one run of `setting` passes to the script.
    pub fn assignments(&self, setting: &Setting) -> Assignments {
        let mut all = self.fixed.clone();
        for (sweep, value) in self.sweeps.iter().zip(&setting.values) {
            set(&mut all, &sweep.name, value);
        }
        all
    }

    /// What the reference run of `setting` passes to the script.
    pub fn reference_assignments(&self, setting: &Setting) -> Assignments {
        let mut all = self.assignments(setting);
        for (name, value) in &self.reference {
            set(&mut all, name, value);
        }
        all
    }

    /// `assignments` less the `--set` values every run shares (unless the reference changed
    /// them): what tells one reference from another.
    pub fn without_fixed(&self, assignments: &Assignments) -> Assignments {
        assignments
            .iter()
            .filter(|(n, v)| !self.fixed.iter().any(|(f, fv)| f == n && fv == v))
            .cloned()
            .collect()
    }

    /// What tells the Pareto fronts apart: the setting's values of every sweep but `except`,
    /// as "method=selma" ("" with one sweep). The plots key their colours by it.
    pub fn group(&self, setting: &Setting, except: usize) -> String {
        describe(
            &self
                .sweeps
                .iter()
                .zip(&setting.values)
                .enumerate()
                .filter(|(i, _)| *i != except)
                .map(|(_, (s, v))| (s.name.clone(), v.clone()))
                .collect::<Vec<_>>(),
        )
    }

    /// "n=4, method=bfecc": a setting as the table and messages show it.
    pub fn describe(&self, setting: &Setting) -> String {
        describe(
            &self
                .sweeps
                .iter()
                .zip(&setting.values)
                .map(|(s, v)| (s.name.clone(), v.clone()))
                .collect::<Vec<_>>(),
        )
    }
}

/// "a=1, b=2".
pub fn describe(assignments: &[(String, String)]) -> String {
    assignments
        .iter()
        .map(|(n, v)| format!("{n}={v}"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn set(all: &mut Assignments, name: &str, value: &str) {
    match all.iter_mut().find(|(n, _)| n == name) {
        Some(slot) => slot.1 = value.to_string(),
        None => all.push((name.to_string(), value.to_string())),
    }
}

/// Splits `v1,v2,...` at the commas outside parentheses, so vectors such as `(1,2,3)` stay whole.
pub fn split_values(text: &str) -> Vec<String> {
    let mut values = Vec::new();
    let mut depth = 0i32;
    let mut current = String::new();
    for c in text.chars() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            _ => {}
        }
        if c == ',' && depth <= 0 {
            values.push(current.trim().to_string());
            current.clear();
        } else {
            current.push(c);
        }
    }
    values.push(current.trim().to_string());
    values
}

/// Whether every value of `sweep` is a number: such a sweep is a knob to trade (a step, a
/// resolution, a frame count), where a sweep of names picks among methods or scenes.
fn numeric(sweep: &Sweep) -> bool {
    sweep.values.iter().all(|v| v.trim().parse::<f64>().is_ok())
}

/// Builds the plan and checks every name and value against the script's `params`. `trade`
/// names the sweep the Pareto fronts trade; by default the last numeric sweep, else the last.
pub fn plan(
    params: &[(String, Type)],
    sweeps: &[(String, String)],
    reference: &[(String, String)],
    fixed: &[(String, String)],
    trade: Option<&str>,
) -> Result<Plan, String> {
    let mut parsed = Vec::new();
    for (name, text) in sweeps {
        let values = split_values(text);
        if values.iter().all(|v| v.is_empty()) {
            return Err(format!(
                "--sweep {name}= has no values; give them as {name}=v1,v2,..."
            ));
        }
        if let Some(empty) = values.iter().position(|v| v.is_empty()) {
            return Err(format!(
                "--sweep {name}={text}: value {} is empty",
                empty + 1
            ));
        }
        if parsed.iter().any(|s: &Sweep| &s.name == name) {
            return Err(format!(
                "--sweep {name} is given twice; list all its values in one --sweep"
            ));
        }
        for value in &values {
            check_value(params, "--sweep", name, value)?;
        }
        parsed.push(Sweep {
            name: name.clone(),
            values,
        });
    }
    if parsed.is_empty() {
        return Err(String::from(
            "a study needs at least one --sweep NAME=v1,v2,...",
        ));
    }
    if reference.is_empty() {
        return Err(String::from(
            "a study needs a --reference NAME=VALUE: the setting every other is compared with",
        ));
    }
    for (name, value) in reference {
        check_value(params, "--reference", name, value)?;
    }
    for (name, value) in fixed {
        check_value(params, "--set", name, value)?;
        if parsed.iter().any(|s| &s.name == name) {
            return Err(format!(
                "{name} is both swept and fixed with --set; choose one"
            ));
        }
    }
    let trade = match trade {
        Some(name) => parsed.iter().position(|s| s.name == name).ok_or_else(|| {
            let swept: Vec<&str> = parsed.iter().map(|s| s.name.as_str()).collect();
            format!(
                "--trade {name}: the Pareto front trades a swept param; the swept params are: {}",
                swept.join(", ")
            )
        })?,
        None => parsed.iter().rposition(numeric).unwrap_or(parsed.len() - 1),
    };
    let mut settings = vec![Setting { values: Vec::new() }];
    for sweep in &parsed {
        settings = settings
            .into_iter()
            .flat_map(|s| {
                sweep.values.iter().map(move |v| {
                    let mut values = s.values.clone();
                    values.push(v.clone());
                    Setting { values }
                })
            })
            .collect();
    }
    Ok(Plan {
        sweeps: parsed,
        fixed: fixed.to_vec(),
        reference: reference.to_vec(),
        settings,
        trade,
    })
}

/// `name` is one of the script's params and `value` reads as its type.
fn check_value(
    params: &[(String, Type)],
    flag: &str,
    name: &str,
    value: &str,
) -> Result<(), String> {
    let Some((_, ty)) = params.iter().find(|(n, _)| n == name) else {
        let names: Vec<&str> = params.iter().map(|(n, _)| n.as_str()).collect();
        let help = match suggest::closest(name, names.iter().copied()) {
            Some(close) => format!("did you mean `{close}`?"),
            None if names.is_empty() => String::from("the script declares no params"),
            None => format!("the script's params are: {}", names.join(", ")),
        };
        return Err(format!(
            "{flag} {name}: the script has no param named `{name}`\n  help: {help}"
        ));
    };
    parse_override(value, ty)
        .map(|_| ())
        .map_err(|message| format!("{flag} {name}={value}: {message} (`{name}` is a {ty})"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> Vec<(String, Type)> {
        vec![
            (String::from("n"), Type::Int),
            (String::from("method"), Type::Str),
            (String::from("res"), Type::Int),
            (String::from("centre"), Type::Vector),
        ]
    }

    fn pair(n: &str, v: &str) -> (String, String) {
        (n.to_string(), v.to_string())
    }

    #[test]
    fn settings_are_the_cross_product_and_references_follow_them() {
        let plan = plan(
            &params(),
            &[pair("method", "a,b"), pair("n", "1,2,4")],
            &[pair("method", "fine"), pair("res", "256")],
            &[pair("res", "32")],
            None,
        )
        .unwrap();
        assert_eq!(plan.settings.len(), 6);
        let last = &plan.settings[5];
        assert_eq!(last.values, vec!["b", "4"]);
        assert_eq!(
            plan.assignments(last),
            vec![pair("res", "32"), pair("method", "b"), pair("n", "4")]
        );
        assert_eq!(
            plan.reference_assignments(last),
            vec![pair("res", "256"), pair("method", "fine"), pair("n", "4")]
        );
        assert_eq!(plan.describe(last), "method=b, n=4");
        // The numeric sweep is traded; the fronts are one per method.
        assert_eq!(plan.trade, 1);
        assert_eq!(plan.group(last, plan.trade), "method=b");
    }

    #[test]
    fn the_traded_sweep_defaults_to_the_last_numeric_one() {
        let refs = [pair("res", "256")];
        let two = [pair("n", "1,2"), pair("method", "a,b")];
        assert_eq!(plan(&params(), &two, &refs, &[], None).unwrap().trade, 0);
        assert_eq!(
            plan(&params(), &two, &refs, &[], Some("method"))
                .unwrap()
                .trade,
            1
        );
        let names = [pair("method", "a,b")];
        assert_eq!(plan(&params(), &names, &refs, &[], None).unwrap().trade, 0);
        let err = plan(&params(), &two, &refs, &[], Some("res")).unwrap_err();
        assert!(
            err.contains("--trade res") && err.contains("n, method"),
            "{err}"
        );
    }

    #[test]
    fn vectors_keep_their_commas() {
        assert_eq!(
            split_values("(1, 2, 3),(4,5,6)"),
            vec!["(1, 2, 3)", "(4,5,6)"]
        );
    }

    #[test]
    fn bad_names_values_and_empty_sweeps_are_refused() {
        let refs = [pair("n", "64")];
        let err = plan(&params(), &[pair("nn", "1")], &refs, &[], None).unwrap_err();
        assert!(err.contains("no param named `nn`") && err.contains("did you mean `n`?"));
        let err = plan(&params(), &[pair("n", "1,two")], &refs, &[], None).unwrap_err();
        assert!(err.contains("--sweep n=two: expected an int"), "{err}");
        let err = plan(&params(), &[pair("n", "")], &refs, &[], None).unwrap_err();
        assert!(err.contains("has no values"), "{err}");
        let err = plan(&params(), &[pair("n", "1,,2")], &refs, &[], None).unwrap_err();
        assert!(err.contains("value 2 is empty"), "{err}");
        let err = plan(&params(), &[pair("n", "1")], &[], &[], None).unwrap_err();
        assert!(err.contains("--reference"), "{err}");
        let err = plan(&params(), &[pair("n", "1")], &[pair("n", "x")], &[], None).unwrap_err();
        assert!(err.contains("--reference n=x"), "{err}");
        let err = plan(&params(), &[pair("n", "1")], &refs, &[pair("n", "2")], None).unwrap_err();
        assert!(err.contains("both swept and fixed"), "{err}");
    }
}
