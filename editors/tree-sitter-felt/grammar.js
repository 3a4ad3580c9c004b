/**
 * @file Tree-sitter grammar for felt, the field-expression language for volumetric effects.
 *
 * felt's own parser (grammar/felt.lalrpop, with the logos lexer in src/syntax/lexer.rs) is
 * the definition; docs/language.md is the reference. This grammar accepts the same scripts,
 * and also rejects, with ERROR nodes, most of what felt's parser reports as a syntax error
 * after parsing: `param` below the top level, `func` and `import` inside a block, an
 * assignment or `++`/`--` to something other than a variable or an array element, and a
 * positional argument after a keyword one. It is more lenient in a few corners: an array
 * literal `{a, b};` may start an expression statement (felt reads `{` there as a block);
 * where `++` or `--` cannot stand, `a++b` reads as `a + +b` (felt's lexer always takes the
 * longest operator); and it checks neither the range of number literals nor nesting depth.
 */

/// <reference types="tree-sitter-cli/dsl" />
// @ts-check

// Precedence, loosest to tightest, as in grammar/felt.lalrpop.
const PREC = {
  or: 1,
  and: 2,
  equality: 3,
  comparison: 4,
  sum: 5,
  product: 6,
  prefix: 7,
  // `^` binds tighter than prefix minus (`-2^2` is `-(2^2)`) and its right operand may
  // carry prefix operators (`2^-1`).
  power: 8,
  postfix: 9,
};

// Every type a value can have; `scalarmcache` is the same keyword as `scalarcache`.
const VALUE_TYPES = [
  'int', 'float', 'bool', 'string', 'vector', 'matrix',
  'scalarfield', 'vectorfield', 'matrixfield', 'domain',
  'scalarcache', 'scalarmcache', 'vectorcache', 'matrixcache',
  'shape', 'particles', 'camera', 'light', 'cloudsim',
];

/**
 * One or more `rule` separated by commas, no trailing comma.
 * @param {RuleOrLiteral} rule
 */
function commaSep1(rule) {
  return seq(rule, repeat(seq(',', rule)));
}

/**
 * Zero or more `rule` separated by commas.
 * @param {RuleOrLiteral} rule
 */
function commaSep(rule) {
  return optional(commaSep1(rule));
}

export default grammar({
  name: 'felt',

  // felt's whitespace is exactly these characters; a byte-order mark is skipped too (felt
  // skips it at the start of a file only).
  extras: $ => [/[ \t\r\n\f]/, /\uFEFF/, $.comment],

  word: $ => $.identifier,

  // felt's lexer makes every keyword a keyword wherever it stands, so none may be a name.
  reserved: {
    global: _ => [
      ...VALUE_TYPES, 'void', 'func', 'return', 'if', 'else', 'for', 'while', 'break',
      'continue', 'true', 'false', 'param', 'import',
    ],
  },

  supertypes: $ => [$._statement, $._expression],

  conflicts: $ => [
    // At the start of a statement `a[i]` may still become an assignment target or stay an
    // expression; the token after `]` decides.
    [$._expression, $._assignable],
  ],

  rules: {
    source_file: $ => repeat($._top_level_item),

    // Functions, imports and `param` declarations live only at the top level.
    _top_level_item: $ => choice(
      $.function_definition,
      $.import_statement,
      $.param_declaration,
      $._statement,
    ),

    comment: _ => token(choice(
      seq('//', /[^\n]*/),
      seq('/*', /[^*]*\*+([^/*][^*]*\*+)*/, '/'),
    )),

    // ---------------------------------------------------------------------------------
    // Top-level items.

    // `func RET name(T a, T b) { ... }`
    function_definition: $ => seq(
      'func',
      field('return_type', choice($._type, alias('void', $.primitive_type))),
      field('name', $.identifier),
      field('parameters', $.parameter_list),
      field('body', $.block),
    ),

    parameter_list: $ => seq('(', commaSep($.parameter), ')'),

    parameter: $ => seq(field('type', $._type), field('name', $.identifier)),

    // `import "path";`
    import_statement: $ => seq('import', field('path', $.string), ';'),

    // `param float step = 0.01;`: an input of the script, set with `--set`.
    param_declaration: $ => seq(
      'param',
      field('type', $._type),
      commaSep1(field('declarator', $.declarator)),
      ';',
    ),

    // ---------------------------------------------------------------------------------
    // Types: a base type keyword followed by zero or more `[]`.

    _type: $ => choice($.primitive_type, $.array_type),

    array_type: $ => seq(field('element', $._type), '[', ']'),

    primitive_type: _ => choice(...VALUE_TYPES),

    // ---------------------------------------------------------------------------------
    // Statements.

    _statement: $ => choice(
      $.declaration,
      $.expression_statement,
      $.break_statement,
      $.continue_statement,
      $.return_statement,
      $.empty_statement,
      $.block,
      $.if_statement,
      $.while_statement,
      $.for_statement,
    ),

    // `T a, b = e, c(args);`
    declaration: $ => seq(
      field('type', $._type),
      commaSep1(field('declarator', $.declarator)),
      ';',
    ),

    // `name`, `name = value`, or the constructor form `name(args)`.
    declarator: $ => seq(
      field('name', $.identifier),
      optional(choice(
        seq('=', field('value', $._expression)),
        field('arguments', $.argument_list),
      )),
    ),

    expression_statement: $ => seq($._expression_statement_body, ';'),

    // What may stand as a statement, or as a `for` header's initialiser or step.
    _expression_statement_body: $ => choice($._expression, $.assignment, $.update),

    // `x = e`, `a[i] += e`, ...
    assignment: $ => seq(
      field('left', $._assignable),
      field('operator', choice('=', '+=', '-=', '*=', '/=')),
      field('right', $._expression),
    ),

    // `x++`, `x--`, `++x`, `--x`
    update: $ => choice(
      seq(field('argument', $._assignable), field('operator', choice('++', '--'))),
      seq(field('operator', choice('++', '--')), field('argument', $._assignable)),
    ),

    // Only variables and array elements (`x`, `a[i]`, `a[i][j]`) can be assigned to.
    _assignable: $ => choice(
      $.identifier,
      alias($.assignable_index, $.index_expression),
    ),

    assignable_index: $ => seq(
      field('target', $._assignable),
      '[',
      field('index', $._expression),
      ']',
    ),

    break_statement: _ => seq('break', ';'),

    continue_statement: _ => seq('continue', ';'),

    return_statement: $ => seq('return', optional(field('value', $._expression)), ';'),

    empty_statement: _ => ';',

    block: $ => prec(1, seq('{', repeat($._statement), '}')),

    // `else` belongs to the nearest `if`.
    if_statement: $ => prec.right(seq(
      'if',
      '(',
      field('condition', $._expression),
      ')',
      field('consequence', $._statement),
      optional(seq('else', field('alternative', $._statement))),
    )),

    while_statement: $ => seq(
      'while',
      '(',
      field('condition', $._expression),
      ')',
      field('body', $._statement),
    ),

    for_statement: $ => seq(
      'for',
      '(',
      optional(field('initializer', choice(
        alias($.for_declaration, $.declaration),
        $._expression_statement_body,
      ))),
      ';',
      optional(field('condition', $._expression)),
      ';',
      optional(field('update', $._expression_statement_body)),
      ')',
      field('body', $._statement),
    ),

    // A `for` header declares one variable.
    for_declaration: $ => seq(field('type', $._type), field('declarator', $.declarator)),

    // ---------------------------------------------------------------------------------
    // Expressions.

    _expression: $ => choice(
      $.binary_expression,
      $.unary_expression,
      $.index_expression,
      $.member_expression,
      $.call_expression,
      $.parenthesized_expression,
      $.tuple_expression,
      $.array_expression,
      $.identifier,
      $.integer,
      $.float,
      $.string,
      $.true,
      $.false,
    ),

    binary_expression: $ => {
      /** @type {[string, number][]} */
      const left = [
        ['||', PREC.or],
        ['&&', PREC.and],
        ['==', PREC.equality],
        ['!=', PREC.equality],
        ['<', PREC.comparison],
        ['<=', PREC.comparison],
        ['>', PREC.comparison],
        ['>=', PREC.comparison],
        ['+', PREC.sum],
        ['-', PREC.sum],
        ['*', PREC.product],
        ['/', PREC.product],
        ['%', PREC.product],
      ];
      return choice(
        ...left.map(([operator, precedence]) => prec.left(precedence, seq(
          field('left', $._expression),
          field('operator', operator),
          field('right', $._expression),
        ))),
        prec.right(PREC.power, seq(
          field('left', $._expression),
          field('operator', '^'),
          field('right', $._expression),
        )),
      );
    },

    unary_expression: $ => prec(PREC.prefix, seq(
      field('operator', choice('-', '!', '+')),
      field('operand', $._expression),
    )),

    index_expression: $ => prec(PREC.postfix, seq(
      field('target', $._expression),
      '[',
      field('index', $._expression),
      ']',
    )),

    // `v.x`: the member name is any identifier; the checker knows which ones exist.
    member_expression: $ => prec(PREC.postfix, seq(
      field('object', $._expression),
      '.',
      field('member', $.identifier),
    )),

    // `noise(x)`, or a type keyword called as a constructor: `scalarfield(1.0)`.
    call_expression: $ => seq(
      field('function', choice($.identifier, $.primitive_type)),
      field('arguments', $.argument_list),
    ),

    // Positional arguments first, then keyword arguments `name = value`.
    argument_list: $ => seq(
      '(',
      optional(choice(
        seq(commaSep1($._expression), optional(seq(',', commaSep1($.keyword_argument)))),
        commaSep1($.keyword_argument),
      )),
      ')',
    ),

    // A keyword argument's name: an identifier, or a type word (`camera = cam`).
    keyword_argument: $ => seq(
      field('name', choice($.identifier, $.primitive_type)),
      '=',
      field('value', $._expression),
    ),

    parenthesized_expression: $ => seq('(', $._expression, ')'),

    // Two or more elements: a vector, or a matrix when the elements are vectors.
    tuple_expression: $ => seq('(', $._expression, ',', commaSep1($._expression), ')'),

    // `{a, b, c}`: an array.
    array_expression: $ => seq('{', commaSep($._expression), '}'),

    identifier: _ => /[A-Za-z_][A-Za-z0-9_]*/,

    integer: _ => /[0-9]+/,

    // `1.5`, `1.`, `.5`, `1e-3`, `2.0e+4`.
    float: _ => token(choice(
      /[0-9]+\.[0-9]*([eE][+-]?[0-9]+)?/,
      /\.[0-9]+([eE][+-]?[0-9]+)?/,
      /[0-9]+[eE][+-]?[0-9]+/,
    )),

    // Strings may span lines; the escapes are `\" \\ \n \t`, any other is an error.
    string: $ => seq(
      '"',
      repeat(choice(
        alias(token.immediate(prec(1, /[^"\\]+/)), $.string_content),
        $.escape_sequence,
      )),
      token.immediate('"'),
    ),

    escape_sequence: _ => token.immediate(seq('\\', /["\\nt]/)),

    true: _ => 'true',

    false: _ => 'false',
  },
});
