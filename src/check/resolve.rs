//! Matching a call's arguments against a builtin's forms, and saying what is wrong when none
//! fits. The checker and the interpreter both call it, so `felt check` and `felt run` report
//! a bad call with the same words at the same place.
//!
//! The one key decision: when no form fits, each form is matched to the end and its problems
//! counted, and the form with the fewest is the one the author meant. Its first problem is the
//! message, pointing at the argument (or keyword) that did not fit, and the help shows that
//! one form, never the whole list: a TD who wrote `render(..., samples = 4)` wants to read
//! "`render` has no argument `samples`; did you mean `spp`?", not every form of `render`. The
//! form's other problems come with it, so the checker reports every bad argument of a call at
//! once rather than one per run.

use super::signature::{Builtin, Param, ParamType, Signature, format_signature};
use super::types::Type;
use crate::base::failure::Failure;
use crate::base::suggest;
use crate::syntax::ast::Arg;
use crate::syntax::span::Span;

/// Result of matching call arguments against a builtin's signatures.
pub enum Resolution {
    /// Signature index and, for each parameter, which argument fills it (`None`: not given);
    /// then the indices of the variadic arguments.
    Match {
        form: usize,
        slots: Vec<Option<usize>>,
        rest: Vec<usize>,
    },
    /// No form fits; the message says why, pointing at `at`. `others` are the closest form's
    /// further problems, each its own error.
    Mismatch {
        message: String,
        at: Culprit,
        help: Option<String>,
        others: Vec<Problem>,
    },
}

/// What a mismatch points at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Culprit {
    /// The call as a whole (an argument is missing).
    Call,
    /// Argument `i`, name and value.
    Arg(usize),
    /// The keyword of argument `i` (no parameter has that name).
    Keyword(usize),
}

impl Culprit {
    /// The span to show, given the call's arguments and the span of the whole call.
    pub fn span(self, args: &[Arg], call: Span) -> Span {
        match self {
            Culprit::Call => call,
            Culprit::Arg(i) => args.get(i).map_or(call, |a| a.span),
            Culprit::Keyword(i) => args
                .get(i)
                .map(|a| a.name.as_ref().map_or(a.span, |n| n.span))
                .unwrap_or(call),
        }
    }
}

/// One reason a form does not fit, and its fix where one is likely.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    pub message: String,
    pub at: Culprit,
    pub help: Option<String>,
}

/// The fix for a cache given where a field is expected: a cache is storage, and `cacheread`
/// is the field that reads it (docs/language.md, "Caches").
pub fn cache_hint(found: &Type, expected: &Type) -> Option<String> {
    let shape = found.cache_shape()?;
    expected.is_field().then(|| {
        format!(
            "a {found} is storage, not a field; read it as a {} with `cacheread(c)`, c being \
             the cache",
            Type::field_of(shape)
        )
    })
}

/// Matches positional and keyword arguments (`names[i]` is the keyword of argument `i`, if
/// any) against the builtin's forms.
pub fn resolve(builtin: &Builtin, types: &[Type], names: &[Option<String>]) -> Resolution {
    let name = builtin.name;
    // Wrong whatever the form, so said before trying them (otherwise a builtin with several
    // forms could only answer with the form that failed least).
    if let Some((arg, keyword)) = repeated_keyword(names) {
        return Resolution::Mismatch {
            message: format!("argument `{keyword}` of `{name}` is given twice"),
            at: Culprit::Arg(arg),
            help: Some(format!("remove one of the two `{keyword} = ...`")),
            others: Vec::new(),
        };
    }
    // Keywords no form has are problems whatever the form; the forms are then matched
    // without them, so the other arguments' problems are found in the same pass.
    let unknown = unknown_keywords(builtin, names);
    let skip: Vec<bool> = (0..names.len())
        .map(|i| unknown.iter().any(|p| p.at == Culprit::Keyword(i)))
        .collect();
    let mut closest: Option<(usize, Vec<Problem>)> = None;
    for (form, sig) in builtin.signatures.iter().enumerate() {
        match match_signature(name, sig, types, names, &skip) {
            Ok((slots, rest)) if unknown.is_empty() => {
                return Resolution::Match { form, slots, rest };
            }
            Ok(_) => {
                closest = Some((form, Vec::new()));
                break;
            }
            Err(problems) => {
                if closest
                    .as_ref()
                    .is_none_or(|(_, best)| problems.len() < best.len())
                {
                    closest = Some((form, problems));
                }
            }
        }
    }
    if !unknown.is_empty() {
        let mut problems = unknown;
        problems.extend(closest.map(|(_, p)| p).unwrap_or_default());
        let others = problems.split_off(1);
        let first = problems.remove(0);
        return Resolution::Mismatch {
            message: first.message,
            at: first.at,
            help: first.help,
            others,
        };
    }
    let Some((form, mut problems)) = closest else {
        return Resolution::Mismatch {
            message: format!("`{name}` has no forms"),
            at: Culprit::Call,
            help: None,
            others: Vec::new(),
        };
    };
    let others = problems.split_off(1);
    let first = problems.remove(0);
    let shown = format_signature(name, &builtin.signatures[form]);
    let mut help = if builtin.signatures.len() == 1 {
        format!("`{shown}`: {}", builtin.doc)
    } else {
        format!(
            "the closest of its {} forms is `{shown}`",
            builtin.signatures.len()
        )
    };
    if !others.is_empty() {
        let more = others.len();
        help.push_str(&format!(
            " ({more} more argument{} do{} not fit it either)",
            if more == 1 { "" } else { "s" },
            if more == 1 { "es" } else { "" }
        ));
    }
    if let Some(fix) = first.help {
        help = format!("{fix}\n{help}");
    }
    Resolution::Mismatch {
        message: first.message,
        at: first.at,
        help: Some(help),
        others,
    }
}

/// The first keyword argument whose keyword an earlier argument already used: its index and
/// the keyword.
fn repeated_keyword(names: &[Option<String>]) -> Option<(usize, &str)> {
    let mut seen = std::collections::HashSet::new();
    names.iter().enumerate().find_map(|(i, name)| {
        let name = name.as_deref()?;
        (!seen.insert(name)).then_some((i, name))
    })
}

/// Every keyword that no form of the builtin has, each with the likely one meant: a parameter
/// of a similar spelling, or one that other tools' users call by that name (`samples` for
/// `spp`).
fn unknown_keywords(builtin: &Builtin, names: &[Option<String>]) -> Vec<Problem> {
    let params = all_params(builtin);
    let listed: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
    names
        .iter()
        .enumerate()
        .filter_map(|(i, n)| {
            let keyword = n.as_deref()?;
            if params.iter().any(|p| p.name == keyword) {
                return None;
            }
            let meant = params
                .iter()
                .find(|p| p.aliases.contains(&keyword))
                .map(|p| p.name.as_str())
                .or_else(|| suggest::closest(keyword, params.iter().map(|p| p.name.as_str())));
            let hint = meant
                .map(|m| format!("; did you mean `{m}`?"))
                .unwrap_or_default();
            Some(Problem {
                message: format!("`{}` has no argument `{keyword}`{hint}", builtin.name),
                at: Culprit::Keyword(i),
                help: Some(format!(
                    "the arguments of `{}` are {}",
                    builtin.name,
                    listed.join(", ")
                )),
            })
        })
        .collect()
}

/// Every parameter of every form, each name once, in the order the forms give them.
fn all_params(builtin: &Builtin) -> Vec<&Param> {
    let mut params: Vec<&Param> = Vec::new();
    for sig in &builtin.signatures {
        for p in &sig.params {
            if !params.iter().any(|q| q.name == p.name) {
                params.push(p);
            }
        }
    }
    params
}

type Matched = (Vec<Option<usize>>, Vec<usize>);

/// Fits the arguments to one form, or lists every reason it does not fit.
fn match_signature(
    name: &str,
    sig: &Signature,
    types: &[Type],
    names: &[Option<String>],
    skip: &[bool],
) -> Result<Matched, Vec<Problem>> {
    let mut slots: Vec<Option<usize>> = vec![None; sig.params.len()];
    let mut rest = Vec::new();
    let mut problems = Vec::new();
    let mut position = 0;
    let mut overflow = false;
    for (i, ty) in types.iter().enumerate() {
        if skip[i] {
            continue;
        }
        match &names[i] {
            None if position < sig.params.len() => {
                slots[position] = Some(i);
                position += 1;
            }
            None => match &sig.variadic {
                Some(v) if v.accepts(ty) => rest.push(i),
                Some(v) => problems.push(Problem {
                    message: format!("argument {} of `{name}` must be {v}, found {ty}", i + 1),
                    at: Culprit::Arg(i),
                    help: exact(v).and_then(|v| cache_hint(ty, v)),
                }),
                None if !overflow => {
                    overflow = true;
                    let most = sig.params.len();
                    problems.push(Problem {
                        message: format!(
                            "`{name}` takes {most} argument{}, found {}",
                            plural(most),
                            types.len()
                        ),
                        at: Culprit::Arg(i),
                        help: None,
                    });
                }
                None => {}
            },
            Some(keyword) => match sig.param_index(keyword) {
                Some(p) if slots[p].is_some() => problems.push(Problem {
                    message: format!(
                        "argument `{keyword}` of `{name}` is given twice, by position and by keyword"
                    ),
                    at: Culprit::Arg(i),
                    help: None,
                }),
                Some(p) => slots[p] = Some(i),
                None => problems.push(Problem {
                    message: format!("this form of `{name}` has no argument `{keyword}`"),
                    at: Culprit::Keyword(i),
                    help: None,
                }),
            },
        }
    }
    for (param, slot) in sig.params.iter().zip(&slots) {
        match *slot {
            None if !param.optional => problems.push(Problem {
                message: format!(
                    "`{name}` is missing its argument `{}` ({})",
                    param.name, param.ty
                ),
                at: Culprit::Call,
                help: None,
            }),
            Some(i) if !param.ty.accepts(&types[i]) => problems.push(Problem {
                message: format!(
                    "argument `{}` of `{name}` must be {}, found {}",
                    param.name, param.ty, types[i]
                ),
                at: Culprit::Arg(i),
                help: exact(&param.ty).and_then(|t| cache_hint(&types[i], t)),
            }),
            _ => {}
        }
    }
    if problems.is_empty() {
        Ok((slots, rest))
    } else {
        Err(problems)
    }
}

/// The one type a parameter takes, if it takes one.
fn exact(ty: &ParamType) -> Option<&Type> {
    match ty {
        ParamType::Exact(t) => Some(t),
        _ => None,
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

/// Checks a string argument against its parameter's fixed set of values, if it has one.
pub fn check_choice(param: &Param, value: &str) -> Result<(), Failure> {
    let Some(choices) = &param.choices else {
        return Ok(());
    };
    if choices.values.contains(&value) {
        return Ok(());
    }
    let hint = suggest::closest(value, choices.values.iter().copied())
        .map(|s| format!("; did you mean \"{s}\"?"))
        .unwrap_or_default();
    let quoted: Vec<String> = choices.values.iter().map(|v| format!("\"{v}\"")).collect();
    let listed = match quoted.split_last() {
        Some((last, [])) => last.clone(),
        Some((last, init)) => format!("{} or {last}", init.join(", ")),
        None => String::new(),
    };
    Err(
        Failure::new(format!("unknown {} \"{value}\"{hint}", choices.noun))
            .with_help(format!("`{}` takes {listed}", param.name)),
    )
}
