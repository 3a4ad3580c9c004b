; Syntax highlighting for felt. Capture names follow the common set that Neovim, Helix and
; Zed themes colour. Neovim lets the last matching pattern win and Helix the first, so no two
; patterns here capture the same node.

(comment) @comment

; Literals

(string) @string
(escape_sequence) @string.escape
(integer) @number
(float) @number.float
[
  (true)
  (false)
] @boolean

; Types

(primitive_type) @type.builtin

; Declarations

(function_definition
  name: (identifier) @function)

(parameter
  name: (identifier) @variable.parameter)

(declaration
  (declarator
    name: (identifier) @variable))

(param_declaration
  (declarator
    name: (identifier) @constant))

; Calls: a type keyword called as a constructor is a type; a name is a function.

(call_expression
  function: (identifier) @function.call)

(call_expression
  function: (primitive_type) @constructor)

(keyword_argument
  name: (_) @variable.parameter)

(member_expression
  member: (identifier) @property)

; Keywords

[
  "if"
  "else"
] @keyword.conditional

[
  "for"
  "while"
  "break"
  "continue"
] @keyword.repeat

"return" @keyword.return

"func" @keyword.function

"import" @keyword.import

"param" @keyword.modifier

; Operators and punctuation

[
  "+"
  "-"
  "*"
  "/"
  "%"
  "^"
  "=="
  "!="
  "<"
  "<="
  ">"
  ">="
  "&&"
  "||"
  "!"
  "="
  "+="
  "-="
  "*="
  "/="
  "++"
  "--"
] @operator

[
  "("
  ")"
  "["
  "]"
  "{"
  "}"
] @punctuation.bracket

[
  ","
  ";"
  "."
] @punctuation.delimiter
