//! `driveset schema json-schema` and `git-setup --json-schemas` (issue 22),
//! checked by the editors' own validators: taplo (`@taplo/cli`, installed
//! by `scripts/setup-node` into target/node; `DRIVESET_TAPLO` may name
//! another binary) on every example TOML set and on broken sets, and
//! Python's `jsonschema` (target/py, `scripts/setup-python`) on the JSON
//! form (`driveset show --to json`) of every example set. Without them the
//! tests are skipped under plain `cargo test` and fail under
//! `./scripts/test` (`DRIVESET_REQUIRE_INTEROP=1`).

use std::path::{Path, PathBuf};
use std::process::Command;

use serde_json::Value;

use driveset_test_support::{driveset, interop_or_skip, python_or_skip, workspace_root};

fn taplo_or_skip(what: &str) -> Option<PathBuf> {
    let taplo = std::env::var_os("DRIVESET_TAPLO").map_or_else(
        || workspace_root().join("target/node/node_modules/.bin/taplo"),
        PathBuf::from,
    );
    let missing = format!(
        "{} is missing (scripts/setup-node installs @taplo/cli into target/node; or set DRIVESET_TAPLO)",
        taplo.display()
    );
    interop_or_skip(what, taplo.exists().then_some(taplo), &missing)
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dst = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &dst);
        } else {
            std::fs::copy(e.path(), dst).unwrap();
        }
    }
}

/// A git work tree holding a copy of `parameter-sets/` after
/// `driveset git-setup --json-schemas .driveset/json-schema`.
fn repo_with_associations() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(
        &workspace_root().join("parameter-sets"),
        &dir.path().join("parameter-sets"),
    );
    let ok = Command::new("git")
        .args(["init", "-q"])
        .current_dir(dir.path())
        .status()
        .unwrap();
    assert!(ok.success());
    let out = driveset()
        .current_dir(dir.path())
        .args([
            "git-setup",
            "--json-schemas",
            ".driveset/json-schema",
            "--command",
            "driveset textconv",
        ])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8(out.stdout).unwrap();
    for id in [
        "fictional-ecs-demo",
        "fictional-mc6000-demo",
        "fictional-vf1000-demo",
        "lenze-tmd",
    ] {
        assert!(
            stdout.contains(&format!(
                ".driveset/json-schema/{id}.schema.json: JSON Schema of {id}\n"
            )),
            "{stdout}"
        );
    }
    dir
}

/// Every example set (TOML and YAML, manifests and fixture schemas left
/// out), relative to the workspace root, sorted.
fn example_sets() -> Vec<String> {
    let mut out = Vec::new();
    let mut stack = vec![workspace_root().join("parameter-sets")];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                if !p.ends_with("fixtures") {
                    stack.push(p);
                }
                continue;
            }
            let rel = p
                .strip_prefix(workspace_root())
                .unwrap()
                .to_string_lossy()
                .to_string();
            if (rel.ends_with(".toml") || rel.ends_with(".yaml")) && !rel.ends_with("line.toml") {
                out.push(rel);
            }
        }
    }
    out.sort();
    out
}

/// set file -> JSON Schema file, from the associations git-setup wrote.
fn associations(repo: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let taplo = std::fs::read_to_string(repo.join(".taplo.toml")).unwrap();
    let mut files: Vec<String> = Vec::new();
    for line in taplo.lines() {
        if let Some(list) = line.strip_prefix("include = ") {
            files = serde_json::from_str(list).unwrap();
        }
        if let Some(path) = line.strip_prefix("path = ") {
            let path: String = serde_json::from_str(path).unwrap();
            out.extend(files.drain(..).map(|f| (f, path.clone())));
        }
    }
    let vscode: Value =
        serde_json::from_str(&std::fs::read_to_string(repo.join(".vscode/settings.json")).unwrap())
            .unwrap();
    for (schema, sets) in vscode["yaml.schemas"].as_object().unwrap() {
        for s in sets.as_array().unwrap() {
            out.push((s.as_str().unwrap().to_string(), schema.clone()));
        }
    }
    out.sort();
    out
}

#[test]
fn json_schema_is_draft_07_with_exact_bounds_labels_and_key_forms() {
    let out = driveset()
        .args(["schema", "json-schema", "lenze-tmd"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8(out.stdout).unwrap();
    // C0011: min "7.5", max "240" in schemas/lenze-tmd.toml, written as their decimal text
    assert!(
        text.contains("\"maximum\": 240,\n          \"minimum\": 7.5,\n"),
        "{}",
        &text[..2000.min(text.len())]
    );
    let v: Value = serde_json::from_str(&text).unwrap();
    assert_eq!(v["$schema"], "http://json-schema.org/draft-07/schema#");
    assert_eq!(v["additionalProperties"], false);
    let values = &v["properties"]["values"];
    assert_eq!(values["additionalProperties"], false);
    assert_eq!(values["properties"]["C0011"]["$ref"], "#/definitions/C0011");
    assert_eq!(
        values["properties"]["maximum_output_frequency"]["$ref"],
        "#/definitions/C0011"
    );
    assert_eq!(
        values["patternProperties"]["^(?:[Cc]?0*11|C0011|maximum_output_frequency|C11)$"]["$ref"],
        "#/definitions/C0011"
    );
    let c11 = &v["definitions"]["C0011"];
    assert_eq!(c11["title"], "Maximum output frequency");
    assert_eq!(
        c11["description"],
        "**C0011** `maximum_output_frequency` — Maximum output frequency\n\n- type: VD (step 0.0001)\n- unit: Hz\n- range: 7.5 ..= 240 Hz\n- default: 50 Hz\n- spec: lecom-ab-tmd-manual.txt §7 Table 1\n\nschema `lenze-tmd` (schemas/lenze-tmd.toml)\n"
    );
    // a complete enumeration: its numbers and its texts
    let c14 = &v["definitions"]["C0014"]["anyOf"];
    assert_eq!(c14[0]["enum"], serde_json::json!([0, 1, 2, 3, 4, 5, 6, 7]));
    assert_eq!(c14[1]["enum"][0], "Linear with Auto Boost");
    // a read-only code takes no value at all
    let ro = v["definitions"]
        .as_object()
        .unwrap()
        .values()
        .find(|d| d["readOnly"] == true)
        .expect("a read-only code");
    assert_eq!(ro["not"], serde_json::json!({}));
    // a bit-field code: members as an object
    let c7 = &v["definitions"]["C0007"]["anyOf"];
    let obj = c7
        .as_array()
        .unwrap()
        .iter()
        .find(|b| b["type"] == "object")
        .unwrap();
    assert_eq!(obj["additionalProperties"], false);
    assert!(obj["properties"]["E1"].is_object());
}

#[test]
fn json_schema_all_writes_one_file_per_schema_and_unknown_is_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = driveset()
        .args(["schema", "json-schema", "--all", "-o"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "lenze-ecs.schema.json",
            "lenze-tmd.schema.json",
            "lust-mc6000.schema.json",
            "lust-vf1000.schema.json"
        ]
    );
    let out = driveset()
        .args(["schema", "json-schema", "lenze-tdm"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8(out.stderr).unwrap();
    assert!(
        err.contains("unknown schema `lenze-tdm`: neither a known id (")
            && err.contains("lenze-tmd")
            && err.contains(") nor a file"),
        "{err}"
    );
}

#[test]
fn taplo_accepts_every_example_set_through_the_git_setup_associations() {
    let Some(taplo) = taplo_or_skip("taplo check of the example sets") else {
        return;
    };
    let repo = repo_with_associations();
    // every example set has its JSON Schema
    let assoc: Vec<String> = associations(repo.path())
        .into_iter()
        .map(|(s, _)| s)
        .collect();
    assert_eq!(assoc, example_sets());
    let out = Command::new(&taplo)
        .arg("check")
        .current_dir(repo.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("found configuration file"), "{err}");
}

#[test]
fn taplo_flags_an_unknown_code_a_value_above_its_maximum_and_an_unknown_text() {
    let Some(taplo) = taplo_or_skip("taplo check of broken sets") else {
        return;
    };
    let repo = repo_with_associations();
    let sets = repo.path().join("parameter-sets/tmd");
    let cases = [
        (
            "unknown-code.toml",
            "C0999 = 1",
            "Additional properties are not allowed ('C0999' was unexpected)",
            "unknown-code.toml:5:1",
        ),
        (
            "above-max.toml",
            "C0011 = 9999",
            "9999 is not valid under any of the schemas listed in the 'anyOf' keyword",
            "above-max.toml:5:9",
        ),
        (
            "unknown-text.toml",
            "C0014 = \"Linear w/ boost\"",
            "\"Linear w/ boost\" is not valid under any of the schemas listed in the 'anyOf' keyword",
            "unknown-text.toml:5:9",
        ),
    ];
    let schema = repo
        .path()
        .join(".driveset/json-schema/lenze-tmd.schema.json");
    let mut cmd = Command::new(&taplo);
    cmd.arg("check")
        .arg("--schema")
        .arg(format!("file://{}", schema.display()));
    for (file, line, _, _) in cases {
        let text = format!("schema = \"lenze-tmd\"\n\n[values]\nC0012 = \"8 s\"\n{line}\n");
        std::fs::write(sets.join(file), text).unwrap();
        cmd.arg(sets.join(file));
    }
    // one run for the three files (taplo's start-up is most of its time)
    let out = cmd.current_dir(repo.path()).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    for (file, _, message, at) in cases {
        // the message, then its place on the next line
        let found = err
            .split("error: ")
            .any(|e| e.starts_with(&format!("{message}\n")) && e.contains(at));
        assert!(found, "{file}: {message} at {at}: {err}");
        // validate agrees
        let v = driveset()
            .arg("validate")
            .arg(sets.join(file))
            .output()
            .unwrap();
        assert_eq!(v.status.code(), Some(1), "{file}");
    }
}

#[test]
fn python_jsonschema_accepts_the_json_form_of_every_example_set() {
    let Some(python) = python_or_skip("jsonschema check of the example sets") else {
        return;
    };
    let has = Command::new(&python)
        .args(["-c", "import jsonschema"])
        .status()
        .is_ok_and(|s| s.success());
    if interop_or_skip(
        "jsonschema check of the example sets",
        has.then_some(()),
        "the jsonschema package is missing from the interpreter",
    )
    .is_none()
    {
        return;
    }
    let repo = repo_with_associations();
    let dir = tempfile::tempdir().unwrap();
    let mut pairs = Vec::new();
    for (i, (set, schema)) in associations(repo.path()).into_iter().enumerate() {
        let out = driveset()
            .args(["show", "--to", "json", &set])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{set}");
        let json = dir.path().join(format!("{i}.json"));
        std::fs::write(&json, &out.stdout).unwrap();
        pairs.push(serde_json::json!([set, repo.path().join(schema), json]));
    }
    // one broken set, which must be flagged
    let bad = dir.path().join("bad.json");
    std::fs::write(
        &bad,
        r#"{"schema": "lenze-tmd", "values": {"C0011": 9999, "C0014": "Linear w/ boost", "C0999": 1}}"#,
    )
    .unwrap();
    let tmd = repo
        .path()
        .join(".driveset/json-schema/lenze-tmd.schema.json");
    pairs.push(serde_json::json!(["bad", tmd, bad]));
    let script = r#"
import json, sys, jsonschema
for name, schema, doc in json.load(open(sys.argv[1])):
    s = json.load(open(schema))
    jsonschema.Draft7Validator.check_schema(s)
    # a key matching a property and a pattern is reported once per match
    errors = sorted(set(e.message[:60] for e in jsonschema.Draft7Validator(s).iter_errors(json.load(open(doc)))))
    print(name, len(errors), *errors, sep="|")
"#;
    let list = dir.path().join("pairs.json");
    std::fs::write(&list, serde_json::to_string(&pairs).unwrap()).unwrap();
    let out = Command::new(&python)
        .args(["-c", script])
        .arg(&list)
        .output()
        .unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<&str> = stdout.lines().collect();
    let sets = example_sets();
    assert_eq!(lines.len(), sets.len() + 1, "{stdout}");
    for (line, set) in lines.iter().zip(&sets) {
        assert_eq!(*line, format!("{set}|0"), "{stdout}");
    }
    assert_eq!(
        lines[sets.len()],
        "bad|3|'C0999' does not match any of the regexes: '^(?:[Cc]?0*101|C|'Linear w/ boost' is not valid under any of the given schema|9999 is not valid under any of the given schemas"
    );
}
