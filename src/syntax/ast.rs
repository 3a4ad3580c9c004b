//! The abstract syntax tree of a felt script, exactly as written: no types resolved, no names
//! bound. Every node carries the `Span` of its text, because the checker and the interpreter
//! report errors in the script author's terms, pointing at what they wrote.
//!
//! Vector and matrix literals are both parenthesised lists (`(1, 2, 3)`,
//! `((1,0,0),(0,1,0),(0,0,1))`); the parser produces `ExprKind::Tuple` and the checker decides
//! which it is from the element types.
//!
//! The shapes that scripts repeat without nesting are flat: a chain of binary operators
//! (`1 + 1 + ... + 1`) is one `Binary` node with a list of operations, and an `else if` chain
//! one `If` with a list of branches. Every pass over the tree (checking, running, dropping,
//! cloning) recurses, and so goes only as deep as the script really nests, which the parser
//! bounds.

use super::span::Span;
use std::collections::VecDeque;

/// A whole source file.
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub items: Vec<Item>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Item {
    Func(FuncDecl),
    Import(Import),
    Stmt(Stmt),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Import {
    /// The path as written, relative to the importing file.
    pub path: String,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Ident {
    pub name: String,
    pub span: Span,
}

/// The element types a script can name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BaseType {
    Int,
    Float,
    Bool,
    String,
    Vector,
    Matrix,
    ScalarField,
    VectorField,
    MatrixField,
    Domain,
    ScalarCache,
    VectorCache,
    MatrixCache,
    Shape,
    Particles,
    Camera,
    Light,
    CloudSim,
    Void,
}

impl BaseType {
    /// The keyword that names this type in scripts.
    pub fn keyword(self) -> &'static str {
        match self {
            BaseType::Int => "int",
            BaseType::Float => "float",
            BaseType::Bool => "bool",
            BaseType::String => "string",
            BaseType::Vector => "vector",
            BaseType::Matrix => "matrix",
            BaseType::ScalarField => "scalarfield",
            BaseType::VectorField => "vectorfield",
            BaseType::MatrixField => "matrixfield",
            BaseType::Domain => "domain",
            BaseType::ScalarCache => "scalarcache",
            BaseType::VectorCache => "vectorcache",
            BaseType::MatrixCache => "matrixcache",
            BaseType::Shape => "shape",
            BaseType::Particles => "particles",
            BaseType::Camera => "camera",
            BaseType::Light => "light",
            BaseType::CloudSim => "cloudsim",
            BaseType::Void => "void",
        }
    }
}

/// A type as written: a base type with zero or more `[]`.
#[derive(Clone, Debug, PartialEq)]
pub struct TypeExpr {
    pub base: BaseType,
    pub array_depth: u8,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub ty: TypeExpr,
    pub name: Ident,
    pub span: Span,
}

/// `func RET name(params) { body }`
#[derive(Clone, Debug, PartialEq)]
pub struct FuncDecl {
    pub ret: TypeExpr,
    pub name: Ident,
    pub params: Vec<Param>,
    pub body: Block,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Block {
    pub stmts: Vec<Stmt>,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Stmt {
    pub kind: StmtKind,
    pub span: Span,
}

/// How a declaration gets its first value.
#[derive(Clone, Debug, PartialEq)]
pub enum DeclInit {
    /// `float x;` — the type's default value.
    Default,
    /// `float x = e;`
    Expr(Expr),
    /// `domain d(a, b, c);` — constructor form, the arguments of the type's constructor.
    Ctor(Vec<Arg>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssignOp {
    Set,
    Add,
    Sub,
    Mul,
    Div,
}

#[derive(Clone, Debug, PartialEq)]
pub enum StmtKind {
    /// `[param] TYPE name [= e | (args)];`
    Decl {
        is_param: bool,
        ty: TypeExpr,
        name: Ident,
        init: DeclInit,
    },
    /// `e;`
    Expr(Expr),
    /// `target op= value;` where target is a variable or an indexed element.
    Assign {
        target: Expr,
        op: AssignOp,
        value: Expr,
    },
    /// `target++;` / `target--;` (also prefix forms)
    IncDec {
        target: Expr,
        increment: bool,
    },
    /// `if (c1) B1 else if (c2) B2 ... else E`: each condition with its block, in order, then
    /// the final `else`. An `else if` chain is one statement however long it is, so that the
    /// passes over the tree go no deeper for it. The parser meets the last `else if` first and
    /// adds each earlier one in front, hence a deque.
    If {
        branches: VecDeque<(Expr, Block)>,
        else_branch: Option<Block>,
    },
    For {
        init: Option<Box<Stmt>>,
        cond: Option<Expr>,
        step: Option<Box<Stmt>>,
        body: Block,
    },
    While {
        cond: Expr,
        body: Block,
    },
    Break,
    Continue,
    Return(Option<Expr>),
    Block(Block),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnaryOp {
    Neg,
    Not,
    /// Unary `+`, kept so that spans and printing stay faithful.
    Plus,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Rem,
    Pow,
    Eq,
    Ne,
    Lt,
    Le,
    Gt,
    Ge,
    And,
    Or,
}

impl BinaryOp {
    pub fn symbol(self) -> &'static str {
        match self {
            BinaryOp::Add => "+",
            BinaryOp::Sub => "-",
            BinaryOp::Mul => "*",
            BinaryOp::Div => "/",
            BinaryOp::Rem => "%",
            BinaryOp::Pow => "^",
            BinaryOp::Eq => "==",
            BinaryOp::Ne => "!=",
            BinaryOp::Lt => "<",
            BinaryOp::Le => "<=",
            BinaryOp::Gt => ">",
            BinaryOp::Ge => ">=",
            BinaryOp::And => "&&",
            BinaryOp::Or => "||",
        }
    }
}

/// One step of a `Binary` chain: `op operand`, with the span of the chain up to this step's
/// operand (what `a + b` covers in `a + b + c`), where an error of this step points.
#[derive(Clone, Debug, PartialEq)]
pub struct Operation {
    pub op: BinaryOp,
    pub operand: Expr,
    pub span: Span,
}

/// A call argument, optionally named (`step = 0.01`; builtins only).
#[derive(Clone, Debug, PartialEq)]
pub struct Arg {
    pub name: Option<Ident>,
    pub value: Expr,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    Int(i64),
    Float(f64),
    Bool(bool),
    Str(String),
    Var(Ident),
    /// `(a, b, c)`: a vector literal, or a matrix literal when the elements are vectors.
    Tuple(Vec<Expr>),
    /// `{a, b, c}`: an array literal.
    Array(Vec<Expr>),
    Unary(UnaryOp, Box<Expr>),
    /// `a + b * c - d`: an operand and the operations applied to it in turn, left to right
    /// (`(a + (b * c)) - d` here). A run of left-associative operators is one node however
    /// long it is, so that the passes over the tree recurse only as deep as the script nests;
    /// the right-associative `^` nests, one operation per node.
    Binary(Box<Expr>, Vec<Operation>),
    /// `name(args)`; `name` may be a type keyword used as a constructor (`scalarfield(1.0)`).
    Call {
        callee: Ident,
        args: Vec<Arg>,
    },
    /// `a[i]`
    Index(Box<Expr>, Box<Expr>),
    /// `v.x`
    Member(Box<Expr>, Ident),
}
