//! The builtin registry: one table of (name, signatures, doc line, implementation) that the
//! checker, the interpreter, the REPL's completion and `felt doc` all read, so a builtin
//! cannot be documented one way and checked another. Later capabilities add builtins by
//! registering them here, nothing else.
//!
//! The key decision: the signatures belong to the checker (`crate::check::signature`), which
//! is handed them through its environment; this registry adds the implementations beside
//! them, so the interpreter depends on the checker and never the other way round.

use super::Interpreter;
use super::value::Value;
use crate::base::failure::Failure;
use std::collections::HashMap;
use std::fmt;
use std::ops::RangeInclusive;
use std::sync::OnceLock;

pub use crate::check::resolve::{Culprit, Resolution, check_choice, resolve};
pub use crate::check::signature::{
    Builtin, Choices, Param, ParamType, Signature, Signatures, format_signature,
};

/// The arguments of one builtin call, already converted to the matched signature's types and
/// put in parameter order (`None` for an optional parameter not given).
///
/// Builtins read them by parameter name only (`a.float("step")`), so the signature string is
/// the one place a parameter's position is written; there is no positional access to creep
/// back. Range checks live here too (`positive_float`, `float_in`, ...), so every builtin
/// words "out of range" the same way.
pub struct Args {
    values: Vec<Option<Value>>,
    /// The variadic arguments after the named ones (`print`, `format`).
    pub rest: Vec<Value>,
    /// Index of the signature that matched, for builtins whose forms differ in behaviour.
    pub form: usize,
    /// The matched signature, for reading arguments by name.
    pub signature: &'static Signature,
    /// The builtin called, for messages and for telling a misspelt name from one that only
    /// another form has.
    builtin: &'static Builtin,
}

impl Args {
    /// The arguments of a call to `builtin` that matched its form `form`.
    pub fn new(
        builtin: &'static Builtin,
        form: usize,
        values: Vec<Option<Value>>,
        rest: Vec<Value>,
    ) -> Args {
        Args {
            values,
            rest,
            form,
            signature: &builtin.signatures[form],
            builtin,
        }
    }

    fn slot(&self, key: &str) -> Option<usize> {
        let i = self.signature.param_index(key);
        // A name that no form has is a mistake in felt's source, caught by the builtin's
        // tests; at run time it reads as "not given". A name only other forms have is simply
        // not given in this one.
        debug_assert!(
            i.is_some()
                || self
                    .builtin
                    .signatures
                    .iter()
                    .any(|s| s.param_index(key).is_some()),
            "builtin `{}` reads `{key}`, which none of its signatures has",
            self.builtin.name
        );
        i
    }

    pub fn get(&self, key: &str) -> Result<&Value, Failure> {
        self.opt(key)
            .ok_or_else(|| Failure::new(format!("missing argument `{key}`")))
    }

    pub fn opt(&self, key: &str) -> Option<&Value> {
        self.slot(key)
            .and_then(|i| self.values.get(i))
            .and_then(|v| v.as_ref())
    }

    /// The argument of the first of `keys` that the matched form has: one parameter that the
    /// forms name differently (`grad(scalarfield f)`, `grad(vectorfield v)`).
    pub fn one_of(&self, keys: &[&str]) -> Result<&Value, Failure> {
        let key = keys
            .iter()
            .find(|k| self.signature.param_index(k).is_some())
            .or(keys.first())
            .copied()
            .unwrap_or_default();
        self.get(key)
    }

    /// Whether the caller gave this argument.
    pub fn given(&self, key: &str) -> bool {
        self.opt(key).is_some()
    }

    pub fn float(&self, key: &str) -> Result<f64, Failure> {
        self.get(key)?.as_float()
    }

    pub fn int(&self, key: &str) -> Result<i64, Failure> {
        self.get(key)?.as_int()
    }

    pub fn opt_float(&self, key: &str) -> Result<Option<f64>, Failure> {
        self.opt(key).map(|v| v.as_float()).transpose()
    }

    pub fn opt_int(&self, key: &str) -> Result<Option<i64>, Failure> {
        self.opt(key).map(|v| v.as_int()).transpose()
    }

    pub fn string(&self, key: &str) -> Result<&str, Failure> {
        self.get(key)?.as_str()
    }

    /// A float that must be finite and above zero.
    pub fn positive_float(&self, key: &str) -> Result<f64, Failure> {
        let v = self.float(key)?;
        self.check_positive(key, v)
    }

    /// `positive_float`, for an optional parameter.
    pub fn opt_positive_float(&self, key: &str) -> Result<Option<f64>, Failure> {
        match self.opt_float(key)? {
            Some(v) => self.check_positive(key, v).map(Some),
            None => Ok(None),
        }
    }

    /// A whole number above zero, as a count.
    pub fn positive_int(&self, key: &str) -> Result<usize, Failure> {
        let n = self.int(key)?;
        self.check_count(key, n)
    }

    /// `positive_int`, for an optional parameter.
    pub fn opt_positive_int(&self, key: &str) -> Result<Option<usize>, Failure> {
        match self.opt_int(key)? {
            Some(n) => self.check_count(key, n).map(Some),
            None => Ok(None),
        }
    }

    /// A float in `range` (ends included).
    pub fn float_in(&self, key: &str, range: RangeInclusive<f64>) -> Result<f64, Failure> {
        let v = self.float(key)?;
        self.check_in(key, v, range)
    }

    /// `float_in`, for an optional parameter.
    pub fn opt_float_in(
        &self,
        key: &str,
        range: RangeInclusive<f64>,
    ) -> Result<Option<f64>, Failure> {
        match self.opt_float(key)? {
            Some(v) => self.check_in(key, v, range).map(Some),
            None => Ok(None),
        }
    }

    /// A whole number in `range` (ends included).
    pub fn int_in(&self, key: &str, range: RangeInclusive<i64>) -> Result<i64, Failure> {
        let n = self.int(key)?;
        if range.contains(&n) {
            Ok(n)
        } else {
            Err(self.out_of(key, n, range.start(), range.end()))
        }
    }

    /// A whole number in `range` (ends included), for an optional parameter.
    pub fn opt_int_in(
        &self,
        key: &str,
        range: RangeInclusive<i64>,
    ) -> Result<Option<i64>, Failure> {
        match self.opt_int(key)? {
            Some(n) if !range.contains(&n) => Err(self.out_of(key, n, range.start(), range.end())),
            n => Ok(n),
        }
    }

    /// How a message names parameter `key`: "sphere radius".
    fn what(&self, key: &str) -> String {
        format!("{} {key}", self.builtin.name)
    }

    fn check_positive(&self, key: &str, v: f64) -> Result<f64, Failure> {
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(Failure::new(format!(
                "{} must be positive, found {v}",
                self.what(key)
            )))
        }
    }

    fn check_count(&self, key: &str, n: i64) -> Result<usize, Failure> {
        usize::try_from(n).ok().filter(|&n| n > 0).ok_or_else(|| {
            Failure::new(format!(
                "{} must be a positive whole number, found {n}",
                self.what(key)
            ))
        })
    }

    fn check_in(&self, key: &str, v: f64, range: RangeInclusive<f64>) -> Result<f64, Failure> {
        if range.contains(&v) {
            Ok(v)
        } else {
            Err(self.out_of(key, v, range.start(), range.end()))
        }
    }

    fn out_of(
        &self,
        key: &str,
        v: impl fmt::Display,
        lo: impl fmt::Display,
        hi: impl fmt::Display,
    ) -> Failure {
        Failure::new(format!(
            "{} must be between {lo} and {hi}, found {v}",
            self.what(key)
        ))
    }
}

pub type BuiltinFn = fn(&mut Interpreter, Args) -> Result<Value, Failure>;

/// The signature table and, for each builtin in it, its implementation.
#[derive(Default)]
pub struct Registry {
    signatures: Signatures,
    implementations: HashMap<&'static str, BuiltinFn>,
}

impl Registry {
    /// Adds a builtin: its forms and doc line (see `Signatures::add`) and its implementation.
    pub fn add(&mut self, group: &'static str, forms: &[&str], doc: &'static str, run: BuiltinFn) {
        let name = self.signatures.add(group, forms, doc);
        self.implementations.insert(name, run);
    }

    /// See `Signatures::choices`.
    pub fn choices(
        &mut self,
        builtin: &str,
        param: &str,
        noun: &'static str,
        values: &'static [&'static str],
    ) {
        self.signatures.choices(builtin, param, noun, values);
    }

    /// See `Signatures::aliases`.
    pub fn aliases(&mut self, builtin: &str, param: &str, aliases: &'static [&'static str]) {
        self.signatures.aliases(builtin, param, aliases);
    }

    /// See `Signatures::details`.
    pub fn details(&mut self, builtin: &str, text: String) {
        self.signatures.details(builtin, text);
    }

    /// Every builtin's signatures, for the checker.
    pub fn signatures(&self) -> &Signatures {
        &self.signatures
    }

    pub fn get(&self, name: &str) -> Option<&Builtin> {
        self.signatures.get(name)
    }

    /// The implementation of builtin `name`.
    pub fn implementation(&self, name: &str) -> Option<BuiltinFn> {
        self.implementations.get(name).copied()
    }

    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.signatures.names()
    }

    pub fn all(&self) -> impl Iterator<Item = &Builtin> {
        self.signatures.all()
    }
}

/// The registry of every builtin, built once.
pub fn registry() -> &'static Registry {
    static REGISTRY: OnceLock<Registry> = OnceLock::new();
    REGISTRY.get_or_init(|| {
        let mut r = Registry::default();
        super::builtins::register_all(&mut r);
        r
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::check::signature::parse_form;

    /// The arguments of `builtin`'s first form with only `given` given.
    fn args(builtin: &str, given: &[(&str, Value)]) -> Args {
        let builtin = registry().get(builtin).unwrap();
        let signature = &builtin.signatures[0];
        let mut values = vec![None; signature.params.len()];
        for (name, value) in given {
            values[signature.param_index(name).unwrap()] = Some(value.clone());
        }
        Args::new(builtin, 0, values, Vec::new())
    }

    #[test]
    fn range_checks_read_by_name_and_word_every_message_alike() {
        let a = args("sphere", &[("radius", Value::Float(-1.0))]);
        let message = a.positive_float("radius").unwrap_err().message;
        assert_eq!(message, "sphere radius must be positive, found -1");
        let a = args("sphere", &[("radius", Value::Float(f64::NAN))]);
        assert!(a.positive_float("radius").is_err());
        let a = args("sphere", &[("radius", Value::Float(0.5))]);
        assert_eq!(a.positive_float("radius").unwrap(), 0.5);
        assert!(!a.given("center"));
        assert_eq!(
            a.get("center").unwrap_err().message,
            "missing argument `center`"
        );

        let a = args(
            "render",
            &[("width", Value::Int(0)), ("spp", Value::Int(4))],
        );
        assert_eq!(
            a.opt_positive_int("width").unwrap_err().message,
            "render width must be a positive whole number, found 0"
        );
        assert_eq!(a.opt_positive_int("spp").unwrap(), Some(4));
        assert_eq!(a.opt_positive_int("height").unwrap(), None);

        let a = args("render", &[("albedo", Value::Float(1.5))]);
        assert_eq!(
            a.opt_float_in("albedo", 0.0..=1.0).unwrap_err().message,
            "render albedo must be between 0 and 1, found 1.5"
        );
        assert_eq!(a.opt_int_in("seed", 0..=9).unwrap(), None);
    }

    #[test]
    fn every_builtin_form_parses_and_prints_back() {
        let r = registry();
        assert!(r.get("print").is_some());
        for b in r.all() {
            assert!(!b.doc.is_empty(), "`{}` has no doc line", b.name);
            assert!(
                r.implementation(b.name).is_some(),
                "`{}` does nothing",
                b.name
            );
            for form in b.forms() {
                let (name, _) = parse_form(&form).unwrap();
                assert_eq!(name, b.name);
            }
        }
    }
}
