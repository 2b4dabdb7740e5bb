//! `driveset lsp` end to end (issue 22): the built binary driven over its
//! stdin / stdout by a plain JSON-RPC client (LSP base protocol framing,
//! `Content-Length` headers), as an editor drives it: initialize, open,
//! incremental changes, diagnostics at their lines, hover, completion,
//! definition, code actions, shutdown and exit. The latency test prints
//! the time from a change to its diagnostics on a 300-code set (a figure
//! to read, never asserted). Timeouts are hang guards only.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use driveset_test_support::workspace_root;

pub(crate) const HANG_GUARD: Duration = Duration::from_secs(60);

pub(crate) struct Client {
    pub(crate) child: Child,
    pub(crate) stdin: ChildStdin,
    pub(crate) rx: Receiver<Value>,
    next_id: i64,
    /// Notifications received while waiting for something else.
    pending: Vec<Value>,
}

fn read_message(r: &mut impl BufRead) -> Option<Value> {
    let mut len = None;
    loop {
        let mut line = String::new();
        if r.read_line(&mut line).ok()? == 0 {
            return None;
        }
        let line = line.trim_end();
        if line.is_empty() {
            break;
        }
        if let Some(v) = line.strip_prefix("Content-Length: ") {
            len = v.parse::<usize>().ok();
        }
    }
    let mut body = vec![0; len?];
    r.read_exact(&mut body).ok()?;
    serde_json::from_slice(&body).ok()
}

fn uri(p: &Path) -> String {
    format!("file://{}", p.display())
}

impl Client {
    pub(crate) fn start(cache: &Path) -> Client {
        // DRIVESET_BIN: another build to measure (e.g. target/release/driveset)
        let bin = std::env::var_os("DRIVESET_BIN")
            .map_or_else(driveset_test_support::driveset_bin, PathBuf::from);
        let mut child = Command::new(bin)
            .arg("lsp")
            .current_dir(workspace_root())
            .env("XDG_CACHE_HOME", cache)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let stdin = child.stdin.take().unwrap();
        let stdout = child.stdout.take().unwrap();
        let (tx, rx) = channel();
        std::thread::spawn(move || {
            let mut r = BufReader::new(stdout);
            while let Some(m) = read_message(&mut r) {
                if tx.send(m).is_err() {
                    break;
                }
            }
        });
        let mut c = Client {
            child,
            stdin,
            rx,
            next_id: 1,
            pending: Vec::new(),
        };
        let caps = c.request(
            "initialize",
            json!({"processId": null, "rootUri": null, "capabilities": {}}),
        );
        assert_eq!(caps["capabilities"]["textDocumentSync"], 2, "{caps}");
        c.notify("initialized", json!({}));
        c
    }

    pub(crate) fn send(&mut self, v: &Value) {
        let body = serde_json::to_string(v).unwrap();
        write!(self.stdin, "Content-Length: {}\r\n\r\n{body}", body.len()).unwrap();
        self.stdin.flush().unwrap();
    }

    pub(crate) fn notify(&mut self, method: &str, params: Value) {
        self.send(&json!({"jsonrpc": "2.0", "method": method, "params": params}));
    }

    pub(crate) fn request(&mut self, method: &str, params: Value) -> Value {
        let id = self.next_id;
        self.next_id += 1;
        self.send(&json!({"jsonrpc": "2.0", "id": id, "method": method, "params": params}));
        loop {
            let m = self.rx.recv_timeout(HANG_GUARD).expect("an answer");
            if m["id"] == id {
                assert!(m.get("error").is_none(), "{method}: {m}");
                return m["result"].clone();
            }
            self.pending.push(m);
        }
    }

    /// The diagnostics published for `uri` at `version`.
    fn diagnostics(&mut self, uri: &str, version: i64) -> Vec<Value> {
        let matches = |m: &Value| {
            m["method"] == "textDocument/publishDiagnostics"
                && m["params"]["uri"] == uri
                && m["params"]["version"] == version
        };
        if let Some(i) = self.pending.iter().position(matches) {
            let m = self.pending.remove(i);
            return m["params"]["diagnostics"].as_array().unwrap().clone();
        }
        loop {
            let m = self.rx.recv_timeout(HANG_GUARD).expect("diagnostics");
            if matches(&m) {
                return m["params"]["diagnostics"].as_array().unwrap().clone();
            }
            self.pending.push(m);
        }
    }

    pub(crate) fn open(&mut self, path: &Path, text: &str) -> Vec<Value> {
        let lang = if path.extension().is_some_and(|e| e == "toml") {
            "toml"
        } else {
            "yaml"
        };
        self.notify(
            "textDocument/didOpen",
            json!({"textDocument": {"uri": uri(path), "languageId": lang, "version": 1, "text": text}}),
        );
        self.diagnostics(&uri(path), 1)
    }

    /// Replace `(line, from)..(line, to)` with `text`, as version `version`.
    fn change(
        &mut self,
        path: &Path,
        version: i64,
        start: (u32, u32),
        end: (u32, u32),
        text: &str,
    ) -> Vec<Value> {
        self.notify(
            "textDocument/didChange",
            json!({
                "textDocument": {"uri": uri(path), "version": version},
                "contentChanges": [{
                    "range": {"start": {"line": start.0, "character": start.1}, "end": {"line": end.0, "character": end.1}},
                    "text": text,
                }],
            }),
        );
        self.diagnostics(&uri(path), version)
    }

    fn at(&mut self, method: &str, path: &Path, line: u32, character: u32) -> Value {
        self.request(
            method,
            json!({"textDocument": {"uri": uri(path)}, "position": {"line": line, "character": character}}),
        )
    }

    pub(crate) fn shutdown(mut self) {
        let r = self.request("shutdown", Value::Null);
        assert_eq!(r, Value::Null);
        self.notify("exit", Value::Null);
        let status = self.child.wait().unwrap();
        assert_eq!(status.code(), Some(0));
    }
}

/// (line, character, end line, end character, code, message) of a diagnostic.
fn summary(d: &Value) -> (u64, u64, u64, u64, String, String) {
    let r = &d["range"];
    (
        r["start"]["line"].as_u64().unwrap(),
        r["start"]["character"].as_u64().unwrap(),
        r["end"]["line"].as_u64().unwrap(),
        r["end"]["character"].as_u64().unwrap(),
        d["code"].as_str().unwrap().to_string(),
        d["message"].as_str().unwrap().to_string(),
    )
}

const TMD_SET: &str = "schema = \"lenze-tmd\"

[values]
C0011 = 9999
C0014 = \"Linear w/ boost\"
C0012 = \"8 s\"
C0050 = 1
maximum_output_frequncy = 50
";

#[test]
fn lsp_diagnostics_follow_open_and_incremental_changes_at_their_lines() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("conveyor.toml");
    let mut c = Client::start(dir.path());
    let d = c.open(&set, TMD_SET);
    let got: Vec<_> = d.iter().map(summary).collect();
    assert_eq!(
        got,
        [
            (3, 8, 3, 12, "out-of-range".into(), "C0011 = 9999 Hz is above the maximum 240 Hz\nhelp: give a value from 7.5 Hz to 240 Hz".into()),
            (4, 8, 4, 25, "unknown-enum-label".into(), "C0014 has no label \"Linear w/ boost\"\nhelp: use one of: \"Linear with Auto Boost\", \"Square law with Auto Boost\", \"Linear with constant Vmin boost\", \"Square law with constant Vmin boost\", \"Vector speed control\", \"Vector torque control\", \"Enhanced linear characteristic with Auto-Boost\", \"Enhanced linear characteristic with constant Vmin boost\"".into()),
            (6, 0, 6, 5, "read-only".into(), "C0050 (output_frequency) is read-only; a set cannot write it\nhelp: remove this line".into()),
            (7, 0, 7, 23, "unknown-code".into(), "`maximum_output_frequncy` is not a code name of lenze-tmd\nhelp: did you mean `maximum_output_frequency`?".into()),
        ]
    );
    // the schema's maximum is named as related information
    let rel = &d[0]["relatedInformation"][0];
    assert_eq!(rel["message"], "maximum in the schema");
    assert_eq!(rel["location"]["range"]["start"]["line"], 217);
    assert_eq!(d[0]["source"], "driveset");

    // fix C0011 in place: `9999` -> `50`; the others stay where they are
    let d = c.change(&set, 2, (3, 8), (3, 12), "50");
    let lines: Vec<u64> = d.iter().map(|d| summary(d).0).collect();
    assert_eq!(lines, [4, 6, 7]);
    // two lines inserted at the top: every finding moves down by two
    let d = c.change(&set, 3, (0, 0), (0, 0), "# line 1 conveyor\n# reviewed\n");
    let got: Vec<(u64, String)> = d.iter().map(|d| (summary(d).0, summary(d).4)).collect();
    assert_eq!(
        got,
        [
            (6, "unknown-enum-label".into()),
            (8, "read-only".into()),
            (9, "unknown-code".into())
        ]
    );
    // a syntax error is one diagnostic at its place
    let d = c.change(&set, 4, (5, 0), (5, 0), "C0010 = \n");
    assert_eq!(d.len(), 1, "{d:?}");
    assert_eq!(summary(&d[0]).0, 5);
    assert_eq!(summary(&d[0]).4, "input-error");
    assert!(summary(&d[0]).5.starts_with("malformed TOML: "), "{d:?}");
    c.shutdown();
}

#[test]
fn lsp_hover_completion_definition_and_code_actions() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("conveyor.toml");
    let mut c = Client::start(dir.path());
    let d = c.open(&set, TMD_SET);
    assert_eq!(d.len(), 4);

    // hover on the key C0012
    let h = c.at("textDocument/hover", &set, 5, 2);
    assert_eq!(h["contents"]["kind"], "markdown");
    let md = h["contents"]["value"].as_str().unwrap();
    assert!(md.starts_with("**C0012** `acceleration_time_1` — "), "{md}");
    for line in [
        "- type: VD (step 0.0001)\n",
        "- unit: s\n",
        "- spec: lecom-ab-tmd-manual.txt §7 Table 1\n",
        "schema `lenze-tmd` (schemas/lenze-tmd.toml)\n",
    ] {
        assert!(md.contains(line), "{line}: {md}");
    }
    assert!(
        md.contains("\n- range: ") && md.contains("\n- default: "),
        "{md}"
    );
    assert_eq!(
        h["range"],
        json!({"start": {"line": 5, "character": 0}, "end": {"line": 5, "character": 5}})
    );

    // completion of a key on a new line of [values]
    c.change(&set, 2, (8, 0), (8, 0), "C001");
    let items = c.at("textDocument/completion", &set, 8, 4);
    let items = items.as_array().unwrap();
    let c11 = items.iter().find(|i| i["label"] == "C0011").expect("C0011");
    assert_eq!(c11["detail"], "Maximum output frequency");
    assert_eq!(
        c11["textEdit"],
        json!({"range": {"start": {"line": 8, "character": 0}, "end": {"line": 8, "character": 4}}, "newText": "C0011 = "})
    );
    assert!(
        items
            .iter()
            .any(|i| i["label"] == "maximum_output_frequency")
    );
    // read-only codes are not offered
    assert!(!items.iter().any(|i| i["label"] == "C0050"));
    // completion of a selection text after `C0014 = `
    c.change(&set, 3, (8, 0), (8, 4), "C0014 = \"Lin");
    let items = c.at("textDocument/completion", &set, 8, 12);
    let labels: Vec<&str> = items
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["label"].as_str().unwrap())
        .collect();
    assert_eq!(labels.len(), 8);
    assert_eq!(labels[0], "Linear with Auto Boost");
    assert_eq!(
        items[0]["textEdit"],
        json!({"range": {"start": {"line": 8, "character": 8}, "end": {"line": 8, "character": 12}}, "newText": "\"Linear with Auto Boost\""})
    );
    let d = c.change(&set, 4, (8, 0), (9, 0), "");
    assert_eq!(d.len(), 4);

    // go to definition: the code's entry in a read-only copy of the built-in schema file
    let def = c.at("textDocument/definition", &set, 3, 1);
    let copy = dir.path().join(format!(
        "driveset/{}/schemas/lenze-tmd.toml",
        env!("CARGO_PKG_VERSION")
    ));
    assert_eq!(def["uri"], uri(&copy));
    let text = std::fs::read_to_string(workspace_root().join("schemas/lenze-tmd.toml")).unwrap();
    assert_eq!(std::fs::read_to_string(&copy).unwrap(), text);
    assert!(std::fs::metadata(&copy).unwrap().permissions().readonly());
    let line = def["range"]["start"]["line"].as_u64().unwrap() as usize;
    assert_eq!(text.lines().nth(line), Some("number = 11"));

    // code actions: the diagnostics with a mechanical fix
    let d = c.change(&set, 5, (0, 0), (0, 0), "");
    let actions = c.request(
        "textDocument/codeAction",
        json!({
            "textDocument": {"uri": uri(&set)},
            "range": {"start": {"line": 0, "character": 0}, "end": {"line": 9, "character": 0}},
            "context": {"diagnostics": d},
        }),
    );
    let edits: Vec<(String, Value)> = actions
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            assert_eq!(a["kind"], "quickfix");
            (
                a["title"].as_str().unwrap().to_string(),
                a["edit"]["changes"][uri(&set)][0].clone(),
            )
        })
        .collect();
    let r = |l0: u32, c0: u32, l1: u32, c1: u32| json!({"start": {"line": l0, "character": c0}, "end": {"line": l1, "character": c1}});
    assert_eq!(
        edits,
        [
            (
                "replace with \"Linear with Auto Boost\"".to_string(),
                json!({"range": r(4, 8, 4, 25), "newText": "\"Linear with Auto Boost\""})
            ),
            (
                "remove this line".to_string(),
                json!({"range": r(6, 0, 7, 0), "newText": ""})
            ),
            (
                "replace with `maximum_output_frequency`".to_string(),
                json!({"range": r(7, 0, 7, 23), "newText": "maximum_output_frequency"})
            ),
        ]
    );
    // applied (last first, as an editor does): C0011's range is left, and
    // the renamed key now names C0011 a second time
    c.change(&set, 6, (7, 0), (7, 23), "maximum_output_frequency");
    c.change(&set, 7, (6, 0), (7, 0), "");
    let d = c.change(&set, 8, (4, 8), (4, 25), "\"Linear with Auto Boost\"");
    let got: Vec<(u64, String)> = d.iter().map(|d| (summary(d).0, summary(d).4)).collect();
    assert_eq!(
        got,
        [(3, "out-of-range".into()), (6, "duplicate-code".into())]
    );
    c.shutdown();
}

#[test]
fn lsp_reads_yaml_sets_learned_schemas_beside_the_set_and_line_manifests() {
    let dir = tempfile::tempdir().unwrap();
    let mut c = Client::start(dir.path());
    // YAML: the finding at its line, hover on a name key
    let yaml = dir.path().join("pump.yaml");
    let d = c.open(
        &yaml,
        "schema: lenze-tmd\nvalues:\n  acceleration_time_1: 8 s\n  C0011: 9999\n",
    );
    let got: Vec<_> = d
        .iter()
        .map(|d| (summary(d).0, summary(d).1, summary(d).4))
        .collect();
    assert_eq!(got, [(3, 9, "out-of-range".to_string())]);
    let h = c.at("textDocument/hover", &yaml, 2, 4);
    assert!(
        h["contents"]["value"]
            .as_str()
            .unwrap()
            .starts_with("**C0012** `acceleration_time_1`"),
        "{h}"
    );
    let items = c.at("textDocument/completion", &yaml, 3, 2);
    let c14 = items
        .as_array()
        .unwrap()
        .iter()
        .find(|i| i["label"] == "C0014")
        .unwrap()
        .clone();
    assert_eq!(c14["textEdit"]["newText"], "C0014: ");

    // a learned / imported schema file beside the set, named by path
    let learned = dir.path().join("learned-mc6000.toml");
    std::fs::copy(
        workspace_root().join("parameter-sets/fixtures/fictional-mc6000-demo.toml"),
        &learned,
    )
    .unwrap();
    let set = dir.path().join("axis.toml");
    let d = c.open(
        &set,
        "schema = \"learned-mc6000.toml\"\n\n[values]\n100-PWMF = \"8 kHz\"\n100 = 2\n",
    );
    let got: Vec<_> = d.iter().map(|d| (summary(d).0, summary(d).4)).collect();
    assert_eq!(got, [(4, "duplicate-code".to_string())]);
    let def = c.at("textDocument/definition", &set, 3, 0);
    assert_eq!(def["uri"], uri(&learned));
    let text = std::fs::read_to_string(&learned).unwrap();
    let line = def["range"]["start"]["line"].as_u64().unwrap() as usize;
    assert_eq!(text.lines().nth(line), Some("number = 100"));

    // a TOML file that is no driveset file (Cargo.toml, CI files) is left alone
    let other = dir.path().join("Cargo.toml");
    assert_eq!(
        c.open(&other, "[package]\nname = \"x\"\n"),
        Vec::<Value>::new()
    );
    // a line manifest: validate's manifest checks, at their line
    let manifest = workspace_root().join("parameter-sets/demo-line/line.toml");
    let text = std::fs::read_to_string(&manifest).unwrap();
    let d = c.open(&manifest, &text);
    assert_eq!(d, Vec::<Value>::new());
    let (n, line) = text
        .lines()
        .enumerate()
        .filter(|(_, l)| l.starts_with("address = "))
        .nth(1)
        .map(|(n, l)| (n, l.to_string()))
        .unwrap();
    let first = text
        .lines()
        .find(|l| l.starts_with("address = "))
        .unwrap()
        .to_string();
    let d = c.change(
        &manifest,
        2,
        (n as u32, 0),
        (n as u32, line.len() as u32),
        &first,
    );
    let codes: Vec<(u64, String)> = d.iter().map(|d| (summary(d).0, summary(d).4)).collect();
    assert!(
        codes.contains(&(n as u64, "duplicate-address".to_string())),
        "{codes:?}: {d:?}"
    );
    c.shutdown();
}

/// A schema of 300 codes and a set giving each a value, beside each other.
fn set_of_300(dir: &Path) -> PathBuf {
    let mut schema = String::from(
        "[schema]\nid = \"latency-300\"\ntitle = \"300 codes (language server latency)\"\nprotocol = \"lustbus-mc\"\ncode_style = \"lust\"\n",
    );
    let mut set = String::from("schema = \"latency-300.toml\"\n\n[values]\n");
    for n in 1000..1300 {
        schema.push_str(&format!(
            "\n[[code]]\nnumber = {n}\nname = \"P{n}\"\ntitle = \"Parameter {n}\"\ntype = \"PT_USIGN16\"\nunit = \"ms\"\nmin = 0\nmax = 1000\ndefault = 0\nkind = \"eeprom\"\n"
        ));
        set.push_str(&format!("{n}-P{n} = \"{} ms\"\n", n - 1000));
    }
    std::fs::write(dir.join("latency-300.toml"), schema).unwrap();
    let path = dir.join("set-300.toml");
    std::fs::write(&path, set).unwrap();
    path
}

#[test]
fn lsp_latency_of_diagnostics_after_a_change_on_a_300_code_set() {
    let dir = tempfile::tempdir().unwrap();
    let path = set_of_300(dir.path());
    let text = std::fs::read_to_string(&path).unwrap();
    let mut c = Client::start(dir.path());
    assert_eq!(c.open(&path, &text), Vec::<Value>::new());
    // each change puts line 150's value out of range and back
    let line = 3 + 150;
    let value_col = "1150-P1150 = \"".len() as u32;
    let mut diag = Vec::new();
    for v in 2..42 {
        let new = if v % 2 == 0 { "5000" } else { "150" };
        let old_len = if v % 2 == 0 { 3 } else { 4 };
        let t = Instant::now();
        let d = c.change(
            &path,
            v,
            (line, value_col),
            (line, value_col + old_len),
            new,
        );
        diag.push(t.elapsed());
        let want = if v % 2 == 0 { 1 } else { 0 };
        assert_eq!(d.len(), want, "{d:?}");
        if want == 1 {
            assert_eq!(summary(&d[0]).0, u64::from(line));
        }
    }
    let mut hover = Vec::new();
    let mut completion = Vec::new();
    for _ in 0..20 {
        let t = Instant::now();
        let h = c.at("textDocument/hover", &path, line, 2);
        hover.push(t.elapsed());
        assert!(
            h["contents"]["value"]
                .as_str()
                .unwrap()
                .starts_with("**1150-P1150**")
        );
        let t = Instant::now();
        let items = c.at("textDocument/completion", &path, line, 0);
        completion.push(t.elapsed());
        assert_eq!(items.as_array().unwrap().len(), 600);
    }
    let stats = |v: &mut Vec<Duration>| {
        v.sort();
        (v[v.len() / 2], v[v.len() * 9 / 10], v[v.len() - 1])
    };
    for (what, v) in [
        ("diagnostics after a change", &mut diag),
        ("hover", &mut hover),
        ("completion (600 items)", &mut completion),
    ] {
        let (median, p90, max) = stats(v);
        let ms = |d: Duration| {
            let us = d.as_micros();
            format!("{}.{} ms", us / 1000, us % 1000 / 100)
        };
        eprintln!(
            "lsp latency, 300-code set, {what}: median {}, p90 {}, max {} ({} runs)",
            ms(median),
            ms(p90),
            ms(max),
            v.len()
        );
    }
    c.shutdown();
}
