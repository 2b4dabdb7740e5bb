//! `driveset lsp` survives its client (issue 29): through the built
//! binary, a malformed frame or body (not JSON, not UTF-8, a bad header,
//! JSON that is no message, a batch, a frame over the 64 MiB cap) is
//! answered with its JSON-RPC error and the server goes on answering;
//! stdin closed, also in the middle of a 4 GB frame, ends it with exit 0.
//! Timeouts are hang guards only.

use std::io::Write as _;

use serde_json::{Value, json};

use crate::lsp::{Client, HANG_GUARD};

fn frame(body: &[u8]) -> Vec<u8> {
    let mut f = format!("Content-Length: {}\r\n\r\n", body.len()).into_bytes();
    f.extend_from_slice(body);
    f
}

impl Client {
    fn raw(&mut self, bytes: &[u8]) {
        self.stdin.write_all(bytes).unwrap();
        self.stdin.flush().unwrap();
    }

    fn next(&mut self) -> Value {
        self.rx.recv_timeout(HANG_GUARD).expect("an answer")
    }

    fn exit_code_after_stdin_closes(self) -> Option<i32> {
        let Client {
            mut child, stdin, ..
        } = self;
        drop(stdin);
        child.wait().unwrap().code()
    }
}

fn error(v: &Value) -> (Value, i64) {
    (v["id"].clone(), v["error"]["code"].as_i64().unwrap_or(0))
}

#[test]
fn lsp_answers_each_malformed_frame_with_its_json_rpc_error_and_goes_on() {
    let cache = tempfile::tempdir().unwrap();
    let mut c = Client::start(cache.path());
    let cases: [(&[u8], (Value, i64)); 6] = [
        (
            &frame(b"{\"jsonrpc\": \"2.0\", \"id\": 1"),
            (Value::Null, -32700),
        ),
        (&frame(b"\xff\xfe\x00garbage"), (Value::Null, -32700)),
        (
            b"Content-Length: twelve\r\n\r\n{\"a\": 1}",
            (Value::Null, -32700),
        ),
        (&frame(br#"{"hello": "world"}"#), (Value::Null, -32600)),
        (
            &frame(br#"{"jsonrpc": "2.0", "id": 9, "method": 42}"#),
            (json!(9), -32600),
        ),
        (
            &frame(br#"[{"jsonrpc": "2.0", "id": 3, "method": "shutdown"}]"#),
            (Value::Null, -32600),
        ),
    ];
    for (bytes, want) in cases {
        c.raw(bytes);
        let got = c.next();
        assert_eq!(
            error(&got),
            want,
            "{}: {got}",
            String::from_utf8_lossy(bytes)
        );
        // and the server still answers
        let r = c.request("textDocument/hover", json!({"textDocument": {"uri": "file:///nowhere.toml"}, "position": {"line": 0, "character": 0}}));
        assert_eq!(r, Value::Null);
    }
    // a frame over the cap is skipped in bounded memory and refused
    let over = 64 * 1024 * 1024 + 1;
    c.raw(format!("Content-Length: {over}\r\n\r\n").as_bytes());
    let chunk = vec![b' '; 1024 * 1024];
    let mut left = over;
    while left > 0 {
        let n = left.min(chunk.len());
        c.raw(&chunk[..n]);
        left -= n;
    }
    let got = c.next();
    assert_eq!(error(&got), (Value::Null, -32600), "{got}");
    assert_eq!(
        got["error"]["message"],
        "a frame of 67108865 bytes is larger than driveset lsp takes (67108864 bytes); it was skipped"
    );
    c.shutdown();
}

#[test]
fn lsp_ends_cleanly_when_stdin_closes_also_inside_a_4_gb_frame() {
    let cache = tempfile::tempdir().unwrap();
    let c = Client::start(cache.path());
    assert_eq!(c.exit_code_after_stdin_closes(), Some(0));
    let mut c = Client::start(cache.path());
    c.raw(b"Content-Length: 4000000000\r\n\r\n{\"jsonrpc\":");
    assert_eq!(c.exit_code_after_stdin_closes(), Some(0));
}
