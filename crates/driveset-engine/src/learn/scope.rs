//! Owns what a learning run covers: whether a schema lacks facts a drive's
//! descriptions could fill, the parameters a family's drives describe
//! (LUSTBUS sections 11.1, 11.2), and the options to learn on top of a
//! learned schema; which schema a bus command would talk with, learned or
//! not ([`learned_use`], what `identify` says as `uses:`).

use std::path::{Path, PathBuf};

use driveset_proto::lustbus::Dialect;
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::{Family, Learning, Schema};

use crate::client::Identity;

use super::LearnOptions;

/// Whether `schema` lacks facts a drive's descriptions could fill: a
/// learned schema (`[schema.learned]`) that did not ask for every
/// parameter of its family ([`unasked`]); or a LUSTBUS schema (not itself
/// learned, `learned-...`, nor a fictional fixture, which is what the
/// simulated drives are built from) with a code (other than a status code
/// whose reading clears it) without a type, kind or range. A learned
/// schema that asked for every parameter is used as it is, and so is a
/// schema of the user's own (a file by path or in `--schemas DIR` whose id
/// is not its family's built-in one): a learned file names its base by id,
/// and only the built-in and learned schemas have an id every later
/// command resolves.
pub fn needs_learning(schema: &Schema) -> bool {
    if schema.learned.is_some() {
        return !unasked(schema).is_empty();
    }
    schema.id == schema.family.descriptor().schema_id
        && !schema.fictional
        && schema.family.descriptor().learning.is_some()
        && schema.codes.iter().any(|c| {
            c.read_clears != Some(true)
                && (schema.type_of(c).is_none()
                    || c.kind.is_none()
                    || (c.min.is_none() && c.max.is_none() && c.values.is_none()))
        })
}

/// The parameters of `schema`'s family a learned schema did not ask for
/// (empty for a schema that is not learned).
pub fn unasked(schema: &Schema) -> Vec<u32> {
    match &schema.learned {
        Some(l) => default_params(schema.family)
            .into_iter()
            .filter(|p| !l.asked.contains(p))
            .collect(),
        None => Vec::new(),
    }
}

/// The options to learn on top of `base`: a learned base asks only for
/// the parameters it did not ask for ([`unasked`]) unless `opts` names
/// them.
pub fn options_for(base: &Schema, opts: &LearnOptions) -> LearnOptions {
    let mut o = opts.clone();
    if base.learned.is_some() && o.params.is_none() {
        o.params = Some(unasked(base));
    }
    o
}

/// The highest parameter number a LUSTBUS family describes (VF1000: 99,
/// two CODE digits; MC6000/7000: 999, three; the descriptor's
/// [`driveset_schema::Descriptor::max_parameter`]); `None` for the families
/// whose drives have no LUSTBUS descriptions.
pub fn max_parameter(protocol: Family) -> Option<u32> {
    protocol.descriptor().max_parameter()
}

/// The parameters asked for by default (the descriptor's
/// [`driveset_schema::Learning::default_params`]). A family without
/// descriptions is asked for 1..=999, as before the descriptor held the
/// figure (no caller learns from one: only LUSTBUS clients learn).
pub fn default_params(protocol: Family) -> Vec<u32> {
    protocol
        .descriptor()
        .learning
        .map_or(1..=999, |l| l.default_params())
        .collect()
}

/// Why the parameters `schema pull` asks for cannot be given
/// ([`params_to_ask`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ParamsError {
    /// The family's drives have no LUSTBUS descriptions (its protocol
    /// named, as schemas spell it).
    #[error("the drive speaks {0}; schema pull reads LUSTBUS descriptions (VF1000, MC6000/7000)")]
    NoDescriptions(&'static str),
    /// `--params` does not parse.
    #[error("--params: {0}")]
    List(String),
    /// A parameter above the family's highest ([`max_parameter`]).
    #[error("--params: parameter {number} is outside 0..={max} for this family")]
    Outside {
        /// The parameter given.
        number: u32,
        /// The family's highest.
        max: u32,
    },
}

/// The parameters `schema pull` asks a drive of `family` for: `list`
/// (`1-99`, `1,5,100-120`: [`parse_params`]), else every parameter the
/// family describes (`1-99` VF1000, `1-999` MC6000/7000).
///
/// # Errors
/// [`ParamsError`]: a family without descriptions, a list that does not
/// parse or names a parameter above the family's highest.
pub fn params_to_ask(family: Family, list: Option<&str>) -> Result<Vec<u32>, ParamsError> {
    let max = max_parameter(family).ok_or(ParamsError::NoDescriptions(
        family.descriptor().schema_protocol,
    ))?;
    parse_params(list.unwrap_or(&format!("1-{max}")), max)
}

/// `1-99`, `1,5,100-120` -> sorted unique numbers (the grammar of
/// `driveset_schema::schema::parse_number_list`), each within 0..=`max`.
///
/// # Errors
/// [`ParamsError::List`], [`ParamsError::Outside`].
pub fn parse_params(text: &str, max: u32) -> Result<Vec<u32>, ParamsError> {
    let out = driveset_schema::schema::parse_number_list(text).map_err(ParamsError::List)?;
    if let Some(n) = out.iter().find(|n| **n > max) {
        return Err(ParamsError::Outside { number: *n, max });
    }
    Ok(out.into_iter().collect())
}

/// Why a learning option does not read ([`LearnOptions::reading`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LearnOptionError {
    /// Not a description layout's length.
    #[error("--description-layout {0}: use 52, 43, 42 or 34 (the lengths errata L22 discusses)")]
    Layout(String),
    /// Not a type-character reading.
    #[error("--type-chars: {0}")]
    TypeChars(String),
}

impl LearnOptions {
    /// The options that say how MC6000/7000 descriptions read: `layout`
    /// (`52`, `43`, `42`, `34`; errata L22) and `type_chars` (`driveset`,
    /// `table` or a map; errata L23), each guessed from the content when
    /// not given; the parameters the default range, texts read.
    ///
    /// # Errors
    /// [`LearnOptionError`], naming the option.
    pub fn reading(
        layout: Option<&str>,
        type_chars: Option<&str>,
    ) -> Result<LearnOptions, LearnOptionError> {
        let layout = match layout {
            None => None,
            Some(l) => Some(
                McLayout::from_name(l.trim()).ok_or_else(|| LearnOptionError::Layout(l.into()))?,
            ),
        };
        let type_chars = match type_chars {
            None => None,
            Some(t) => Some(McTypeChars::parse(t).map_err(LearnOptionError::TypeChars)?),
        };
        Ok(LearnOptions {
            params: None,
            layout,
            type_chars,
            no_texts: false,
        })
    }
}

/// Which schema a bus command would talk with ([`learned_use`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LearnedUse {
    /// The schema's id, a learned file's id, or the pattern of the learned
    /// file's id the next pull would write (`learned-mc6000-type6000-*`).
    pub would_use: String,
    /// Whether it is (or would be) learned from the drive's descriptions.
    pub learned: bool,
    /// The learned file, where there is one.
    pub file: Option<PathBuf>,
}

/// Which schema a bus command would talk with, and whether it is learned
/// (docs/file-formats.md, "Learned schemas"): a learned schema named
/// (`learned-...`, at `path` if named by file); a schema that needs no
/// learning as it is; else a learned file of this drive's family and TYPE
/// among `entries` (the schema directory's files, listed by the caller
/// only when asked: the engine reads no directory), the newest by name,
/// or the pattern it would be written as.
pub fn learned_use(
    schema: &Schema,
    identity: &Identity,
    path: Option<&Path>,
    entries: impl FnOnce() -> Vec<PathBuf>,
) -> LearnedUse {
    if (schema.learned.is_some() || Learning::is_learned_id(&schema.id)) && !needs_learning(schema)
    {
        return LearnedUse {
            would_use: schema.id.clone(),
            learned: true,
            file: path.map(Path::to_path_buf),
        };
    }
    if !needs_learning(schema) {
        return LearnedUse {
            would_use: schema.id.clone(),
            learned: false,
            file: None,
        };
    }
    // The descriptor's learned-file scheme (a schema that needs learning is
    // of a family that has one; any other is looked for as an MC file, as
    // before). The TYPE is slugged as the learned file's name holds it
    // (`Learning::file_prefix`, the slug of `Learning::file_id`).
    let d = Some(schema.family.descriptor())
        .filter(|d| d.learning.is_some())
        .unwrap_or_else(|| Family::from_dialect(Dialect::Mc).descriptor());
    let ty = identity
        .value_of(d.device_type_code())
        .map(ToString::to_string);
    let prefix = d
        .learning
        .map(|l| l.file_prefix(ty.as_deref()))
        .unwrap_or_default();
    let mut found: Vec<PathBuf> = entries()
        .into_iter()
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with(&prefix) && n.ends_with(".toml"))
        })
        .collect();
    found.sort();
    match found.pop() {
        Some(f) => LearnedUse {
            would_use: f
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or_default()
                .to_string(),
            learned: true,
            file: Some(f),
        },
        None => LearnedUse {
            would_use: format!("{prefix}*"),
            learned: true,
            file: None,
        },
    }
}

#[cfg(test)]
mod tests {
    use driveset_schema::{CodeKey, Registry};

    use super::*;
    use crate::client::{IdentCode, IdentProtocol, IdentValue};

    /// A drive whose TYPE has characters a file name does not keep (`MC
    /// 6000/A`) finds the learned file the engine named for it
    /// (`learned-mc6000-typeMC6000A-...`): the search slugs the TYPE as
    /// the learned id does.
    #[test]
    fn params_lists_and_ranges() {
        assert_eq!(parse_params("1-3, 7,5", 99).unwrap(), vec![1, 2, 3, 5, 7]);
        assert!(parse_params("5-1", 99).is_err());
        assert!(parse_params("1-100", 99).is_err());
        assert!(parse_params("x", 99).is_err());
        assert_eq!(params_to_ask(Family::Vf1000, None).map(|p| p.len()), Ok(99));
        assert_eq!(
            params_to_ask(Family::Mc6000, None).map(|p| p.len()),
            Ok(999)
        );
        assert_eq!(
            params_to_ask(Family::Vf1000, Some("1-100")).map_err(|e| e.to_string()),
            Err("--params: parameter 100 is outside 0..=99 for this family".to_string())
        );
        assert!(matches!(
            params_to_ask(Family::Tmd, Some("1")),
            Err(ParamsError::NoDescriptions(_))
        ));
    }

    #[test]
    fn learning_options_read_or_say_which_is_wrong() {
        let o = LearnOptions::reading(Some(" 43 "), Some("table")).expect("reads");
        assert_eq!(o.layout, McLayout::from_name("43"));
        assert_eq!(o.type_chars, Some(McTypeChars::Table));
        assert_eq!(
            LearnOptions::reading(None, None),
            Ok(LearnOptions::default())
        );
        assert_eq!(
            LearnOptions::reading(Some("50"), None).map_err(|e| e.to_string()),
            Err(
                "--description-layout 50: use 52, 43, 42 or 34 (the lengths errata L22 discusses)"
                    .to_string()
            )
        );
        assert!(LearnOptions::reading(None, Some("1=PT_NOPE")).is_err());
    }

    #[test]
    fn a_type_with_spaces_and_a_slash_finds_its_learned_file() {
        let reg = Registry::builtin().expect("built-in schemas");
        let schema = reg.get("lust-mc6000").expect("mc6000");
        assert!(needs_learning(&schema));
        let d = schema.family.descriptor();
        let ty = "MC 6000/A";
        let mut identity = Identity::of(IdentProtocol::Family(schema.family));
        identity.codes.push(IdentCode::new(
            CodeKey::new(d.device_type_code()),
            "91-TYPE",
            IdentValue::Text(ty.into()),
        ));
        let id = d
            .learned_id(Some(ty), None, 0x1234)
            .expect("a learning family");
        assert_eq!(id, "learned-mc6000-typeMC6000A-d00001234");
        let dir = Path::new("plant");
        let file = dir.join(format!("{id}.toml"));
        let other = dir.join("learned-mc6000-type6000-d00001234.toml");
        let listed = vec![other, file.clone()];
        let got = learned_use(&schema, &identity, None, || listed);
        assert_eq!(
            (got.would_use.as_str(), got.learned, got.file.as_deref()),
            (id.as_str(), true, Some(file.as_path()))
        );
        // none there: the pattern it would be found by, slugged the same way
        let got = learned_use(&schema, &identity, None, Vec::new);
        assert_eq!(
            (got.would_use.as_str(), got.file),
            ("learned-mc6000-typeMC6000A-*", None)
        );
    }
}
