//! The builtin registry: one table of (name, signatures, doc line, implementation) that the
//! checker, the interpreter, the REPL's completion and `felt doc` all read, so a builtin
//! cannot be documented one way and checked another. Later capabilities add builtins by
//! registering them here, nothing else.
//!
//! Signatures are written the way the docs show them, `sin(scalarfield x) -> scalarfield`,
//! and parsed once when the registry is built. A parameter written `float step?` is optional
//! (the implementation sees `None` when it is not given); every parameter may also be passed
//! by keyword. A builtin may have several signatures: the first whose parameters accept the
//! arguments (after the implicit conversions `int → float`, plain → constant field) wins, so
//! plain forms are listed before field forms.

use super::Interpreter;
use super::value::Value;
use crate::check::types::Type;
use crate::failure::Failure;
use std::collections::BTreeMap;
use std::fmt;
use std::sync::OnceLock;

/// What a parameter accepts.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamType {
    Exact(Type),
    /// Anything printable (`print`, `str`).
    Any,
    /// An array of anything (`size`).
    AnyArray,
}

impl ParamType {
    pub fn accepts(&self, arg: &Type) -> bool {
        match self {
            ParamType::Exact(t) => arg.converts_to(t),
            ParamType::Any => *arg != Type::Void,
            ParamType::AnyArray => matches!(arg, Type::Array(_) | Type::EmptyArray | Type::Error),
        }
    }
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamType::Exact(t) => write!(f, "{t}"),
            ParamType::Any => f.write_str("any"),
            ParamType::AnyArray => f.write_str("any[]"),
        }
    }
}

#[derive(Clone, Debug)]
pub struct Param {
    pub name: String,
    pub ty: ParamType,
    pub optional: bool,
}

#[derive(Clone, Debug)]
pub struct Signature {
    pub params: Vec<Param>,
    /// `...` at the end: any number of further arguments of this type.
    pub variadic: Option<ParamType>,
    pub ret: Type,
}

impl Signature {
    pub fn required(&self) -> usize {
        self.params.iter().filter(|p| !p.optional).count()
    }

    pub fn param_index(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }
}

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

pub struct Builtin {
    pub name: &'static str,
    pub doc: &'static str,
    pub signatures: Vec<Signature>,
    pub run: BuiltinFn,
    /// The group it belongs to in `felt doc` ("math", "fields", "render", ...).
    pub group: &'static str,
}

impl Builtin {
    /// The signatures as the docs show them.
    pub fn forms(&self) -> Vec<String> {
        self.signatures
            .iter()
            .map(|s| format_signature(self.name, s))
            .collect()
    }
}

pub fn format_signature(name: &str, sig: &Signature) -> String {
    let mut params: Vec<String> = sig
        .params
        .iter()
        .map(|p| format!("{} {}{}", p.ty, p.name, if p.optional { "?" } else { "" }))
        .collect();
    if let Some(v) = &sig.variadic {
        params.push(format!("{v}..."));
    }
    if sig.ret == Type::Void {
        format!("{name}({})", params.join(", "))
    } else {
        format!("{name}({}) -> {}", params.join(", "), sig.ret)
    }
}

#[derive(Default)]
pub struct Registry {
    builtins: BTreeMap<&'static str, Builtin>,
}

impl Registry {
    /// Adds a builtin. `forms` are signatures in doc syntax, e.g.
    /// `"clamp(float x, float lo, float hi) -> float"`. Panics on a malformed form: the forms
    /// are part of felt's source, and a test builds the registry.
    pub fn add(&mut self, group: &'static str, forms: &[&str], doc: &'static str, run: BuiltinFn) {
        let mut name = None;
        let mut signatures = Vec::new();
        for form in forms {
            let (n, sig) =
                parse_form(form).unwrap_or_else(|e| panic!("builtin form `{form}`: {e}"));
            if let Some(prev) = name {
                assert_eq!(prev, n, "all forms of a builtin share its name");
            }
            name = Some(n);
            signatures.push(sig);
        }
        let name: &'static str = Box::leak(
            name.expect("at least one form")
                .to_string()
                .into_boxed_str(),
        );
        let previous = self.builtins.insert(
            name,
            Builtin {
                name,
                doc,
                signatures,
                run,
                group,
            },
        );
        assert!(previous.is_none(), "builtin `{name}` registered twice");
    }

    pub fn get(&self, name: &str) -> Option<&Builtin> {
        self.builtins.get(name)
    }

    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.builtins.keys().copied()
    }

    pub fn all(&self) -> impl Iterator<Item = &Builtin> {
        self.builtins.values()
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

/// Result of matching call arguments against a builtin's signatures.
pub enum Resolution {
    /// Signature index and, for each parameter, which argument fills it (`None`: not given);
    /// then the indices of the variadic arguments.
    Match {
        form: usize,
        slots: Vec<Option<usize>>,
        rest: Vec<usize>,
    },
    /// No form fits; the message says why, pointing at argument `arg` if there is one culprit.
    Mismatch {
        message: String,
        arg: Option<usize>,
        help: Option<String>,
    },
}

/// Matches positional and keyword arguments (`names[i]` is the keyword of argument `i`, if
/// any) against the builtin's forms.
pub fn resolve(builtin: &Builtin, types: &[Type], names: &[Option<String>]) -> Resolution {
    // The same keyword twice is wrong whatever the form, so it is said before trying them
    // (otherwise a builtin with several forms could only answer "no form takes ...").
    if let Some((arg, keyword)) = repeated_keyword(names) {
        return Resolution::Mismatch {
            message: format!("argument `{keyword}` of `{}` is given twice", builtin.name),
            arg: Some(arg),
            help: Some(format!("remove one of the two `{keyword} = ...`")),
        };
    }
    let mut first_error = None;
    let single = builtin.signatures.len() == 1;
    for (form, sig) in builtin.signatures.iter().enumerate() {
        match match_signature(builtin.name, sig, types, names) {
            Ok((slots, rest)) => return Resolution::Match { form, slots, rest },
            Err(e) => {
                if first_error.is_none() {
                    first_error = Some(e);
                }
            }
        }
    }
    let (message, arg) = first_error.unwrap_or_else(|| (String::from("no forms"), None));
    if single {
        Resolution::Mismatch {
            message,
            arg,
            help: None,
        }
    } else {
        let shown: Vec<String> = types.iter().map(|t| t.to_string()).collect();
        Resolution::Mismatch {
            message: format!("no form of `{}` takes ({})", builtin.name, shown.join(", ")),
            arg: None,
            help: Some(format!("the forms are:\n{}", builtin.forms().join("\n"))),
        }
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

type Matched = (Vec<Option<usize>>, Vec<usize>);

fn match_signature(
    name: &str,
    sig: &Signature,
    types: &[Type],
    names: &[Option<String>],
) -> Result<Matched, (String, Option<usize>)> {
    let mut slots: Vec<Option<usize>> = vec![None; sig.params.len()];
    let mut rest = Vec::new();
    let mut position = 0;
    for (i, ty) in types.iter().enumerate() {
        match &names[i] {
            None => {
                if position < sig.params.len() {
                    slots[position] = Some(i);
                    position += 1;
                } else if let Some(v) = &sig.variadic {
                    if !v.accepts(ty) {
                        return Err((
                            format!("argument {} of `{name}` must be {v}, found {ty}", i + 1),
                            Some(i),
                        ));
                    }
                    rest.push(i);
                } else {
                    let most = sig.params.len();
                    return Err((
                        format!(
                            "`{name}` takes {} argument{}, found {}",
                            most,
                            if most == 1 { "" } else { "s" },
                            types.len()
                        ),
                        Some(i),
                    ));
                }
            }
            Some(keyword) => match sig.param_index(keyword) {
                Some(p) if slots[p].is_some() => {
                    return Err((
                        format!("argument `{keyword}` of `{name}` is given twice"),
                        Some(i),
                    ));
                }
                Some(p) => slots[p] = Some(i),
                None => {
                    let known: Vec<&str> = sig.params.iter().map(|p| p.name.as_str()).collect();
                    let hint = crate::interp::suggest::closest(keyword, known.iter().copied())
                        .map(|s| format!(" (did you mean `{s}`?)"))
                        .unwrap_or_default();
                    return Err((
                        format!("`{name}` has no parameter named `{keyword}`{hint}"),
                        Some(i),
                    ));
                }
            },
        }
    }
    for (p, param) in sig.params.iter().enumerate() {
        match slots[p] {
            None if !param.optional => {
                return Err((
                    format!(
                        "`{name}` needs at least {} argument{}, found {}",
                        sig.required(),
                        if sig.required() == 1 { "" } else { "s" },
                        types.len()
                    ),
                    None,
                ));
            }
            Some(i) if !param.ty.accepts(&types[i]) => {
                return Err((
                    format!(
                        "argument `{}` of `{name}` must be {}, found {}",
                        param.name, param.ty, types[i]
                    ),
                    Some(i),
                ));
            }
            _ => {}
        }
    }
    Ok((slots, rest))
}

/// Parses `name(type a, type b?, type...) -> ret`.
fn parse_form(form: &str) -> Result<(&str, Signature), String> {
    let open = form.find('(').ok_or("missing `(`")?;
    let close = form.rfind(')').ok_or("missing `)`")?;
    let name = form[..open].trim();
    let ret = match form[close + 1..].trim() {
        "" => Type::Void,
        r => parse_type(r.strip_prefix("->").ok_or("expected `->`")?.trim())?,
    };
    let mut params = Vec::new();
    let mut variadic = None;
    let inner = form[open + 1..close].trim();
    if !inner.is_empty() {
        for part in inner.split(',') {
            let part = part.trim();
            if let Some(ty) = part.strip_suffix("...") {
                variadic = Some(parse_param_type(ty.trim())?);
                continue;
            }
            let (ty, pname) = part
                .rsplit_once(' ')
                .ok_or("parameter needs a type and a name")?;
            let (pname, optional) = match pname.strip_suffix('?') {
                Some(n) => (n, true),
                None => (pname, false),
            };
            params.push(Param {
                name: pname.to_string(),
                ty: parse_param_type(ty.trim())?,
                optional,
            });
        }
    }
    Ok((
        name,
        Signature {
            params,
            variadic,
            ret,
        },
    ))
}

fn parse_param_type(text: &str) -> Result<ParamType, String> {
    Ok(match text {
        "any" => ParamType::Any,
        "any[]" => ParamType::AnyArray,
        t => ParamType::Exact(parse_type(t)?),
    })
}

fn parse_type(text: &str) -> Result<Type, String> {
    if let Some(elem) = text.strip_suffix("[]") {
        return Ok(Type::array_of(parse_type(elem)?));
    }
    Ok(match text {
        "int" => Type::Int,
        "float" => Type::Float,
        "bool" => Type::Bool,
        "string" => Type::Str,
        "vector" => Type::Vector,
        "matrix" => Type::Matrix,
        "scalarfield" => Type::ScalarField,
        "vectorfield" => Type::VectorField,
        "matrixfield" => Type::MatrixField,
        "domain" => Type::Domain,
        "scalarcache" => Type::ScalarCache,
        "vectorcache" => Type::VectorCache,
        "matrixcache" => Type::MatrixCache,
        "shape" => Type::Shape,
        "particles" => Type::Particles,
        "camera" => Type::Camera,
        "light" => Type::Light,
        "cloudsim" => Type::CloudSim,
        "void" => Type::Void,
        other => return Err(format!("unknown type `{other}`")),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_builtin_form_parses_and_prints_back() {
        let r = registry();
        assert!(r.get("print").is_some());
        for b in r.all() {
            assert!(!b.doc.is_empty(), "`{}` has no doc line", b.name);
            for form in b.forms() {
                let (name, _) = parse_form(&form).unwrap();
                assert_eq!(name, b.name);
            }
        }
    }

    #[test]
    fn a_keyword_given_twice_is_named_whatever_the_forms() {
        let render = registry().get("render").unwrap();
        assert!(render.signatures.len() > 1);
        let types = [Type::Str, Type::ScalarField, Type::ScalarField];
        let names = [None, Some("density".into()), Some("density".into())];
        let Resolution::Mismatch { message, arg, .. } = resolve(render, &types, &names) else {
            panic!("resolved")
        };
        assert_eq!(message, "argument `density` of `render` is given twice");
        assert_eq!(arg, Some(2));
    }

    #[test]
    fn forms_parse() {
        let (name, sig) =
            parse_form("render(string path, scalarfield density?, float...)").unwrap();
        assert_eq!(name, "render");
        assert_eq!(sig.params.len(), 2);
        assert!(sig.params[1].optional);
        assert_eq!(sig.variadic, Some(ParamType::Exact(Type::Float)));
        assert_eq!(sig.ret, Type::Void);
        let (_, sig) = parse_form("layers(int n) -> scalarfield[]").unwrap();
        assert_eq!(sig.ret, Type::array_of(Type::ScalarField));
    }
}
