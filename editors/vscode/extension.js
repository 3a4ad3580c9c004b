// The felt extension: starts `felt lsp` over stdio for .felt files and restarts it when the
// path of the felt program changes. Highlighting comes from syntaxes/felt.tmLanguage.json;
// everything else (diagnostics, hover, completion, navigation) from the server.

const vscode = require('vscode');
const { LanguageClient } = require('vscode-languageclient/node');

/** @type {LanguageClient | undefined} */
let client;

function startClient() {
  const command = vscode.workspace.getConfiguration('felt').get('path') || 'felt';
  // An Executable without a transport talks over the child's stdin and stdout.
  const serverOptions = { command, args: ['lsp'] };
  const clientOptions = {
    documentSelector: [
      { scheme: 'file', language: 'felt' },
      { scheme: 'untitled', language: 'felt' },
    ],
  };
  client = new LanguageClient('felt', 'felt', serverOptions, clientOptions);
  return client.start().catch((error) => {
    vscode.window.showErrorMessage(
      `felt: could not start \`${command} lsp\` (${error.message}); ` +
        'set felt.path to the felt program.',
    );
  });
}

async function stopClient() {
  if (client) {
    const running = client;
    client = undefined;
    await running.stop();
  }
}

/** @param {vscode.ExtensionContext} context */
function activate(context) {
  context.subscriptions.push(
    vscode.workspace.onDidChangeConfiguration(async (event) => {
      if (event.affectsConfiguration('felt.path')) {
        await stopClient();
        await startClient();
      }
    }),
  );
  return startClient();
}

function deactivate() {
  return stopClient();
}

module.exports = { activate, deactivate };
