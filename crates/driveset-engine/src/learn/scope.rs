//! Owns what a learning run covers: whether a schema lacks facts a drive's
//! descriptions could fill, the parameters a family's drives describe
//! (LUSTBUS sections 11.1, 11.2), and the options to learn on top of a
//! learned schema.

use driveset_schema::{Family, Schema};

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
