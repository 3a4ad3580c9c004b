//! The checker and the interpreter agree on types: for every builtin form and every operator
//! whose operands can be written as literals, the type the checker gives an expression is the
//! type of the value the interpreter computes for it.
//!
//! The one key decision: expressions are generated from the registry's own signatures and the
//! operator tables, so a builtin or an operator rule added later is covered without editing
//! this file. Calls the interpreter rejects at run time (a range check the checker cannot see)
//! are skipped, and the test asserts that most forms did run.

use felt::check::types::Type;
use felt::interp::Interpreter;
use felt::interp::registry::{ParamType, registry};
use felt::interp::value::Value;
use felt::session::Session;

/// A literal of `ty`, where one can be written.
fn literal(ty: &Type) -> Option<&'static str> {
    Some(match ty {
        Type::Int => "2",
        Type::Float => "0.5",
        Type::Bool => "true",
        Type::Str => "\"a\"",
        Type::Vector => "(0.5, 0.25, 0.125)",
        Type::Matrix => "((2.0, 0.5, 0.0), (0.0, 1.0, 0.0), (0.25, 0.0, 1.0))",
        Type::ScalarField => "scalarfield(0.5)",
        Type::VectorField => "vectorfield((0.5, 0.25, 0.125))",
        Type::MatrixField => "matrixfield(((2.0, 0.5, 0.0), (0.0, 1.0, 0.0), (0.25, 0.0, 1.0)))",
        _ => return None,
    })
}

/// Tallies of the expressions tried.
#[derive(Default)]
struct Tally {
    /// Accepted by the checker.
    checked: usize,
    /// Also computed by the interpreter.
    ran: usize,
    mismatches: Vec<String>,
}

impl Tally {
    /// Compares the checker's type of `text` with the type of the value it computes.
    fn compare(&mut self, session: &mut Session, text: &str) {
        let Ok(checked) = session.type_of(text) else {
            return;
        };
        self.checked += 1;
        let mut value_type = None;
        let mut keep = |_: &mut Interpreter, v: Value| value_type = Some(v.type_of().to_string());
        let ran = session.eval_input(text, &mut keep);
        if let (Ok(_), Some(computed)) = (ran, value_type) {
            self.ran += 1;
            if checked != computed {
                self.mismatches
                    .push(format!("{text}: checker {checked}, value {computed}"));
            }
        }
    }
}

#[test]
fn checker_types_are_the_interpreter_value_types() {
    let Ok(mut session) = Session::new(Box::new(std::io::sink())) else {
        panic!("the standard library loads");
    };
    let mut tally = Tally::default();
    for builtin in registry().all() {
        for sig in &builtin.signatures {
            if sig.ret == Type::Void {
                continue;
            }
            let args: Option<Vec<&str>> = sig
                .params
                .iter()
                .filter(|p| !p.optional)
                .map(|p| match &p.ty {
                    ParamType::Exact(t) => literal(t),
                    ParamType::Any => Some("0.5"),
                    ParamType::AnyArray => Some("{1, 2}"),
                })
                .collect();
            let Some(args) = args else { continue };
            tally.compare(
                &mut session,
                &format!("{}({})", builtin.name, args.join(", ")),
            );
        }
    }
    let operands = [
        Type::Int,
        Type::Float,
        Type::Bool,
        Type::Vector,
        Type::Matrix,
        Type::ScalarField,
        Type::VectorField,
        Type::MatrixField,
    ];
    let symbols = [
        "+", "-", "*", "/", "%", "^", "==", "!=", "<", "<=", ">", ">=", "&&", "||",
    ];
    for a in &operands {
        for b in &operands {
            for op in symbols {
                let text = format!("{} {op} {}", literal(a).unwrap(), literal(b).unwrap());
                tally.compare(&mut session, &text);
            }
        }
        for op in ["-", "!", "+"] {
            tally.compare(&mut session, &format!("{op}{}", literal(a).unwrap()));
        }
    }
    assert!(
        tally.mismatches.is_empty(),
        "{}",
        tally.mismatches.join("\n")
    );
    // Most accepted forms must have run, or this test checks little.
    let Tally { checked, ran, .. } = tally;
    assert!(
        ran >= 150 && ran * 3 >= checked * 2,
        "only {ran} of {checked} forms ran"
    );
}
