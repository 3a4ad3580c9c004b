//! Every kind of syntax error, with its exact position (1-based line and column).

use super::*;

const ADD_SEMICOLON: Option<&str> = Some("add `;` at the end of the statement");

fn check(source: &str, message: &str, line: usize, column: usize) -> Option<String> {
    let (m, l, c, help) = first_error(source);
    assert_eq!(
        (m.as_str(), l, c),
        (message, line, column),
        "for {source:?}"
    );
    help
}

#[test]
fn missing_semicolon_is_reported_at_the_end_of_the_previous_line() {
    let help = check(
        "float a = 1\nfloat b = 2;",
        "unexpected `float`, expected `;`",
        1,
        12,
    );
    assert_eq!(help.as_deref(), ADD_SEMICOLON);
    let help = check(
        "x = f(1)\n\n  y = 2;",
        "unexpected identifier `y`, expected `;`",
        1,
        9,
    );
    assert_eq!(help.as_deref(), ADD_SEMICOLON);
    check("{ x = 1 }", "unexpected `}`, expected `;`", 1, 8);
    let help = check(
        "a = 1;\nb = 2",
        "unexpected end of file, expected `;`",
        2,
        6,
    );
    assert_eq!(help.as_deref(), ADD_SEMICOLON);
}

#[test]
fn missing_semicolons_in_separate_statements_are_all_reported() {
    let found: Vec<(u32, String)> = errors("a = 1; b = 2 c = 3; d = 4 e = 5;")
        .into_iter()
        .map(|e| (e.span.start, e.message))
        .collect();
    assert_eq!(
        found,
        vec![
            (12, "unexpected identifier `c`, expected `;`".to_string()),
            (25, "unexpected identifier `e`, expected `;`".to_string()),
        ]
    );
}

#[test]
fn one_mistake_is_one_error() {
    // After recovering, the parser would trip over the rest of the statement again.
    assert_eq!(errors("f(a b);").len(), 1);
    assert_eq!(errors("func f() {}").len(), 1);
    assert_eq!(errors("x = {1, 2};\n{1, 2};").len(), 1);
}

#[test]
fn unbalanced_braces() {
    let help = check(
        "func void f() {\n  x = 1;\n",
        "unexpected end of file, expected `}`",
        2,
        9,
    );
    assert_eq!(help.as_deref(), Some("the `{` on line 1 is never closed"));
    let help = check("x = 1;\n}\n", "unexpected `}`, expected a statement", 2, 1);
    assert_eq!(help.as_deref(), Some("this `}` has no matching `{`"));
    let help = check("x = (1 + 2;", "unexpected `;`, expected `,` or `)`", 1, 11);
    assert_eq!(help, None);
    check(
        "x = f(a,\n  b\n",
        "unexpected end of file, expected `)`",
        2,
        4,
    );
    check("x = f(a];", "unexpected `]`, expected `,` or `)`", 1, 8);
}

#[test]
fn a_doubled_sign_in_an_expression_is_the_decrement_operator() {
    let help = check("x = --1;", "unexpected `--`, expected an expression", 1, 5);
    assert_eq!(
        help.as_deref(),
        Some("`--` changes a variable by one; for two signs write `- -`")
    );
    let help = check(
        "print(1 + ++y);",
        "unexpected `++`, expected an expression",
        1,
        11,
    );
    assert_eq!(
        help.as_deref(),
        Some("`++` changes a variable by one; for two signs write `+ +`")
    );
}

#[test]
fn array_types_state_their_limit() {
    let source = format!("float{} x;", "[]".repeat(256));
    check(&source, "too many `[]` in a type (more than 255)", 1, 1);
    assert!(parse(FileId(0), &format!("float{} x;", "[]".repeat(255))).is_ok());
}

#[test]
fn unexpected_tokens_are_named_by_their_text_and_expected_sets_are_summarised() {
    check("x = ;", "unexpected `;`, expected an expression", 1, 5);
    check(
        "f(a b);",
        "unexpected identifier `b`, expected `,` or `)`",
        1,
        5,
    );
    check(
        "func f() {}",
        "unexpected identifier `f`, expected a type",
        1,
        6,
    );
    check(
        "func float (x) {}",
        "unexpected `(`, expected identifier",
        1,
        12,
    );
    check("if x) {}", "unexpected identifier `x`, expected `(`", 1, 4);
    check(
        "import x;",
        "unexpected identifier `x`, expected string",
        1,
        8,
    );
    check("x = (1, 2;", "unexpected `;`, expected `,` or `)`", 1, 10);
    check(
        "return return;",
        "unexpected `return`, expected an expression or `;`",
        1,
        8,
    );
    check("x = 1 + 2 3;", "unexpected number `3`, expected `;`", 1, 10);
    check("while (x) }", "unexpected `}`, expected a statement", 1, 11);
    let help = check("if (a = b) {}", "unexpected `=`, expected `)`", 1, 7);
    assert_eq!(help.as_deref(), Some("to compare two values, use `==`"));
    let help = check("else x;", "unexpected `else`, expected a statement", 1, 1);
    assert_eq!(
        help.as_deref(),
        Some("this `else` has no `if` to belong to")
    );
}

#[test]
fn lexical_errors() {
    check("x = 1;\ny = a @ b;", "unknown character `@`", 2, 7);
    check("s = \"abc;\nt = 1;", "unterminated string", 1, 5);
    check("x = 1; /* note\n\n y = 2;", "unterminated comment", 1, 8);
    check("s = \"a\\qb\";", "unknown escape `\\q` in string", 1, 7);
    check(
        "n = 99999999999999999999;",
        "integer literal is too large",
        1,
        5,
    );
    // Every lexical error is reported, not only the first.
    assert_eq!(errors("a = @;\nb = #;\nc = $;").len(), 3);
}

#[test]
fn positional_argument_after_keyword_argument() {
    let help = check(
        "render(\"a.exr\", density = d,\n       0.01);",
        "positional argument after a keyword argument",
        2,
        8,
    );
    assert_eq!(
        help.as_deref(),
        Some("put positional arguments before `density = ...`, or give this one a name too")
    );
    check(
        "domain d(a, b = 1, c);",
        "positional argument after a keyword argument",
        1,
        20,
    );
}

#[test]
fn assignment_to_something_that_is_not_a_variable_or_element() {
    let message = "can only assign to a variable or an array element";
    check("a + b = c;", message, 1, 1);
    check("x = 1;\n  f(x) += 2;", message, 2, 3);
    check("(a, b) = c;", message, 1, 1);
    let help = check("v.x = 1;", message, 1, 1);
    assert!(help.unwrap().contains("build a new vector"));
    check(
        "3++;",
        "can only increment a variable or an array element",
        1,
        1,
    );
    check(
        "--f(x);",
        "can only decrement a variable or an array element",
        1,
        3,
    );
    // The span covers the whole target.
    let e = errors("a + b = c;").remove(0);
    assert_eq!((e.span.start, e.span.end), (0, 5));
}

#[test]
fn func_and_import_inside_a_block() {
    let help = check(
        "func void f() {\n  func float g() { return 1; }\n}",
        "functions can only be declared at the top level of a file",
        2,
        3,
    );
    assert!(help.is_some());
    check(
        "if (a) {\n import \"b.felt\";\n}",
        "`import` can only appear at the top level of a file",
        2,
        2,
    );
}

#[test]
fn param_inside_a_block_or_body() {
    let message = "`param` declarations must be at the top level of the script";
    check("{ param float a = 1; }", message, 1, 3);
    check("if (x) param int n = 1;", message, 1, 8);
    check("for (param int i = 0; i < 2; i++) {}", message, 1, 6);
}

#[test]
fn several_independent_errors_are_reported_in_order() {
    let source = "x = 1 +;\nfunc void f() { v.x = 2; }\ny = g(a = 1, 2);\n";
    let found: Vec<(usize, String)> = errors(source)
        .into_iter()
        .map(|e| {
            let (line, _) = SourceFile::new("t", source).line_col(e.span.start as usize);
            (line, e.message)
        })
        .collect();
    assert_eq!(
        found,
        vec![
            (1, "unexpected `;`, expected an expression".to_string()),
            (
                2,
                "can only assign to a variable or an array element".to_string()
            ),
            (
                3,
                "positional argument after a keyword argument".to_string()
            ),
        ]
    );
}

#[test]
fn error_display_is_the_message() {
    let e = errors("x = ;").remove(0);
    assert_eq!(e.to_string(), "unexpected `;`, expected an expression");
}
