#!/usr/bin/env node
// Writes the names of felt's builtins and standard-library functions into the TextMate
// grammar, from what `felt doc` lists, so that highlighting knows every callable name the
// checker knows. Run it after adding or renaming a builtin or a library function:
//
//     node editors/vscode/scripts/update-builtins.js [path/to/felt]
//
// (default: target/debug/felt, then `felt` on PATH). felt's test suite fails while the
// grammar's lists differ from felt's (tests/tree_sitter.rs).

const { execFileSync } = require('child_process');
const fs = require('fs');
const path = require('path');

const root = path.resolve(__dirname, '..', '..', '..');
const grammarPath = path.resolve(__dirname, '..', 'syntaxes', 'felt.tmLanguage.json');

function feltProgram() {
  if (process.argv[2]) return process.argv[2];
  const built = path.join(root, 'target', 'debug', 'felt');
  return fs.existsSync(built) ? built : 'felt';
}

// `felt doc` prints each group's name on a line of its own, then one `  name  summary` line
// per entry; the last group is the standard library.
function listFunctions(index) {
  const builtins = [];
  const library = [];
  let group = null;
  for (const line of index.split('\n')) {
    const entry = /^ {2}([A-Za-z_][A-Za-z0-9_]*)\s/.exec(line);
    if (entry && group !== null) {
      (group === 'standard library' ? library : builtins).push(entry[1]);
    } else if (/^\S/.test(line) && !line.startsWith('`')) {
      group = line.trim();
    }
  }
  return { builtins: [...new Set(builtins)].sort(), library: [...new Set(library)].sort() };
}

// A name from the list followed by `(`: `camera` is a type where it declares and a builtin
// where it is called.
function callOf(names) {
  return `\\b(?:${names.join('|')})\\b(?=\\s*\\()`;
}

const index = execFileSync(feltProgram(), ['doc'], { encoding: 'utf8' });
const { builtins, library } = listFunctions(index);
if (builtins.length === 0 || library.length === 0) {
  throw new Error('`felt doc` listed no builtins or no library functions');
}
const grammar = JSON.parse(fs.readFileSync(grammarPath, 'utf8'));
grammar.repository['builtin-functions'].match = callOf(builtins);
grammar.repository['library-functions'].match = callOf(library);
fs.writeFileSync(grammarPath, JSON.stringify(grammar, null, 2) + '\n');
console.log(`${builtins.length} builtins, ${library.length} library functions`);
