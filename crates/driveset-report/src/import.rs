//! Owns what `driveset schema import` says on stderr (docs/file-formats.md,
//! "Imported schemas"): the lints and the summary line of a schema imported
//! from a CiA 306 EDS / DCF, for people or as one JSON document
//! ([`imported`]), and the refusal of a file that is not an EDS / DCF
//! ([`refused`]). The JSON documents' keys are in alphabetical order, as
//! they always were.

use std::path::Path;

use driveset_schema::eds::{ImportError, Imported};

/// The form of what `schema import` says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// Lines for people.
    Human,
    /// One JSON document.
    Json,
}

/// `schema import --format json`'s report.
#[derive(serde::Serialize)]
struct ImportDoc<'a> {
    cia_objects: usize,
    file: &'a str,
    lenze_codes: usize,
    lints: Vec<LintDoc<'a>>,
    output: Option<String>,
    schema: &'a str,
}

/// One lint of the import.
#[derive(serde::Serialize)]
struct LintDoc<'a> {
    line: usize,
    message: &'a str,
    object: &'a str,
}

/// `schema import --format json`'s refusal of a file it cannot read.
#[derive(serde::Serialize)]
struct Refused<'a> {
    error: RefusedAt<'a>,
    file: &'a str,
}

/// Where and why.
#[derive(serde::Serialize)]
struct RefusedAt<'a> {
    column: usize,
    help: &'a str,
    line: usize,
    message: &'a str,
}

/// The report of `imported` from `file`, written to `output` (none:
/// stdout): one JSON document ([`Form::Json`]), else a `lint: FILE:LINE: OBJECT:
/// what was done` line per lint and the summary line; each ends with a
/// newline.
pub fn imported(imported: &Imported, file: &str, output: Option<&Path>, form: Form) -> String {
    if form == Form::Json {
        let doc = ImportDoc {
            cia_objects: imported.cia_objects,
            file,
            lenze_codes: imported.lenze_codes,
            lints: imported
                .lints
                .iter()
                .map(|l| LintDoc {
                    line: l.line,
                    message: &l.message,
                    object: &l.object,
                })
                .collect(),
            output: output.map(|o| o.display().to_string()),
            schema: &imported.id,
        };
        return format!(
            "{}\n",
            serde_json::to_string_pretty(&doc).unwrap_or_default()
        );
    }
    let mut text = String::new();
    for l in &imported.lints {
        text.push_str(&format!("lint: {}\n", l.render(file)));
    }
    text.push_str(&format!(
        "imported {}: schema {}, {} Lenze codes, {} objects by index, {} lints\n",
        file,
        imported.id,
        imported.lenze_codes,
        imported.cia_objects,
        imported.lints.len()
    ));
    text
}

/// The refusal of `file`, which is not an EDS / DCF: one JSON document
/// ([`Form::Json`]), else `error: FILE[:LINE[:COLUMN]]: message` and its help;
/// each ends with a newline.
pub fn refused(e: &ImportError, file: &str, form: Form) -> String {
    if form == Form::Json {
        let doc = Refused {
            error: RefusedAt {
                column: e.column,
                help: &e.help,
                line: e.line,
                message: &e.message,
            },
            file,
        };
        return format!(
            "{}\n",
            serde_json::to_string_pretty(&doc).unwrap_or_default()
        );
    }
    let at = match (e.line, e.column) {
        (0, _) => file.to_string(),
        (l, 0) => format!("{file}:{l}"),
        (l, c) => format!("{file}:{l}:{c}"),
    };
    format!("error: {at}: {}\n  = help: {}\n", e.message, e.help)
}

#[cfg(test)]
mod tests {
    use driveset_schema::eds::{ImportOptions, import};

    use super::*;

    #[test]
    fn a_refusal_names_where_and_what_to_do() {
        let e = |line, column| ImportError {
            line,
            column,
            message: "m".into(),
            help: "h".into(),
        };
        assert_eq!(
            refused(&e(0, 3), "f.eds", Form::Human),
            "error: f.eds: m\n  = help: h\n"
        );
        assert_eq!(
            refused(&e(2, 0), "f.eds", Form::Human),
            "error: f.eds:2: m\n  = help: h\n"
        );
        assert_eq!(
            refused(&e(2, 3), "f.eds", Form::Human),
            "error: f.eds:2:3: m\n  = help: h\n"
        );
        assert_eq!(
            refused(&e(2, 3), "f.eds", Form::Json),
            "{\n  \"error\": {\n    \"column\": 3,\n    \"help\": \"h\",\n    \"line\": 2,\n    \"message\": \"m\"\n  },\n  \"file\": \"f.eds\"\n}\n"
        );
    }

    #[test]
    fn an_import_reports_its_lints_and_a_summary() {
        let eds = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/data/eds/fictional-ecs-axis.eds"
        ))
        .expect("the test EDS");
        let opts = ImportOptions {
            id: Some("x".into()),
            file: "x.eds".into(),
        };
        let i = import(&eds, &opts).expect("imports");
        let human = imported(&i, "x.eds", None, Form::Human);
        assert!(human.ends_with(&format!(
            "imported x.eds: schema x, {} Lenze codes, {} objects by index, {} lints\n",
            i.lenze_codes,
            i.cia_objects,
            i.lints.len()
        )));
        assert_eq!(human.lines().count(), i.lints.len() + 1);
        let json: serde_json::Value = serde_json::from_str(&imported(
            &i,
            "x.eds",
            Some(Path::new("o.toml")),
            Form::Json,
        ))
        .expect("JSON");
        assert_eq!(json["output"], "o.toml");
        assert_eq!(json["schema"], "x");
        assert_eq!(json["lints"].as_array().map(Vec::len), Some(i.lints.len()));
    }
}
