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
use crate::failure::Failure;
use std::collections::HashMap;
use std::fmt;
use std::sync::OnceLock;

pub use crate::check::resolve::{Culprit, Resolution, check_choice, resolve};
pub use crate::check::signature::{
    Builtin, Choices, Param, ParamType, Signature, Signatures, format_signature,
};

/// The arguments of one builtin call, already converted to the matched signature's types and
/// put in parameter order (`None` for an optional parameter not given).
///
/// Builtins read them by parameter name (`a.float("step")`), so the signature string is the
/// one place a parameter's position is written; a positional index still works for the
/// builtins whose forms differ only in arity.
pub struct Args {
    pub values: Vec<Option<Value>>,
    pub rest: Vec<Value>,
    /// Index of the signature that matched, for builtins whose forms differ in behaviour.
    pub form: usize,
    /// The matched signature, for reading arguments by name.
    pub signature: &'static Signature,
}

/// How a builtin names one of its arguments: by position or by parameter name.
pub trait ArgKey: Copy + fmt::Display {
    fn index(self, signature: &Signature) -> Option<usize>;
}

impl ArgKey for usize {
    fn index(self, _: &Signature) -> Option<usize> {
        Some(self)
    }
}

impl ArgKey for &str {
    fn index(self, signature: &Signature) -> Option<usize> {
        signature.param_index(self)
    }
}

impl Args {
    fn slot<K: ArgKey>(&self, key: K) -> Option<usize> {
        let i = key.index(self.signature);
        // A name that is not a parameter of the matched form is a mistake in felt's source,
        // caught by the builtin's tests; at run time it reads as "not given".
        debug_assert!(
            i.is_some(),
            "builtin reads `{key}`, which its signature lacks"
        );
        i
    }

    pub fn get<K: ArgKey>(&self, key: K) -> Result<&Value, Failure> {
        self.opt(key)
            .ok_or_else(|| Failure::new(format!("missing argument `{key}`")))
    }

    pub fn opt<K: ArgKey>(&self, key: K) -> Option<&Value> {
        self.slot(key)
            .and_then(|i| self.values.get(i))
            .and_then(|v| v.as_ref())
    }

    /// Whether the caller gave this argument.
    pub fn given<K: ArgKey>(&self, key: K) -> bool {
        self.opt(key).is_some()
    }

    pub fn float<K: ArgKey>(&self, key: K) -> Result<f64, Failure> {
        self.get(key)?.as_float()
    }

    pub fn int<K: ArgKey>(&self, key: K) -> Result<i64, Failure> {
        self.get(key)?.as_int()
    }

    pub fn opt_float<K: ArgKey>(&self, key: K) -> Result<Option<f64>, Failure> {
        self.opt(key).map(|v| v.as_float()).transpose()
    }

    pub fn opt_int<K: ArgKey>(&self, key: K) -> Result<Option<i64>, Failure> {
        self.opt(key).map(|v| v.as_int()).transpose()
    }

    pub fn string<K: ArgKey>(&self, key: K) -> Result<&str, Failure> {
        self.get(key)?.as_str()
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
