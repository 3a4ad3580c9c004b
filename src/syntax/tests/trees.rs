//! The trees that scripts parse into.

use super::*;

#[test]
fn arithmetic_precedence_and_associativity() {
    assert_eq!(expr("a + b * c ^ d ^ e"), "(+ a (* b (^ c (^ d e))))");
    assert_eq!(expr("a - b - c"), "(- (- a b) c)");
    assert_eq!(expr("a / b * c % d"), "(% (* (/ a b) c) d)");
    assert_eq!(expr("(a + b) * c"), "(* (+ a b) c)");
    assert_eq!(expr("a ^ b * c"), "(* (^ a b) c)");
}

#[test]
fn logical_and_comparison_precedence() {
    assert_eq!(expr("a || b && c == d < e"), "(|| a (&& b (== c (< d e))))");
    assert_eq!(expr("a < b == c > d"), "(== (< a b) (> c d))");
    assert_eq!(expr("a != b <= c + 1"), "(!= a (<= b (+ c 1)))");
    assert_eq!(expr("a >= b || !c && d"), "(|| (>= a b) (&& (! c) d))");
}

#[test]
fn power_binds_tighter_than_prefix_minus() {
    assert_eq!(expr("-2^2"), "(neg (^ 2 2))");
    assert_eq!(expr("-x^2"), "(neg (^ x 2))");
    assert_eq!(expr("2^-1"), "(^ 2 -1)");
    assert_eq!(expr("2^-x^2"), "(^ 2 (neg (^ x 2)))");
    assert_eq!(expr("a*-b^c"), "(* a (neg (^ b c)))");
    assert_eq!(expr("(-2)^2"), "(^ -2 2)");
}

#[test]
fn prefix_operators_nest_and_fold_into_literals() {
    assert_eq!(expr("-1"), "-1");
    assert_eq!(expr("-1.5"), "-1.5");
    assert_eq!(expr("- -1"), "1");
    assert_eq!(expr("-x"), "(neg x)");
    assert_eq!(expr("!!x"), "(! (! x))");
    assert_eq!(expr("-!+x"), "(neg (! (pos x)))");
    assert_eq!(expr("+1"), "(pos 1)");
    assert_eq!(expr("a - -1"), "(- a -1)");
}

#[test]
fn folded_negative_literal_spans_the_minus() {
    let p = program("x = - 2.5;");
    let Item::Stmt(Stmt {
        kind: StmtKind::Assign { value, .. },
        ..
    }) = &p.items[0]
    else {
        panic!("not an assignment: {p:?}")
    };
    assert_eq!(value.kind, ExprKind::Float(-2.5));
    assert_eq!((value.span.start, value.span.end), (4, 9));
}

#[test]
fn postfix_chains() {
    assert_eq!(expr("a[i][j]"), "(index (index a i) j)");
    assert_eq!(expr("v.x"), "(. v x)");
    assert_eq!(expr("a[0].y"), "(. (index a 0) y)");
    assert_eq!(expr("f(x).z"), "(. (f x) z)");
    assert_eq!(expr("grad(r)[1]"), "(index (grad r) 1)");
    assert_eq!(expr("-v.x^2"), "(neg (^ (. v x) 2))");
    assert_eq!(expr("m[i + 1][j * 2]"), "(index (index m (+ i 1)) (* j 2))");
}

#[test]
fn tuples_versus_parentheses() {
    assert_eq!(expr("(a)"), "a");
    assert_eq!(expr("((a))"), "a");
    assert_eq!(expr("(a, b)"), "(tuple a b)");
    assert_eq!(expr("(-1, -1, -1)"), "(tuple -1 -1 -1)");
    assert_eq!(expr("(a + 1, (b), c * 2)"), "(tuple (+ a 1) b (* c 2))");
    assert_eq!(
        expr("((1, 0, 0), (0, 1, 0), (0, 0, 1))"),
        "(tuple (tuple 1 0 0) (tuple 0 1 0) (tuple 0 0 1))"
    );
}

#[test]
fn parenthesised_expression_span_covers_the_parentheses() {
    let p = program("x = (a + b);");
    let Item::Stmt(Stmt {
        kind: StmtKind::Assign { value, .. },
        ..
    }) = &p.items[0]
    else {
        panic!("not an assignment")
    };
    assert_eq!((value.span.start, value.span.end), (4, 11));
}

#[test]
fn array_literals() {
    assert_eq!(render("x = {};"), "(= x (array))");
    assert_eq!(render("x = {1, 2, 3};"), "(= x (array 1 2 3))");
    assert_eq!(render("x = {{1}, {}};"), "(= x (array (array 1) (array)))");
    assert_eq!(render("f({a, b});"), "(f (array a b))");
    assert_eq!(render("x = {(1, 2, 3)};"), "(= x (array (tuple 1 2 3)))");
}

#[test]
fn calls_with_keyword_arguments() {
    assert_eq!(expr("f()"), "(f)");
    assert_eq!(expr("f(a, b + 1)"), "(f a (+ b 1))");
    assert_eq!(
        expr("render(\"a.exr\", density = d, step = 0.01, lights = {key})"),
        "(render \"a.exr\" density=d step=0.01 lights=(array key))"
    );
    assert_eq!(expr("f(x = 1)"), "(f x=1)");
}

#[test]
fn type_keywords_are_constructors() {
    assert_eq!(expr("scalarfield(1.0)"), "(scalarfield 1.0)");
    assert_eq!(expr("vectorfield(a, b, c)"), "(vectorfield a b c)");
    assert_eq!(expr("matrixfield(m)"), "(matrixfield m)");
    assert_eq!(expr("camera(e, l, u, 40)"), "(camera e l u 40)");
    assert_eq!(expr("int(x) + float(i)"), "(+ (int x) (float i))");
    assert_eq!(expr("string(x)"), "(string x)");
    assert_eq!(expr("scalarmcache(d)"), "(scalarcache d)");
    // The callee's span is the keyword as written.
    let p = program("scalarmcache(d);");
    let Item::Stmt(Stmt {
        kind: StmtKind::Expr(e),
        ..
    }) = &p.items[0]
    else {
        panic!()
    };
    let ExprKind::Call { callee, .. } = &e.kind else {
        panic!()
    };
    assert_eq!((callee.span.start, callee.span.end), (0, 12));
}

#[test]
fn literals() {
    assert_eq!(expr("12"), "12");
    assert_eq!(expr(".5"), "0.5");
    assert_eq!(expr("1e-3"), "0.001");
    assert_eq!(expr("2.0e+4"), "20000.0");
    assert_eq!(expr("true && false"), "(&& true false)");
    assert_eq!(expr(r#""a\"b\\c\nd\te""#), r#""a\"b\\c\nd\te""#);
}

#[test]
fn literal_kinds() {
    let p = program("x = 12; y = 1.5;");
    let kinds: Vec<&ExprKind> = p
        .items
        .iter()
        .map(|item| match item {
            Item::Stmt(Stmt {
                kind: StmtKind::Assign { value, .. },
                ..
            }) => &value.kind,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(kinds, vec![&ExprKind::Int(12), &ExprKind::Float(1.5)]);
}

#[test]
fn declarations() {
    assert_eq!(render("float kappa = 4.0;"), "(decl float kappa = 4.0)");
    assert_eq!(render("scalarfield d;"), "(decl scalarfield d)");
    assert_eq!(
        render("scalarfield[][] grid;"),
        "(decl scalarfield[][] grid)"
    );
    assert_eq!(
        render("param float step = 0.01;"),
        "(decl param float step = 0.01)"
    );
    assert_eq!(
        render("domain d(o, l, r, 0.1, 0.1);"),
        "(decl domain d (o l r 0.1 0.1))"
    );
    assert_eq!(
        render("scalarmcache c(doms[i]);"),
        "(decl scalarcache c ((index doms i)))"
    );
    assert_eq!(render("camera cam();"), "(decl camera cam ())");
    assert_eq!(
        render("light key = distantlight(dir, (1, 1, 1));"),
        "(decl light key = (distantlight dir (tuple 1 1 1)))"
    );
}

#[test]
fn declarator_lists_are_spliced_into_the_enclosing_list() {
    assert_eq!(
        render("float a = 1, b, c(2);"),
        "(decl float a = 1)\n(decl float b)\n(decl float c (2))"
    );
    assert_eq!(
        render("{ int i, j = i; x = j; }"),
        "{(decl int i) (decl int j = i) (= x j)}"
    );
    assert_eq!(
        render("param int a = 1, b = 2;"),
        "(decl param int a = 1)\n(decl param int b = 2)"
    );
}

#[test]
fn declarator_spans() {
    let p = program("param float a = 1, bb;");
    let spans: Vec<(u32, u32)> = p
        .items
        .iter()
        .map(|item| match item {
            Item::Stmt(s) => (s.span.start, s.span.end),
            other => panic!("{other:?}"),
        })
        .collect();
    // The first covers `param float a = 1`; the last ends with the `;`.
    assert_eq!(spans, vec![(0, 17), (19, 22)]);
}

#[test]
fn assignments_and_increments() {
    assert_eq!(render("x = 1;"), "(= x 1)");
    assert_eq!(render("out += e;"), "(+= out e)");
    assert_eq!(render("a[i] -= 2;"), "(-= (index a i) 2)");
    assert_eq!(render("a[i][j] *= 2;"), "(*= (index (index a i) j) 2)");
    assert_eq!(render("x /= y + 1;"), "(/= x (+ y 1))");
    assert_eq!(
        render("x++; x--; ++x; --a[0];"),
        "(++ x)\n(-- x)\n(++ x)\n(-- (index a 0))"
    );
}

#[test]
fn if_else_chains() {
    assert_eq!(render("if (c) x = 1;"), "(if c {(= x 1)})");
    assert_eq!(
        render("if (c) { x = 1; } else { y; }"),
        "(if c {(= x 1)} else {y})"
    );
    assert_eq!(render("if (c) x; else y;"), "(if c {x} else {y})");
    assert_eq!(
        render("if (a) x; else if (b) y; else z;"),
        "(if a {x} else (if b {y} else {z}))"
    );
    // `else` binds to the nearest `if`.
    assert_eq!(
        render("if (a) if (b) x; else y;"),
        "(if a {(if b {x} else {y})})"
    );
    assert_eq!(
        render("if (a) while (b) if (c) x; else y; else z;"),
        "(if a {(while b {(if c {x} else {y})})} else {z})"
    );
    // A single declaration as a body gets a block of its own.
    assert_eq!(
        render("if (a) float t = 1, u;"),
        "(if a {(decl float t = 1) (decl float u)})"
    );
}

#[test]
fn loops() {
    assert_eq!(
        render("for (int i = 0; i < n; i++) { s += i; }"),
        "(for (decl int i = 0); (< i n); (++ i) {(+= s i)})"
    );
    assert_eq!(render("for (;;) break;"), "(for ; ;  {break})");
    assert_eq!(
        render("for (i = 0; ; i += 2) continue;"),
        "(for (= i 0); ; (+= i 2) {continue})"
    );
    assert_eq!(render("for (f(); g(); h()) ;"), "(for (f); (g); (h) {})");
    assert_eq!(render("for (--i; i; ) {}"), "(for (-- i); i;  {})");
    assert_eq!(render("while (x > 0) x--;"), "(while (> x 0) {(-- x)})");
    assert_eq!(render("while (true) { }"), "(while true {})");
}

#[test]
fn jumps_blocks_and_empty_statements() {
    assert_eq!(render("return;"), "(return)");
    assert_eq!(render("return a + 1;"), "(return (+ a 1))");
    assert_eq!(render("{ x; { y; } ; }"), "{x {y}}");
    assert_eq!(render(";;"), "");
    assert_eq!(render("{}"), "{}");
}

#[test]
fn functions_and_imports() {
    assert_eq!(
        render("func scalarfield[] f(int n, domain[] d) { return g(n); }"),
        "(func scalarfield[] f (int n, domain[] d) {(return (g n))})"
    );
    assert_eq!(
        render("func void show() { print(1); }"),
        "(func void show () {(print 1)})"
    );
    assert_eq!(render("import \"lib/a.felt\";"), "(import \"lib/a.felt\")");
}

#[test]
fn comments_are_ignored() {
    assert_eq!(
        render("x = 1; // one\n/* two\n lines */ y = /* inline */ 2;"),
        "(= x 1)\n(= y 2)"
    );
}

#[test]
fn statement_and_node_spans() {
    let source = "func float f(float x) {\n  return x * 2;\n}\nif (a) b = 1;";
    let p = program(source);
    let Item::Func(f) = &p.items[0] else { panic!() };
    assert_eq!(
        &source[f.span.start as usize..f.span.end as usize],
        &source[..41]
    );
    assert_eq!(
        &source[f.ret.span.start as usize..f.ret.span.end as usize],
        "float"
    );
    assert_eq!(
        &source[f.params[0].span.start as usize..f.params[0].span.end as usize],
        "float x"
    );
    let ret = &f.body.stmts[0];
    assert_eq!(
        &source[ret.span.start as usize..ret.span.end as usize],
        "return x * 2;"
    );
    let Item::Stmt(s) = &p.items[1] else { panic!() };
    assert_eq!(
        &source[s.span.start as usize..s.span.end as usize],
        "if (a) b = 1;"
    );
    let StmtKind::If { branches, .. } = &s.kind else {
        panic!()
    };
    let then_branch = &branches[0].1;
    assert_eq!(
        &source[then_branch.span.start as usize..then_branch.span.end as usize],
        "b = 1;"
    );
}

/// The course notes' scripts, with their two typos fixed, parse unchanged.
#[test]
fn course_notes_scripts() {
    let source = include_str!("course_notes.felt");
    let p = program(source);
    let funcs: Vec<&str> = p
        .items
        .iter()
        .filter_map(|i| match i {
            Item::Func(f) => Some(f.name.name.as_str()),
            _ => None,
        })
        .collect();
    assert_eq!(funcs, vec!["cumulo", "NoiseLayers"]);
    assert_eq!(p.items.len(), 27);
    let text = render(source);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines[0],
        "(decl scalarfield r = (sqrt (* (identity) (identity))))"
    );
    assert_eq!(lines[2], "(decl vector origin = (tuple -1 -1 -1))");
    assert_eq!(
        lines[6],
        "(decl domain d (origin lengths orientation cellSize cellSize))"
    );
    assert_eq!(lines[7], "(decl scalarcache rCache (d))");
    assert_eq!(
        lines[13],
        "(func scalarfield cumulo (scalarfield base, scalarfield[] displacementArray, \
         int iterations, domain[] doms) {(decl scalarfield out = base) \
         (for (decl int i = 0); (< i (size displacementArray)); (++ i) \
         {(decl vectorfield surfaceX = (levelsetsurface out iterations)) \
         (+= out (compose (abs (index displacementArray i)) surfaceX)) \
         (decl scalarcache outCache ((index doms i))) (cachewrite outCache out) \
         (= out (cacheread outCache))}) (return out)})"
    );
    assert_eq!(
        lines[19],
        "(decl scalarfield A = (/ (+ (scalarfield -1) (^ (+ (scalarfield 1) \
         (* (* 2.0 del) Gamma)) 0.5)) Gamma))"
    );
    assert_eq!(
        lines[18],
        "(decl scalarfield Gamma = (/ (* (* B M) B) (* B B)))"
    );
    assert_eq!(
        lines[26],
        "(render \"a.exr\" density=d step=0.01 lights=(array key))"
    );
}
