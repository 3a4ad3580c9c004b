; Scopes, definitions and references, for editors that highlight a name by what it refers to.
; Functions are visible in the whole file; blocks, function bodies and `for` headers open
; lexical scopes.

[
  (source_file)
  (function_definition)
  (block)
  (for_statement)
] @local.scope

(function_definition
  name: (identifier) @local.definition)

(parameter
  name: (identifier) @local.definition)

(declarator
  name: (identifier) @local.definition)

(identifier) @local.reference
