//! Owns `driveset lsp`, the language server of set files (TOML, YAML) and
//! line manifests over stdio (docs/editors.md): request dispatch and the
//! capabilities it declares, on `lsp-server`'s messages (the synchronous
//! scaffold of rust-analyzer), `driveset-lsp-base`'s frames and
//! `lsp-types`, over each open document's analysis
//! (`driveset_ide::document`, converted in `analysis`): incremental text
//! sync, diagnostics after every open and change, hover with a code's
//! facts, completion of code keys and selection texts, go to a code's
//! entry in its schema file, and code actions for the findings with a
//! mechanical fix.

pub mod analysis;
pub mod uri;

use std::collections::HashMap;
use std::path::PathBuf;

use driveset_schema::Registry;
use lsp_server::{Message, Notification, Request, Response};
use lsp_types::{
    CodeAction, CodeActionKind, CodeActionOrCommand, CodeActionParams,
    CodeActionProviderCapability, CompletionItem, CompletionItemKind, CompletionOptions,
    CompletionParams, CompletionTextEdit, Diagnostic, DidChangeTextDocumentParams,
    DidCloseTextDocumentParams, DidOpenTextDocumentParams, Documentation, GotoDefinitionParams,
    Hover, HoverContents, HoverParams, HoverProviderCapability, Location, MarkupContent,
    MarkupKind, OneOf, Position, PublishDiagnosticsParams, Range, ServerCapabilities,
    TextDocumentSyncCapability, TextDocumentSyncKind, TextEdit, Uri, WorkspaceEdit,
};
use serde_json::Value;

use driveset_ide::document::OpenDocument;
use driveset_ide::navigate::{self, Completion, CompletionKind, Insert};
use driveset_ide::text::Text;
use driveset_lsp_base as frame;

use analysis::{line_col, range};

/// Options of the server (`driveset lsp`'s arguments).
#[derive(Debug, Clone, Default)]
pub struct Config {
    /// Schema directories loaded beside the built-in schemas (`--schemas`).
    pub schemas: Vec<PathBuf>,
    /// Where read-only copies of the built-in schema files are written for
    /// go to definition (default: the user's cache directory).
    pub cache_dir: Option<PathBuf>,
}

struct Doc {
    doc: OpenDocument,
    version: i32,
}

/// The server's state: open documents and the schema registry.
pub struct Server {
    docs: HashMap<String, Doc>,
    /// The document of the last completion, whose items `resolve` fills.
    completed: Option<String>,
    registry: Registry,
    cache_dir: PathBuf,
}

/// The capabilities `driveset lsp` announces.
pub fn capabilities() -> ServerCapabilities {
    ServerCapabilities {
        text_document_sync: Some(TextDocumentSyncCapability::Kind(
            TextDocumentSyncKind::INCREMENTAL,
        )),
        hover_provider: Some(HoverProviderCapability::Simple(true)),
        completion_provider: Some(CompletionOptions {
            trigger_characters: Some(vec!["\"".into(), "=".into(), ":".into(), " ".into()]),
            // a code's facts are sent when an item is chosen, not with all 600
            resolve_provider: Some(true),
            ..CompletionOptions::default()
        }),
        definition_provider: Some(OneOf::Left(true)),
        code_action_provider: Some(CodeActionProviderCapability::Simple(true)),
        ..ServerCapabilities::default()
    }
}

/// Serve LSP over stdin / stdout until the client says `exit` or closes
/// stdin.
pub fn serve(config: Config) -> anyhow::Result<()> {
    let server = Server::new(&config)?;
    let stdin = std::io::stdin().lock();
    let mut stdout = std::io::stdout().lock();
    run(frame::Reader::new(stdin), &mut stdout, server)
}

/// The JSON-RPC error of a request the server does not take now.
fn refuse(req: &Request, code: lsp_server::ErrorCode, message: &str) -> Message {
    Message::Response(Response::new_err(
        req.id.clone(),
        code as i32,
        message.into(),
    ))
}

/// The server's loop: the lifecycle (initialize, shutdown, exit; LSP 3.17
/// "Lifecycle Messages") around [`Server::request`] and
/// [`Server::notify`]; a refused frame is answered and reading goes on
/// (`driveset_lsp_base`).
fn run(
    mut reader: frame::Reader<impl std::io::BufRead>,
    w: &mut impl std::io::Write,
    mut server: Server,
) -> anyhow::Result<()> {
    let mut initialized = false;
    let mut shut_down = false;
    loop {
        let msg = match reader.read()? {
            frame::Frame::Eof => return Ok(()),
            frame::Frame::Refused(e) => {
                frame::write(w, &e)?;
                continue;
            }
            frame::Frame::Message(m) => m,
        };
        let out: Vec<Message> = match msg {
            Message::Request(req) if req.method == "initialize" => {
                if initialized {
                    vec![refuse(
                        &req,
                        lsp_server::ErrorCode::InvalidRequest,
                        "the server is initialized already",
                    )]
                } else {
                    initialized = true;
                    vec![Message::Response(Response::new_ok(
                        req.id,
                        lsp_types::InitializeResult {
                            capabilities: capabilities(),
                            server_info: None,
                        },
                    ))]
                }
            }
            Message::Request(req) if !initialized => vec![refuse(
                &req,
                lsp_server::ErrorCode::ServerNotInitialized,
                "send `initialize` first",
            )],
            Message::Request(req) if shut_down => vec![refuse(
                &req,
                lsp_server::ErrorCode::InvalidRequest,
                "the server is shut down; send `exit`",
            )],
            Message::Request(req) if req.method == "shutdown" => {
                shut_down = true;
                vec![Message::Response(Response::new_ok(req.id, Value::Null))]
            }
            Message::Request(req) => vec![Message::Response(server.request(req))],
            Message::Notification(n) if n.method == "exit" => return Ok(()),
            Message::Notification(n) if initialized && !shut_down => server
                .notify(n)
                .into_iter()
                .map(Message::Notification)
                .collect(),
            Message::Notification(_) | Message::Response(_) => Vec::new(),
        };
        for m in &out {
            frame::write_message(w, m)?;
        }
    }
}

fn default_cache_dir() -> PathBuf {
    let base = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .filter(|p| p.is_absolute())
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(std::env::temp_dir);
    base.join("driveset").join(env!("CARGO_PKG_VERSION"))
}

impl Server {
    /// A server with the built-in schemas and those of `config.schemas`.
    pub fn new(config: &Config) -> anyhow::Result<Self> {
        let registry = crate::output::registry(&config.schemas)
            .map_err(|e| anyhow::anyhow!("{}: {}", e.location, e.message))?;
        Ok(Server {
            docs: HashMap::new(),
            completed: None,
            registry,
            cache_dir: config.cache_dir.clone().unwrap_or_else(default_cache_dir),
        })
    }

    fn notify(&mut self, n: Notification) -> Vec<Notification> {
        match n.method.as_str() {
            "textDocument/didOpen" => {
                let Ok(p) = serde_json::from_value::<DidOpenTextDocumentParams>(n.params) else {
                    return Vec::new();
                };
                let key = p.text_document.uri.as_str().to_string();
                let Some(path) = uri::to_path(&p.text_document.uri) else {
                    return Vec::new();
                };
                self.docs.insert(
                    key.clone(),
                    Doc {
                        doc: OpenDocument::new(path, p.text_document.text),
                        version: p.text_document.version,
                    },
                );
                self.publish(&key)
            }
            "textDocument/didChange" => {
                let Ok(p) = serde_json::from_value::<DidChangeTextDocumentParams>(n.params) else {
                    return Vec::new();
                };
                let key = p.text_document.uri.as_str().to_string();
                let Some(doc) = self.docs.get_mut(&key) else {
                    return Vec::new();
                };
                for c in p.content_changes {
                    let r = c.range.map(|r| line_col(r.start)..line_col(r.end));
                    doc.doc.edit(r, &c.text);
                }
                doc.version = p.text_document.version;
                self.publish(&key)
            }
            "textDocument/didClose" => {
                if let Ok(p) = serde_json::from_value::<DidCloseTextDocumentParams>(n.params) {
                    self.docs.remove(p.text_document.uri.as_str());
                    return vec![diagnostics_notification(
                        p.text_document.uri,
                        Vec::new(),
                        None,
                    )];
                }
                Vec::new()
            }
            _ => Vec::new(),
        }
    }

    /// Analyse a document and say its diagnostics.
    fn publish(&mut self, key: &str) -> Vec<Notification> {
        let Some(doc) = self.docs.get_mut(key) else {
            return Vec::new();
        };
        let diagnostics = analysis::diagnostics(&mut doc.doc, &mut self.registry);
        let Ok(uri) = key.parse::<Uri>() else {
            return Vec::new();
        };
        vec![diagnostics_notification(
            uri,
            diagnostics,
            Some(doc.version),
        )]
    }

    fn request(&mut self, req: Request) -> Response {
        let id = req.id.clone();
        let result = match req.method.as_str() {
            "textDocument/hover" => {
                serde_json::from_value::<HoverParams>(req.params)
                    .ok()
                    .map(|p| {
                        let pos = p.text_document_position_params;
                        serde_json::to_value(
                            self.hover(pos.text_document.uri.as_str(), pos.position),
                        )
                    })
            }
            "textDocument/completion" => serde_json::from_value::<CompletionParams>(req.params)
                .ok()
                .map(|p| {
                    let pos = p.text_document_position;
                    self.completed = Some(pos.text_document.uri.as_str().to_string());
                    serde_json::to_value(
                        self.completion(pos.text_document.uri.as_str(), pos.position),
                    )
                }),
            "textDocument/definition" => serde_json::from_value::<GotoDefinitionParams>(req.params)
                .ok()
                .map(|p| {
                    let pos = p.text_document_position_params;
                    serde_json::to_value(
                        self.definition(pos.text_document.uri.as_str(), pos.position),
                    )
                }),
            "completionItem/resolve" => serde_json::from_value::<CompletionItem>(req.params)
                .ok()
                .map(|item| serde_json::to_value(self.resolve(item))),
            "textDocument/codeAction" => serde_json::from_value::<CodeActionParams>(req.params)
                .ok()
                .map(|p| serde_json::to_value(code_actions(&p))),
            _ => {
                return Response::new_err(
                    id,
                    lsp_server::ErrorCode::MethodNotFound as i32,
                    format!("driveset lsp does not handle `{}`", req.method),
                );
            }
        };
        match result {
            Some(Ok(v)) => Response::new_ok(id, v),
            _ => Response::new_err(
                id,
                lsp_server::ErrorCode::InvalidParams as i32,
                "the request's parameters do not parse".into(),
            ),
        }
    }

    fn hover(&self, key: &str, pos: Position) -> Option<Hover> {
        let doc = &self.docs.get(key)?.doc;
        let h = doc.hover(line_col(pos))?;
        Some(Hover {
            contents: HoverContents::Markup(MarkupContent {
                kind: MarkupKind::Markdown,
                value: h.markdown,
            }),
            range: Some(range(doc.text(), h.span)),
        })
    }

    fn definition(&self, key: &str, pos: Position) -> Option<Location> {
        let loc = self.docs.get(key)?.doc.definition(line_col(pos))?;
        analysis::location(&navigate::schema_file(&loc.file, &self.cache_dir)?, &loc)
    }

    /// A completion item of the last completion with the code's facts
    /// (`data` is the code number: the items stay small).
    fn resolve(&self, mut item: CompletionItem) -> CompletionItem {
        let found = item.data.as_ref().and_then(|d| {
            let doc = self.docs.get(self.completed.as_deref()?)?;
            doc.doc.facts(u32::try_from(d.as_u64()?).ok()?)
        });
        if let Some(md) = found {
            item.documentation = Some(markdown(md));
        }
        item
    }

    fn completion(&self, key: &str, pos: Position) -> Option<Vec<CompletionItem>> {
        let doc = &self.docs.get(key)?.doc;
        let items = doc.complete(line_col(pos), &self.registry)?;
        Some(
            items
                .into_iter()
                .map(|c| completion_item(doc.text(), pos, c))
                .collect(),
        )
    }
}

fn diagnostics_notification(
    uri: Uri,
    diagnostics: Vec<Diagnostic>,
    version: Option<i32>,
) -> Notification {
    Notification::new(
        "textDocument/publishDiagnostics".into(),
        PublishDiagnosticsParams {
            uri,
            diagnostics,
            version,
        },
    )
}

/// An LSP completion item of a completion; a replacement ends at the
/// request's position `pos`.
fn completion_item(text: &Text, pos: Position, c: Completion) -> CompletionItem {
    let (insert_text, text_edit) = match c.insert {
        Insert::Text(t) => (Some(t), None),
        Insert::Replace { start, text: new } => (
            None,
            Some(CompletionTextEdit::Edit(TextEdit::new(
                Range::new(analysis::position(text.position(start)), pos),
                new,
            ))),
        ),
    };
    CompletionItem {
        label: c.label,
        kind: Some(match c.kind {
            CompletionKind::Field => CompletionItemKind::FIELD,
            CompletionKind::EnumMember => CompletionItemKind::ENUM_MEMBER,
            CompletionKind::Value => CompletionItemKind::VALUE,
            CompletionKind::Module => CompletionItemKind::MODULE,
        }),
        detail: c.detail,
        filter_text: c.filter_text,
        data: c.code.map(Value::from),
        insert_text,
        text_edit,
        ..CompletionItem::default()
    }
}

fn markdown(value: String) -> Documentation {
    Documentation::MarkupContent(MarkupContent {
        kind: MarkupKind::Markdown,
        value,
    })
}

/// The code actions of the diagnostics in the request that carry a fix.
// `WorkspaceEdit::changes` is lsp-types' `HashMap<Uri, _>`; its `Uri` has a
// lazily filled parse cache, never changed while it is a key
#[allow(clippy::mutable_key_type)]
fn code_actions(p: &CodeActionParams) -> Vec<CodeActionOrCommand> {
    p.context
        .diagnostics
        .iter()
        .filter_map(|d| {
            let data: &Value = d.data.as_ref()?;
            let title = data.get("title")?.as_str()?.to_string();
            let edits: Vec<TextEdit> = serde_json::from_value(data.get("edits")?.clone()).ok()?;
            let mut changes = HashMap::new();
            changes.insert(p.text_document.uri.clone(), edits);
            Some(CodeActionOrCommand::CodeAction(CodeAction {
                title,
                kind: Some(CodeActionKind::QUICKFIX),
                diagnostics: Some(vec![d.clone()]),
                edit: Some(WorkspaceEdit {
                    changes: Some(changes),
                    ..WorkspaceEdit::default()
                }),
                is_preferred: Some(true),
                ..CodeAction::default()
            }))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The server's own time (no pipe, no client) for the requests of a
    /// 300-code set: printed, never asserted (debug builds are slow).
    #[test]
    fn server_side_time_on_a_300_code_set() {
        let dir = tempfile::tempdir().unwrap();
        let mut schema = String::from(
            "[schema]\nid = \"t300\"\ntitle = \"t\"\nprotocol = \"lustbus-mc\"\ncode_style = \"lust\"\n",
        );
        let mut set = String::from("schema = \"t300.toml\"\n\n[values]\n");
        for n in 1000..1300 {
            schema.push_str(&format!(
                "\n[[code]]\nnumber = {n}\nname = \"P{n}\"\ntype = \"PT_USIGN16\"\nmin = 0\nmax = 1000\n"
            ));
            set.push_str(&format!("{n}-P{n} = {}\n", n - 1000));
        }
        std::fs::write(dir.path().join("t300.toml"), schema).unwrap();
        let path = dir.path().join("s.toml");
        let uri = uri::from_path(&path).unwrap();
        let mut server = Server::new(&Config::default()).unwrap();
        let open = Notification::new(
            "textDocument/didOpen".into(),
            serde_json::json!({"textDocument": {"uri": uri, "languageId": "toml", "version": 1, "text": set}}),
        );
        let t = std::time::Instant::now();
        let out = server.notify(open);
        let open_time = t.elapsed();
        assert_eq!(out.len(), 1);
        let t = std::time::Instant::now();
        let items = server
            .completion(uri.as_str(), Position::new(100, 0))
            .unwrap();
        let completion_time = t.elapsed();
        assert_eq!(items.len(), 600);
        let t = std::time::Instant::now();
        let json = serde_json::to_string(&items).unwrap();
        let serialise_time = t.elapsed();
        eprintln!(
            "server side, 300 codes: open + diagnostics {} us, completion {} us, its JSON ({} bytes) {} us",
            open_time.as_micros(),
            completion_time.as_micros(),
            json.len(),
            serialise_time.as_micros()
        );
    }
}
