//! Builtin signatures: what each builtin accepts and returns, as the checker needs it. The
//! checker owns them; the interpreter registers its builtins here (forms, doc line, group)
//! and keeps their implementations beside, so the checker never depends on the interpreter.
//!
//! Signatures are written the way the docs show them, `sin(scalarfield x) -> scalarfield`,
//! and parsed once when the table is built. A parameter written `float step?` is optional
//! (the implementation sees `None` when it is not given); every parameter may also be passed
//! by keyword. A builtin may have several signatures: the first whose parameters accept the
//! arguments (after the implicit conversions `int → float`, plain → constant field) wins, so
//! plain forms are listed before field forms.

use super::types::Type;
use std::collections::BTreeMap;
use std::fmt;

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
    /// The only values a string (or each string of an array) may take, when there is a
    /// fixed set: checked on literals by `felt check` and on every value at run time.
    pub choices: Option<Choices>,
    /// Names users of other tools give this parameter (`samples` for `spp`), offered as
    /// the fix when one is used as a keyword.
    pub aliases: &'static [&'static str],
}

/// A parameter's fixed set of string values, and what one of them is called in a message
/// ("shadows mode", "AOV").
#[derive(Clone, Debug)]
pub struct Choices {
    pub noun: &'static str,
    pub values: &'static [&'static str],
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

#[derive(Debug)]
pub struct Builtin {
    pub name: &'static str,
    pub doc: &'static str,
    pub signatures: Vec<Signature>,
    /// The group it belongs to in `felt doc` ("math", "fields", "render", ...).
    pub group: &'static str,
    /// More than one line of doc: what `felt doc` shows after the doc line (render's
    /// keyword table).
    pub details: Option<String>,
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

/// Every builtin's signatures, by name.
#[derive(Debug, Default)]
pub struct Signatures {
    builtins: BTreeMap<&'static str, Builtin>,
}

impl Signatures {
    /// Adds a builtin and returns its name. `forms` are signatures in doc syntax, e.g.
    /// `"clamp(float x, float lo, float hi) -> float"`. Panics on a malformed form: the forms
    /// are part of felt's source, and a test builds the table.
    pub fn add(&mut self, group: &'static str, forms: &[&str], doc: &'static str) -> &'static str {
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
                group,
                details: None,
            },
        );
        assert!(previous.is_none(), "builtin `{name}` registered twice");
        name
    }

    /// Gives `builtin` more documentation than its doc line. Panics when there is no such
    /// builtin: the call is part of felt's source.
    pub fn details(&mut self, builtin: &str, text: String) {
        let entry = self
            .builtins
            .get_mut(builtin)
            .unwrap_or_else(|| panic!("no builtin `{builtin}` to document"));
        entry.details = Some(text);
    }

    /// Gives parameter `param` of every form of `builtin` a fixed set of string values.
    /// Panics when there is no such parameter: the call is part of felt's source.
    pub fn choices(
        &mut self,
        builtin: &str,
        param: &str,
        noun: &'static str,
        values: &'static [&'static str],
    ) {
        for p in self.params_named(builtin, param) {
            p.choices = Some(Choices { noun, values });
        }
    }

    /// Records names other tools give parameter `param` of `builtin`, for the did-you-mean
    /// of an unknown keyword.
    pub fn aliases(&mut self, builtin: &str, param: &str, aliases: &'static [&'static str]) {
        for p in self.params_named(builtin, param) {
            p.aliases = aliases;
        }
    }

    fn params_named(&mut self, builtin: &str, param: &str) -> Vec<&mut Param> {
        let b = self
            .builtins
            .get_mut(builtin)
            .unwrap_or_else(|| panic!("no builtin `{builtin}`"));
        let params: Vec<&mut Param> = b
            .signatures
            .iter_mut()
            .flat_map(|s| s.params.iter_mut())
            .filter(|p| p.name == param)
            .collect();
        assert!(!params.is_empty(), "`{builtin}` has no parameter `{param}`");
        params
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

/// Parses `name(type a, type b?, type...) -> ret`.
pub(crate) fn parse_form(form: &str) -> Result<(&str, Signature), String> {
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
                choices: None,
                aliases: &[],
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
