//! The server loop: read a message, answer it, and before blocking for the next one check the
//! buffers edited since their last check and publish what is wrong in them.
//!
//! The key decision is when to check. An edit only marks its buffer stale; every message that
//! follows within a millisecond is handled first (a burst of edits, or the keystrokes that
//! queued up while the last check ran), and only when none comes are the stale buffers
//! checked, once each, at their latest text (a burst holds a check back 50 ms at most). So queued edits cost one check, not one each. Requests are answered from the
//! buffer's text as of that request, stale or not; they never wait for a check. Each request
//! and each check runs under `catch_unwind`: a bug in felt becomes an error answer or an
//! internal-error diagnostic, and the editor keeps its server.

use super::documents::{Documents, path_of};
use super::outline::Outline;
use super::{completion, definition, diagnostics, hover, signature};
use lsp_server::{Connection, ErrorCode, Message, Notification, Request, Response};
use lsp_types::notification::{
    DidChangeTextDocument, DidCloseTextDocument, DidOpenTextDocument, DidSaveTextDocument,
    Notification as _, PublishDiagnostics,
};
use lsp_types::request::{
    Completion, DocumentSymbolRequest, GotoDefinition, HoverRequest, Request as _,
    SignatureHelpRequest,
};
use lsp_types::{
    CompletionOptions, CompletionResponse, DocumentSymbolResponse, GotoDefinitionResponse,
    HoverProviderCapability, OneOf, PublishDiagnosticsParams, ServerCapabilities,
    SignatureHelpOptions, TextDocumentPositionParams, TextDocumentSyncCapability,
    TextDocumentSyncKind, Url,
};
use std::collections::{BTreeMap, BTreeSet};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// Serves one editor on stdin and stdout until it says `exit` or closes the pipe.
pub fn serve() -> ExitCode {
    let (connection, io_threads) = Connection::stdio();
    let capabilities = ServerCapabilities {
        text_document_sync: Some(TextDocumentSyncCapability::Kind(
            TextDocumentSyncKind::INCREMENTAL,
        )),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec!["(".into(), ",".into(), "\"".into()]),
            ..CompletionOptions::default()
        }),
        signature_help_provider: Some(SignatureHelpOptions {
            trigger_characters: Some(vec!["(".into(), ",".into()]),
            ..SignatureHelpOptions::default()
        }),
        definition_provider: Some(OneOf::Left(true)),
        document_symbol_provider: Some(OneOf::Left(true)),
        ..ServerCapabilities::default()
    };
    let code = match serde_json::to_value(capabilities)
        .map_err(|e| e.to_string())
        .and_then(|c| connection.initialize(c).map_err(|e| e.to_string()))
    {
        Ok(_) => Server::default().run(&connection),
        Err(e) => {
            eprintln!("felt lsp: {e}");
            ExitCode::from(1)
        }
    };
    drop(connection);
    if let Err(e) = io_threads.join() {
        eprintln!("felt lsp: {e}");
        return ExitCode::from(1);
    }
    code
}

#[derive(Default)]
struct Server {
    documents: Documents,
    /// For each checked buffer, the other files it last published diagnostics to (imports),
    /// so a later check that finds them clean clears them.
    published: BTreeMap<Url, BTreeSet<Url>>,
}

/// How long after an edit the server waits for the next message before checking.
const GRACE: Duration = Duration::from_millis(1);
/// The longest a burst of messages may hold back a check.
const MOST_DELAY: Duration = Duration::from_millis(50);

/// What the loop does after a message.
enum Next {
    Continue,
    Stop(ExitCode),
}

impl Server {
    fn run(&mut self, connection: &Connection) -> ExitCode {
        loop {
            let Ok(message) = connection.receiver.recv() else {
                // The editor went away without `shutdown`: the protocol's exit status 1.
                return ExitCode::from(1);
            };
            if let Next::Stop(code) = self.handle(connection, message) {
                return code;
            }
            // Edits queued behind this one are read a message at a time (the reader thread
            // parses the next only once this one is taken), so wait briefly for each before
            // checking, but never past `MOST_DELAY` however fast they come.
            let deadline = Instant::now() + MOST_DELAY;
            while self.documents.any_stale() && Instant::now() < deadline {
                let Ok(message) = connection.receiver.recv_timeout(GRACE) else {
                    break;
                };
                if let Next::Stop(code) = self.handle(connection, message) {
                    return code;
                }
            }
            self.publish_stale(connection);
        }
    }

    fn handle(&mut self, connection: &Connection, message: Message) -> Next {
        match message {
            Message::Request(request) => match connection.handle_shutdown(&request) {
                Ok(true) => Next::Stop(ExitCode::SUCCESS),
                Ok(false) => {
                    let response = self.answer(&request);
                    let _ = connection.sender.send(Message::Response(response));
                    Next::Continue
                }
                Err(e) => {
                    eprintln!("felt lsp: {e}");
                    Next::Stop(ExitCode::from(1))
                }
            },
            Message::Notification(notification) if notification.method == "exit" => {
                // `exit` without `shutdown` first.
                Next::Stop(ExitCode::from(1))
            }
            Message::Notification(notification) => {
                self.notice(connection, notification);
                Next::Continue
            }
            Message::Response(_) => Next::Continue,
        }
    }

    fn notice(&mut self, connection: &Connection, notification: Notification) {
        match notification.method.as_str() {
            DidOpenTextDocument::METHOD => {
                if let Ok(p) = notification
                    .extract::<lsp_types::DidOpenTextDocumentParams>(DidOpenTextDocument::METHOD)
                {
                    let d = p.text_document;
                    self.documents.open(d.uri, d.text, d.version);
                }
            }
            DidChangeTextDocument::METHOD => {
                if let Ok(p) = notification.extract::<lsp_types::DidChangeTextDocumentParams>(
                    DidChangeTextDocument::METHOD,
                ) {
                    let d = p.text_document;
                    self.documents.change(&d.uri, p.content_changes, d.version);
                }
            }
            DidSaveTextDocument::METHOD => {
                // A saved file may be imported by another open buffer: check them all again.
                self.documents.mark_all_stale();
            }
            DidCloseTextDocument::METHOD => {
                if let Ok(p) = notification
                    .extract::<lsp_types::DidCloseTextDocumentParams>(DidCloseTextDocument::METHOD)
                {
                    let uri = p.text_document.uri;
                    self.documents.close(&uri);
                    let mut cleared = self.published.remove(&uri).unwrap_or_default();
                    cleared.insert(uri);
                    for uri in cleared {
                        publish(connection, uri, Vec::new(), None);
                    }
                }
            }
            _ => {}
        }
    }

    /// Checks each stale buffer and publishes its diagnostics, and clears those of files it
    /// no longer finds anything wrong in.
    fn publish_stale(&mut self, connection: &Connection) {
        for uri in self.documents.take_stale() {
            let Some(document) = self.documents.get(&uri) else {
                continue;
            };
            let found = catch_unwind(AssertUnwindSafe(|| diagnostics::check(&uri, document)))
                .unwrap_or_else(|_| {
                    let mut internal = BTreeMap::new();
                    internal.insert(uri.clone(), vec![internal_error()]);
                    internal
                });
            let version = Some(document.version);
            let before = self.published.remove(&uri).unwrap_or_default();
            let mut now = BTreeSet::new();
            let mut own = Vec::new();
            for (file, list) in found {
                if file == uri {
                    own = list;
                } else {
                    now.insert(file.clone());
                    publish(connection, file, list, None);
                }
            }
            for gone in before.difference(&now) {
                publish(connection, gone.clone(), Vec::new(), None);
            }
            // The buffer's own list last: a client that waits for it has seen the others.
            publish(connection, uri.clone(), own, version);
            self.published.insert(uri, now);
        }
    }

    /// The answer to a request about an open buffer.
    fn answer(&self, request: &Request) -> Response {
        let id = request.id.clone();
        let answered = catch_unwind(AssertUnwindSafe(|| self.result(request)));
        match answered {
            Ok(Ok(value)) => Response::new_ok(id, value),
            Ok(Err((code, message))) => Response::new_err(id, code as i32, message),
            Err(_) => Response::new_err(
                id,
                ErrorCode::InternalError as i32,
                "felt lsp: internal error; please report it, with the script".into(),
            ),
        }
    }

    fn result(&self, request: &Request) -> Result<serde_json::Value, (ErrorCode, String)> {
        let method = request.method.as_str();
        let invalid = |e: serde_json::Error| (ErrorCode::InvalidParams, e.to_string());
        let json = |value: serde_json::Result<serde_json::Value>| {
            value.map_err(|e| (ErrorCode::InternalError, e.to_string()))
        };
        match method {
            HoverRequest::METHOD
            | Completion::METHOD
            | SignatureHelpRequest::METHOD
            | GotoDefinition::METHOD => {
                let at: TextDocumentPositionParams =
                    serde_json::from_value(request.params.clone()).map_err(invalid)?;
                let uri = at.text_document.uri;
                let Some(document) = self.documents.get(&uri) else {
                    return Ok(serde_json::Value::Null);
                };
                let text = &document.text;
                let offset = document.lines.offset(text, at.position);
                let outline = Outline::new(text);
                let path = path_of(&uri);
                json(match method {
                    HoverRequest::METHOD => {
                        serde_json::to_value(hover::hover(&path, text, &outline, offset))
                    }
                    Completion::METHOD => serde_json::to_value(CompletionResponse::Array(
                        completion::complete(&path, text, &outline, offset),
                    )),
                    SignatureHelpRequest::METHOD => serde_json::to_value(
                        signature::signature_help(&path, text, &outline, offset),
                    ),
                    _ => serde_json::to_value(
                        definition::definition(
                            &uri,
                            &path,
                            text,
                            &document.lines,
                            &outline,
                            offset,
                        )
                        .map(GotoDefinitionResponse::Scalar),
                    ),
                })
            }
            DocumentSymbolRequest::METHOD => {
                let p: lsp_types::DocumentSymbolParams =
                    serde_json::from_value(request.params.clone()).map_err(invalid)?;
                let Some(document) = self.documents.get(&p.text_document.uri) else {
                    return Ok(serde_json::Value::Null);
                };
                let outline = Outline::new(&document.text);
                let symbols = definition::symbols(&document.text, &document.lines, &outline);
                json(serde_json::to_value(DocumentSymbolResponse::Nested(
                    symbols,
                )))
            }
            _ => Err((
                ErrorCode::MethodNotFound,
                format!("felt lsp does not answer `{method}`"),
            )),
        }
    }
}

fn publish(
    connection: &Connection,
    uri: Url,
    diagnostics: Vec<lsp_types::Diagnostic>,
    version: Option<i32>,
) {
    let params = PublishDiagnosticsParams {
        uri,
        diagnostics,
        version,
    };
    let _ = connection
        .sender
        .send(Message::Notification(Notification::new(
            PublishDiagnostics::METHOD.to_string(),
            params,
        )));
}

/// What a buffer shows when checking it hit a bug in felt.
fn internal_error() -> lsp_types::Diagnostic {
    lsp_types::Diagnostic {
        severity: Some(lsp_types::DiagnosticSeverity::ERROR),
        source: Some("felt".into()),
        message: "felt lsp: internal error while checking this file; please report it, with \
                  the script"
            .into(),
        ..lsp_types::Diagnostic::default()
    }
}
