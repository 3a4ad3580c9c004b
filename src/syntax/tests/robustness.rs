//! No input panics, hangs or overflows the stack, and the REPL's completeness test.
use super::*;
use crate::syntax::parse::{MAX_NESTING, is_incomplete};

use crate::base::test_random::SplitMix as Rng;

/// Runs `f` on a thread with a deliberately small stack, so that any recursion whose depth
/// follows the input shows up as a crash here rather than on a user's machine.
fn with_small_stack(f: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .stack_size(1 << 20)
        .spawn(f)
        .expect("spawn test thread")
        .join()
        .expect("parser thread panicked");
}

/// Parses arbitrary text and checks what must hold whatever the text: a failure carries at
/// least one error, and every error points inside the text, on character boundaries.
fn parse_any(text: &str) -> bool {
    match parse(FileId(0), text) {
        Ok(_) => true,
        Err(errors) => {
            assert!(!errors.is_empty(), "no error for {text:?}");
            for e in errors {
                let (start, end) = (e.span.start as usize, e.span.end as usize);
                assert!(start <= end && end <= text.len(), "{e:?} outside {text:?}");
                assert!(
                    text.is_char_boundary(start) && text.is_char_boundary(end),
                    "{e:?}"
                );
            }
            false
        }
    }
}

fn first_message(source: &str) -> String {
    match parse(FileId(0), source) {
        Ok(_) => "parsed".to_string(),
        Err(errors) => errors[0].message.clone(),
    }
}

#[test]
fn random_bytes_never_panic() {
    let mut rng = Rng(1);
    let alphabet = b"(){}[];,.=+-*/^!<>&|\"\\ \n\tabcxyz019e_/*";
    for round in 0..3000 {
        let len = rng.below(64);
        let bytes: Vec<u8> = (0..len)
            .map(|_| {
                if round % 2 == 0 {
                    rng.next() as u8
                } else {
                    alphabet[rng.below(alphabet.len())]
                }
            })
            .collect();
        let text = String::from_utf8_lossy(&bytes);
        parse_any(&text);
        let _ = is_incomplete(&text);
    }
}

#[test]
fn random_token_soups_never_panic() {
    const WORDS: &[&str] = &[
        "(",
        ")",
        "[",
        "]",
        "{",
        "}",
        ";",
        ",",
        ".",
        "=",
        "+=",
        "-=",
        "*=",
        "/=",
        "++",
        "--",
        "+",
        "-",
        "*",
        "/",
        "%",
        "^",
        "==",
        "!=",
        "<",
        "<=",
        ">",
        ">=",
        "&&",
        "||",
        "!",
        "if",
        "else",
        "for",
        "while",
        "break",
        "continue",
        "return",
        "func",
        "param",
        "import",
        "true",
        "false",
        "void",
        "int",
        "float",
        "scalarfield",
        "vector",
        "domain",
        "scalarmcache",
        "x",
        "y",
        "f",
        "12",
        "1.5",
        ".5",
        "1e-3",
        "\"s\"",
        "/* c */",
    ];
    let mut rng = Rng(2);
    let mut parsed = 0;
    for _ in 0..3000 {
        let len = 1 + rng.below(40);
        let text: Vec<&str> = (0..len).map(|_| WORDS[rng.below(WORDS.len())]).collect();
        let text = text.join(" ");
        if parse_any(&text) {
            parsed += 1;
        }
        let _ = is_incomplete(&text);
    }
    // Soups almost never form a program; the point is that none of them crashed.
    assert!(parsed < 3000);
}

#[test]
fn mutated_scripts_never_panic() {
    let script = include_str!("course_notes.felt").as_bytes();
    let mut rng = Rng(3);
    for _ in 0..300 {
        let mut bytes = script.to_vec();
        for _ in 0..1 + rng.below(4) {
            let at = rng.below(bytes.len());
            match rng.below(3) {
                0 => {
                    bytes.remove(at);
                }
                1 => bytes.insert(at, b"(){};,=\"/"[rng.below(9)]),
                _ => {
                    let other = rng.below(bytes.len());
                    bytes.swap(at, other);
                }
            }
        }
        let text = String::from_utf8_lossy(&bytes);
        parse_any(&text);
    }
}

fn too_deep(what: &str) -> String {
    format!("{what} nested too deeply (more than {MAX_NESTING} levels)")
}

#[test]
fn deep_brackets_are_refused_before_parsing() {
    with_small_stack(|| {
        let deep = format!("x = {}1{};", "(".repeat(10_000), ")".repeat(10_000));
        let e = parse(FileId(0), &deep).unwrap_err().remove(0);
        assert_eq!(e.message, too_deep("expression"));
        // It points at the first bracket beyond the limit.
        assert_eq!(e.span.start as usize, 4 + MAX_NESTING);
        assert_eq!(first_message(&"{".repeat(10_000)), too_deep("blocks"));
        assert_eq!(first_message(&"a[".repeat(10_000)), too_deep("expression"));
    });
}

#[test]
fn long_operator_chains_are_flat_and_parse() {
    with_small_stack(|| {
        for op in ["+", "-", "*", "/", "%", "&&", "||", "<", "==", "!="] {
            let chain = format!("x = a{};", format!(" {op} a").repeat(10_000));
            let program = program(&chain);
            let Item::Stmt(Stmt {
                kind: StmtKind::Assign { value, .. },
                ..
            }) = &program.items[0]
            else {
                panic!("not an assignment")
            };
            // One node, not a tree 10,000 deep.
            let ExprKind::Binary(first, operations) = &value.kind else {
                panic!("{op}: not a chain")
            };
            assert_eq!(
                first.kind,
                ExprKind::Var(Ident {
                    name: "a".into(),
                    span: first.span
                })
            );
            assert_eq!(operations.len(), 10_000, "{op}");
        }
        // Operators of different precedence in one run: each operand is measured on its
        // own, so a long sum of deep-ish products parses.
        let mixed = format!(
            "x = a{};",
            format!(" + {}a * b", "-!".repeat(100)).repeat(2_000)
        );
        assert_eq!(first_message(&mixed), "parsed");
    });
}

#[test]
fn real_expression_nesting_is_refused_without_deep_recursion() {
    with_small_stack(|| {
        // `^` is right-associative: each one nests.
        let powers = format!("x = a{};", " ^ a".repeat(10_000));
        assert_eq!(first_message(&powers), too_deep("expression"));
        let prefixes = format!("x = {}1;", "-!".repeat(5_000));
        assert_eq!(first_message(&prefixes), too_deep("expression"));
        let calls = format!("x = {}1{};", "f(".repeat(300), ")".repeat(300));
        assert_eq!(first_message(&calls), too_deep("expression"));
        // A chain is one level, but an operand nested past the limit is still refused.
        let deep_operand = format!("x = a + a + {}a + a;", "-!".repeat(MAX_NESTING / 2));
        assert_eq!(first_message(&deep_operand), too_deep("expression"));
        let operand_inside = format!("x = a + a + {}a + a;", "-!".repeat(MAX_NESTING / 2 - 1));
        assert_eq!(first_message(&operand_inside), "parsed");
    });
}

#[test]
fn long_statement_chains() {
    with_small_stack(|| {
        let ifs = format!("{}x = 1;", "if (a) ".repeat(10_000));
        assert_eq!(first_message(&ifs), too_deep("statements"));
        let loops = format!("{}{{}}", "while (a) for (;;) ".repeat(5_000));
        assert_eq!(first_message(&loops), too_deep("statements"));
        // An `else if` chain is one statement, however long.
        for tail in ["", "else x;", "else { x; }"] {
            let chain = format!("if (a) x; {}{tail}", "else if (a) x; ".repeat(10_000));
            let program = program(&chain);
            let Item::Stmt(Stmt {
                kind:
                    StmtKind::If {
                        branches,
                        else_branch,
                    },
                ..
            }) = &program.items[0]
            else {
                panic!("not an if")
            };
            assert_eq!(branches.len(), 10_001);
            assert_eq!(else_branch.is_some(), !tail.is_empty());
        }
        let braced = format!("if (a) {{ x; }} {}", "else if (a) { x; } ".repeat(10_000));
        assert_eq!(first_message(&braced), "parsed");
        // Nested inside the chain's last branch, bare bodies still count.
        let inner = format!(
            "if (a) x; {}else {}x;",
            "else if (a) x; ".repeat(1_000),
            "if (a) ".repeat(MAX_NESTING + 1)
        );
        assert_eq!(first_message(&inner), too_deep("statements"));
    });
}

#[test]
fn nesting_just_inside_the_limit_parses() {
    with_small_stack(|| {
        let n = MAX_NESTING - 10;
        let parens = format!("x = {}1{};", "(".repeat(n), ")".repeat(n));
        assert_eq!(first_message(&parens), "parsed");
        let sum = format!("x = a{};", " + a".repeat(n));
        assert_eq!(first_message(&sum), "parsed");
        let calls = format!("x = {}1{};", "f(".repeat(n), ")".repeat(n));
        assert_eq!(first_message(&calls), "parsed");
        let blocks = format!("{}{}", "{".repeat(n), "}".repeat(n));
        assert_eq!(first_message(&blocks), "parsed");
        let chain = format!("if (a) x; {}", "else if (a) x; ".repeat(n / 2 - 1));
        assert_eq!(first_message(&chain), "parsed");
        // Many statements side by side are not nesting.
        let flat = "if (a) { x = 1; } else { y = -2; }\n".repeat(5_000);
        assert_eq!(first_message(&flat), "parsed");
    });
}

#[test]
fn error_recovery_ends_with_bounded_errors_on_hostile_input() {
    // A deep stack followed by a long run of tokens that recovery has to skip.
    let hostile = format!(
        "x = {}{}",
        "(-".repeat(MAX_NESTING - 1),
        "] ".repeat(100_000)
    );
    let errors = parse(FileId(0), &hostile).unwrap_err();
    assert!(!errors.is_empty());
    let garbage = ") = ; else ] }".repeat(20_000);
    let errors = parse(FileId(0), &garbage).unwrap_err();
    assert!(errors.len() <= 50);
}

#[test]
fn incomplete_input_asks_for_more() {
    for source in [
        "f(a,",
        "func void f() {\n  x = 1;",
        "x = a[1",
        "s = \"abc",
        "s = \"abc\\\"",
        "/* a comment",
        "x = \"a\" + (",
        "if (a) {\n  if (b) {\n  }",
    ] {
        assert!(is_incomplete(source), "{source:?}");
    }
}

#[test]
fn complete_or_unfixable_input_does_not() {
    for source in [
        "",
        "x = 1;",
        // Not finished, but no bracket is open: the parser's error is the answer.
        "x = 1",
        "// a comment",
        "/* closed */",
        "}",
        "f(a]",
        "x = @ (",
        "s = \"a\\q\"; (",
        "{ x = 1; } }",
    ] {
        assert!(!is_incomplete(source), "{source:?}");
    }
}
