//! Owns `driveset git-setup --json-schemas DIR`: the JSON Schema of every
//! schema the repository's sets name (read as `validate` reads them, so a
//! learned or imported schema beside the sets counts), written into DIR,
//! and their association with the set files for the editors: taplo's
//! `.taplo.toml` rules (Even Better TOML and the taplo CLI read them) and
//! VS Code's `.vscode/settings.json` `yaml.schemas` (yaml-language-server).
//! Both files keep what they hold; driveset's part is replaced on a rerun.

use std::collections::BTreeMap;
use std::path::Path;

use driveset_schema::Registry;
use driveset_schema::doc::Syntax;
use serde_json::{Map, Value};

use crate::json_schema::{file_name, json_schema};

/// First and last line of driveset's block in `.taplo.toml`.
pub const TAPLO_BEGIN: &str = "# >>> driveset git-setup --json-schemas (rerun it to update)";
/// See [`TAPLO_BEGIN`].
pub const TAPLO_END: &str = "# <<< driveset git-setup --json-schemas";

/// Sets grouped by the schema they name: schema id -> (TOML files, YAML files),
/// paths relative to the work tree's top, `/`-separated.
#[derive(Debug, Default)]
pub struct Sets {
    by_schema: BTreeMap<String, (Vec<String>, Vec<String>)>,
}

fn rel(top: &Path, p: &Path) -> String {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    abs.strip_prefix(top)
        .unwrap_or(&abs)
        .to_string_lossy()
        .replace('\\', "/")
}

/// Write the JSON Schemas of the sets under `dirs` into `out_dir` and
/// associate them (`.taplo.toml`, `.vscode/settings.json` at `top`); the
/// sets' schemas are looked up in `registry`, as `validate` does. Returns
/// the lines to print.
pub fn associate(
    top: &Path,
    dirs: &[String],
    out_dir: &str,
    registry: &mut Registry,
) -> Result<Vec<String>, String> {
    let mut sets = Sets::default();
    let mut schemas = BTreeMap::new();
    for d in dirs {
        let mut files = Vec::new();
        driveset_schema::walk::collect(&top.join(d), &mut files).map_err(|e| e.message)?;
        for f in files {
            if driveset_engine::line::manifest::is_manifest(&f) {
                continue;
            }
            // schema files and unreadable sets are `validate`'s to report
            let Ok(loaded) = driveset_schema::load_set(&f, registry) else {
                continue;
            };
            let Some(schema) = loaded.schema else {
                continue;
            };
            let entry = sets.by_schema.entry(schema.id.clone()).or_default();
            match Syntax::from_path(&f) {
                Syntax::Toml => entry.0.push(rel(top, &f)),
                Syntax::Yaml => entry.1.push(rel(top, &f)),
            }
            schemas.insert(schema.id.clone(), schema);
        }
    }
    let mut said = Vec::new();
    let out = top.join(out_dir);
    std::fs::create_dir_all(&out).map_err(|e| format!("cannot create {}: {e}", out.display()))?;
    for (id, schema) in &schemas {
        let p = out.join(file_name(id));
        driveset_schema::output::write_output(&p, json_schema(schema).as_bytes())
            .map_err(|e| format!("{}; {}", e.message, e.help))?;
        said.push(format!("{}: JSON Schema of {id}", rel(top, &p)));
    }
    let taplo = top.join(".taplo.toml");
    let existing = read_or_empty(&taplo)?;
    write_if_changed(&taplo, &existing, &taplo_text(&existing, &sets, out_dir))?;
    said.push(".taplo.toml: set files use their JSON Schema (taplo, Even Better TOML)".into());
    let vscode = top.join(".vscode/settings.json");
    let existing = read_or_empty(&vscode)?;
    let text = vscode_text(&existing, &sets, out_dir).map_err(|e| {
        format!(
            "{}: {e}; add `yaml.schemas` by hand (docs/editors.md)",
            vscode.display()
        )
    })?;
    if let Some(dir) = vscode.parent() {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    write_if_changed(&vscode, &existing, &text)?;
    said.push(
        ".vscode/settings.json: YAML sets use their JSON Schema (yaml-language-server)".into(),
    );
    Ok(said)
}

/// The settings file at `p`, or empty when there is none yet (the one
/// settings reader, `driveset_schema::input::read_settings`).
fn read_or_empty(p: &Path) -> Result<String, String> {
    driveset_schema::input::read_settings(p).map_err(|e| format!("{}; {}", e.message, e.help))
}

fn write_if_changed(p: &Path, old: &str, new: &str) -> Result<(), String> {
    if old == new {
        return Ok(());
    }
    driveset_schema::output::write_output(p, new.as_bytes())
        .map_err(|e| format!("{}; {}", e.message, e.help))
}

fn toml_str(s: &str) -> String {
    serde_json::to_string(s).unwrap_or_default()
}

/// `.taplo.toml` with driveset's block (one `[[rule]]` per schema) in
/// place of the previous one, or appended.
pub fn taplo_text(existing: &str, sets: &Sets, out_dir: &str) -> String {
    let mut block = format!("{TAPLO_BEGIN}\n");
    for (id, (toml, _)) in &sets.by_schema {
        if toml.is_empty() {
            continue;
        }
        let files: Vec<String> = toml.iter().map(|f| toml_str(f)).collect();
        block.push_str(&format!(
            "[[rule]]\nname = {}\ninclude = [{}]\n[rule.schema]\npath = {}\n",
            toml_str(&format!("driveset {id}")),
            files.join(", "),
            toml_str(&format!(
                "{}/{}",
                out_dir.trim_end_matches('/'),
                file_name(id)
            ))
        ));
    }
    block.push_str(TAPLO_END);
    block.push('\n');
    match (existing.find(TAPLO_BEGIN), existing.find(TAPLO_END)) {
        (Some(a), Some(b)) if b > a => {
            let end = existing[b..]
                .find('\n')
                .map_or(existing.len(), |i| b + i + 1);
            format!("{}{block}{}", &existing[..a], &existing[end..])
        }
        _ if existing.is_empty() => block,
        _ => {
            let sep = if existing.ends_with('\n') {
                "\n"
            } else {
                "\n\n"
            };
            format!("{existing}{sep}{block}")
        }
    }
}

/// `.vscode/settings.json` with `yaml.schemas` naming each schema's YAML
/// sets (other settings and other schemas kept). `Err` when the file is
/// not plain JSON (VS Code allows comments, which this does not rewrite).
pub fn vscode_text(existing: &str, sets: &Sets, out_dir: &str) -> Result<String, String> {
    let mut root: Map<String, Value> = if existing.trim().is_empty() {
        Map::new()
    } else {
        serde_json::from_str(existing)
            .map_err(|e| format!("not plain JSON ({e}), so driveset does not rewrite it"))?
    };
    let schemas = root
        .entry("yaml.schemas")
        .or_insert_with(|| Value::Object(Map::new()));
    let Value::Object(schemas) = schemas else {
        return Err("`yaml.schemas` is not an object".into());
    };
    for (id, (_, yaml)) in &sets.by_schema {
        if yaml.is_empty() {
            continue;
        }
        let key = format!("{}/{}", out_dir.trim_end_matches('/'), file_name(id));
        schemas.insert(
            key,
            Value::Array(yaml.iter().map(|f| Value::String(f.clone())).collect()),
        );
    }
    let mut text = serde_json::to_string_pretty(&Value::Object(root)).unwrap_or_default();
    text.push('\n');
    Ok(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sets() -> Sets {
        let mut s = Sets::default();
        s.by_schema.insert(
            "lenze-tmd".into(),
            (vec!["sets/a.toml".into()], vec!["sets/b.yaml".into()]),
        );
        s
    }

    #[test]
    fn taplo_block_is_replaced_not_repeated() {
        let first = taplo_text("[formatting]\nalign_entries = true\n", &sets(), ".driveset");
        assert_eq!(
            first,
            format!(
                "[formatting]\nalign_entries = true\n\n{TAPLO_BEGIN}\n[[rule]]\nname = \"driveset lenze-tmd\"\ninclude = [\"sets/a.toml\"]\n[rule.schema]\npath = \".driveset/lenze-tmd.schema.json\"\n{TAPLO_END}\n"
            )
        );
        assert_eq!(taplo_text(&first, &sets(), ".driveset"), first);
    }

    #[test]
    fn vscode_settings_keep_other_keys_and_refuse_comments() {
        let t = vscode_text("{\"editor.tabSize\": 2}", &sets(), ".driveset").unwrap();
        let v: Value = serde_json::from_str(&t).unwrap();
        assert_eq!(v["editor.tabSize"], 2);
        assert_eq!(
            v["yaml.schemas"][".driveset/lenze-tmd.schema.json"][0],
            "sets/b.yaml"
        );
        assert!(vscode_text("// c\n{}", &sets(), ".driveset").is_err());
    }
}
