//! The LSP base protocol (LSP 3.17, "Base Protocol") as a codec, apart
//! from the language server that uses it (as rust-analyzer keeps its
//! `lsp-server` library apart from its server and its `ide` crate): reading
//! a frame (headers, `Content-Length`, a body of JSON-RPC 2.0) from the
//! client and writing one back. A body is at most [`MAX_FRAME`] bytes (a
//! larger one is skipped in bounded memory and refused); a header line at
//! most [`MAX_HEADER_LINE`]. A frame that is malformed — bad header, body
//! that is not UTF-8 or not JSON, JSON that is not a message, a batch — is
//! answered with the JSON-RPC 2.0 error (§5.1: parse error -32700,
//! invalid request -32600, id null when none can be read) and the server
//! reads on; after a bad header it resynchronises on the next
//! `Content-Length:`. End of input, also in the middle of a frame, ends
//! the server cleanly. docs/editors.md, "Frames the server refuses".

use std::io::{self, BufRead, Read as _, Write};

use lsp_server::Message;
use serde_json::Value;

/// The largest frame body read (64 MiB: a set file is at most 4 MiB and
/// an editor sends it whole at most once per message).
pub const MAX_FRAME: u64 = 64 * 1024 * 1024;

/// The longest header line read (8 KiB).
pub const MAX_HEADER_LINE: u64 = 8 * 1024;

/// JSON-RPC 2.0 parse error: the body is not JSON (or not UTF-8 text).
pub const PARSE_ERROR: i64 = -32700;
/// JSON-RPC 2.0 invalid request: JSON, but not a message the server takes.
pub const INVALID_REQUEST: i64 = -32600;

/// What one read gives.
#[derive(Debug)]
pub enum Frame {
    /// A JSON-RPC message.
    Message(Message),
    /// A frame refused: the error response to send, and the server goes on.
    Refused(Value),
    /// The client closed its end.
    Eof,
}

/// Reads frames from the client.
pub struct Reader<R> {
    r: R,
    /// After a bad header: skip to the next `Content-Length:`.
    resync: bool,
}

/// The error response `code` / `message` with the request's `id` (null
/// when none is known).
pub fn error(id: Value, code: i64, message: impl Into<String>) -> Value {
    let e = ErrorResponse {
        error: ErrorBody {
            code,
            message: message.into(),
        },
        id,
        jsonrpc: "2.0",
    };
    serde_json::to_value(e).unwrap_or_default()
}

/// A JSON-RPC error response.
#[derive(serde::Serialize)]
struct ErrorResponse {
    error: ErrorBody,
    id: Value,
    jsonrpc: &'static str,
}

/// Its `error` member.
#[derive(serde::Serialize)]
struct ErrorBody {
    code: i64,
    message: String,
}

enum Line {
    Text(String),
    /// Longer than [`MAX_HEADER_LINE`] (the rest of it is skipped).
    TooLong,
    Eof,
}

impl<R: BufRead> Reader<R> {
    /// A reader of `r`.
    pub fn new(r: R) -> Self {
        Reader { r, resync: false }
    }

    /// One header line without its line end, at most [`MAX_HEADER_LINE`]
    /// bytes kept.
    fn line(&mut self) -> io::Result<Line> {
        let mut buf = Vec::new();
        let n = (&mut self.r)
            .take(MAX_HEADER_LINE)
            .read_until(b'\n', &mut buf)?;
        if n == 0 {
            return Ok(Line::Eof);
        }
        if buf.last() != Some(&b'\n') {
            if n as u64 == MAX_HEADER_LINE {
                // skip the rest of the line in bounded memory
                loop {
                    let chunk = self.r.fill_buf()?;
                    if chunk.is_empty() {
                        return Ok(Line::Eof);
                    }
                    match chunk.iter().position(|&b| b == b'\n') {
                        Some(i) => {
                            self.r.consume(i + 1);
                            return Ok(Line::TooLong);
                        }
                        None => {
                            let len = chunk.len();
                            self.r.consume(len);
                        }
                    }
                }
            }
            return Ok(Line::Eof);
        }
        while matches!(buf.last(), Some(b'\n' | b'\r')) {
            buf.pop();
        }
        Ok(Line::Text(String::from_utf8_lossy(&buf).into_owned()))
    }

    /// Reads the next frame.
    ///
    /// # Errors
    /// Only the input's own read errors; a malformed frame is
    /// [`Frame::Refused`].
    pub fn read(&mut self) -> io::Result<Frame> {
        let mut length: Option<u64> = None;
        let mut bad: Option<String> = None;
        let mut any = false;
        loop {
            let line = match self.line()? {
                Line::Eof => return Ok(Frame::Eof),
                Line::TooLong => {
                    if !self.resync {
                        bad.get_or_insert_with(|| {
                            format!("a header line longer than {MAX_HEADER_LINE} bytes")
                        });
                    }
                    any = true;
                    continue;
                }
                Line::Text(t) => t,
            };
            let mut line = line.as_str();
            if self.resync {
                // a body without a line end runs into the next header
                let lower = line.to_ascii_lowercase();
                let Some(at) = lower.find("content-length:") else {
                    continue;
                };
                line = &line[at..];
                self.resync = false;
            }
            if line.is_empty() {
                if !any {
                    // blank lines between frames
                    continue;
                }
                break;
            }
            any = true;
            let Some((name, value)) = line.split_once(':') else {
                bad.get_or_insert_with(|| format!("`{}` is not a header", clip(line)));
                continue;
            };
            if name.trim().eq_ignore_ascii_case("content-length") {
                match value.trim().parse::<u64>() {
                    Ok(n) => length = Some(n),
                    Err(_) => {
                        bad.get_or_insert_with(|| {
                            format!("Content-Length `{}` is not a number", clip(value.trim()))
                        });
                    }
                }
            }
        }
        if let Some(why) = bad {
            match length {
                // the body's end is known: skip it, the next frame follows
                Some(n) => {
                    if io::copy(&mut (&mut self.r).take(n), &mut io::sink())? < n {
                        return Ok(Frame::Eof);
                    }
                }
                None => self.resync = true,
            }
            return Ok(Frame::Refused(error(
                Value::Null,
                PARSE_ERROR,
                format!("malformed frame header: {why}"),
            )));
        }
        let Some(length) = length else {
            self.resync = true;
            return Ok(Frame::Refused(error(
                Value::Null,
                PARSE_ERROR,
                "malformed frame header: no Content-Length",
            )));
        };
        if length > MAX_FRAME {
            // skipped, never held: the server reads on after it
            let skipped = io::copy(&mut (&mut self.r).take(length), &mut io::sink())?;
            if skipped < length {
                return Ok(Frame::Eof);
            }
            return Ok(Frame::Refused(error(
                Value::Null,
                INVALID_REQUEST,
                format!(
                    "a frame of {length} bytes is larger than driveset lsp takes ({MAX_FRAME} bytes); it was skipped"
                ),
            )));
        }
        let mut body = Vec::new();
        let got = (&mut self.r).take(length).read_to_end(&mut body)?;
        if (got as u64) < length {
            return Ok(Frame::Eof);
        }
        Ok(parse(&body))
    }
}

fn clip(s: &str) -> String {
    s.chars().take(60).collect()
}

/// A frame's body as a message, or the error that answers it.
fn parse(body: &[u8]) -> Frame {
    let Ok(text) = std::str::from_utf8(body) else {
        return Frame::Refused(error(
            Value::Null,
            PARSE_ERROR,
            "the frame's body is not UTF-8 text",
        ));
    };
    let value: Value = match serde_json::from_str(text) {
        Ok(v) => v,
        Err(e) => {
            return Frame::Refused(error(
                Value::Null,
                PARSE_ERROR,
                format!("the frame's body is not JSON: {e}"),
            ));
        }
    };
    if value.is_array() {
        // LSP (3.17, "Base Protocol") sends no batches; JSON-RPC 2.0 §6
        // answers a batch it does not process with one error
        return Frame::Refused(error(
            Value::Null,
            INVALID_REQUEST,
            "a JSON-RPC batch: the language server protocol sends one message per frame",
        ));
    }
    let id = value
        .get("id")
        .filter(|id| id.is_string() || id.is_number())
        .cloned()
        .unwrap_or(Value::Null);
    let well_formed = value.get("jsonrpc").and_then(Value::as_str) == Some("2.0")
        && (value.get("method").is_some_and(Value::is_string) || value.get("id").is_some());
    if !well_formed {
        return Frame::Refused(error(
            id,
            INVALID_REQUEST,
            "not a JSON-RPC 2.0 message (`jsonrpc`: \"2.0\" and a `method` or an `id`)",
        ));
    }
    match serde_json::from_value::<Message>(value) {
        Ok(m) => Frame::Message(m),
        Err(e) => Frame::Refused(error(
            id,
            INVALID_REQUEST,
            format!("not a JSON-RPC 2.0 message: {e}"),
        )),
    }
}

/// Writes one frame.
///
/// # Errors
/// The output's write errors.
pub fn write(w: &mut impl Write, v: &Value) -> io::Result<()> {
    let text = serde_json::to_string(v).map_err(io::Error::other)?;
    write!(w, "Content-Length: {}\r\n\r\n{text}", text.len())?;
    w.flush()
}

/// Writes a message (with `"jsonrpc": "2.0"`).
///
/// # Errors
/// The output's write errors.
pub fn write_message(w: &mut impl Write, m: &Message) -> io::Result<()> {
    m.write(w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use serde_json::json;

    fn frame(body: &[u8]) -> Vec<u8> {
        let mut f = format!("Content-Length: {}\r\n\r\n", body.len()).into_bytes();
        f.extend_from_slice(body);
        f
    }

    fn all(input: &[u8]) -> Vec<Frame> {
        let mut r = Reader::new(input);
        let mut out = Vec::new();
        loop {
            match r.read().unwrap() {
                Frame::Eof => return out,
                f => out.push(f),
            }
        }
    }

    fn code(f: &Frame) -> Option<i64> {
        match f {
            Frame::Refused(v) => v["error"]["code"].as_i64(),
            _ => None,
        }
    }

    const GOOD: &[u8] = br#"{"jsonrpc":"2.0","method":"initialized","params":{}}"#;

    #[test]
    fn each_malformed_frame_is_answered_and_the_next_is_read() {
        let mut input = Vec::new();
        input.extend(frame(b"{not json"));
        input.extend(frame(b"\xff\xfe"));
        input.extend(frame(b"[1,2]"));
        input.extend(frame(br#"{"foo":1}"#));
        input.extend(frame(br#"{"jsonrpc":"2.0","id":7,"method":5}"#));
        input.extend(b"Content-Length: lots\r\n\r\n{}");
        input.extend(frame(GOOD));
        input.extend(b"Content-Length: 4000000000\r\n\r\n");
        let frames = all(&input);
        let codes: Vec<Option<i64>> = frames.iter().map(code).collect();
        assert_eq!(
            codes,
            [
                Some(PARSE_ERROR),
                Some(PARSE_ERROR),
                Some(INVALID_REQUEST),
                Some(INVALID_REQUEST),
                Some(INVALID_REQUEST),
                Some(PARSE_ERROR),
                None,
            ]
        );
        assert!(matches!(
            frames[6],
            Frame::Message(Message::Notification(_))
        ));
        let Frame::Refused(v) = &frames[4] else {
            unreachable!()
        };
        assert_eq!(v["id"], json!(7));
    }

    #[test]
    fn an_oversize_frame_is_skipped_and_refused() {
        let big = MAX_FRAME + 10;
        let mut input = format!("Content-Length: {big}\r\n\r\n").into_bytes();
        input.resize(input.len() + big as usize, b'x');
        input.extend(frame(GOOD));
        let frames = all(&input);
        assert_eq!(code(&frames[0]), Some(INVALID_REQUEST));
        assert!(matches!(frames[1], Frame::Message(_)));
        assert_eq!(frames.len(), 2);
    }

    proptest! {
        /// Random bytes and random frames never panic and never hold more
        /// than a frame; a good frame after garbage and a newline is read.
        #[test]
        fn random_frames_never_panic_and_the_reader_resyncs(
            garbage in proptest::collection::vec(any::<u8>(), 0..300),
            lens in proptest::collection::vec(0u64..u64::MAX, 0..4),
        ) {
            let mut input = garbage.clone();
            for l in &lens {
                input.extend(format!("Content-Length: {l}\r\n\r\n").as_bytes());
            }
            let _ = all(&input);
            let mut input = garbage;
            input.extend(b"\r\n\r\n");
            input.extend(frame(GOOD));
            let frames = all(&input);
            prop_assert!(frames.iter().any(|f| matches!(f, Frame::Message(_))), "{frames:?}");
        }
    }
}
