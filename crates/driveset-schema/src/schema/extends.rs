//! Fixture schemas that `extends` a base: filling the base code's unset
//! facts from the fixture's code of the same number, and a finding for a
//! fact both give differently (docs/file-formats.md, "extends").

use crate::error::{Finding, FindingKind, Location};

use super::{Code, EnumSource, Fact};

/// Fill the unset facts of a base code from a fixture's code of the same
/// number; a fact both give differently is a finding.
pub(super) fn fill_unset(base: &mut Code, over: Code) -> Vec<Finding> {
    let mut out = Vec::new();
    let number = base.number;
    macro_rules! fill {
        ($field:ident) => {
            match (&base.$field, over.$field) {
                (None, Some(v)) => base.$field = Some(v),
                (Some(a), Some(b)) if *a != b => out.push(Finding::new(
                    FindingKind::SchemaError,
                    over.loc.clone(),
                    format!("fixture changes `{}` of code {number}, which the base schema already gives", stringify!($field)),
                    "a fixture may only fill facts the base leaves unset; remove it from the fixture",
                )),
                _ => {}
            }
        };
    }
    if base.name.is_empty() {
        base.name = over.name;
        base.name_loc = over.name_loc;
    } else if !over.name.is_empty() && over.name != base.name {
        out.push(Finding::new(
            FindingKind::SchemaError,
            over.name_loc.clone().unwrap_or_else(|| over.loc.clone()),
            format!(
                "fixture renames code {number} from `{}` to `{}`",
                base.name, over.name
            ),
            "add the new name to `aliases` instead",
        ));
    }
    base.aliases.extend(over.aliases);
    base.unit_aliases.extend(over.unit_aliases);
    fill!(title);
    fill!(spec);
    fill!(unit);
    fill!(access);
    fill!(lecom_only);
    fill!(subcodes);
    fill!(index);
    fill!(subindex);
    fill!(data_type);
    fill!(note);
    fill!(kind);
    fill!(basis);
    fill!(width);
    fill!(card_writeable);
    if base.stopped.is_empty() {
        base.stopped = over.stopped;
    }
    if base.role.is_none() {
        base.role = over.role;
        base.role_loc = over.role_loc;
    } else if over.role.is_some() && over.role != base.role {
        out.push(Finding::new(
            FindingKind::SchemaError,
            over.role_loc.clone().unwrap_or_else(|| over.loc.clone()),
            format!("fixture changes `role` of code {number}, which the base schema already gives"),
            "a fixture may only fill facts the base leaves unset; remove it from the fixture",
        ));
    }
    fill!(read_clears);
    fill!(compatible);
    fill!(values_partial);
    // facts with locations: compare by value only
    macro_rules! fill_loc {
        ($field:ident, $eq:expr) => {
            match (&base.$field, over.$field) {
                (None, Some(v)) => base.$field = Some(v),
                (Some(a), Some(b)) if !$eq(a, &b) => out.push(Finding::new(
                    FindingKind::SchemaError,
                    over.loc.clone(),
                    format!("fixture changes `{}` of code {number}, which the base schema already gives", stringify!($field)),
                    "a fixture may only fill facts the base leaves unset; remove it from the fixture",
                )),
                _ => {}
            }
        };
    }
    fill_loc!(
        type_name,
        |a: &(String, Location), b: &(String, Location)| a.0 == b.0
    );
    fill_loc!(min, |a: &Fact, b: &Fact| a.value == b.value);
    fill_loc!(max, |a: &Fact, b: &Fact| a.value == b.value);
    fill_loc!(default, |a: &Fact, b: &Fact| a.value == b.value);
    fill_loc!(values, |_: &EnumSource, _: &EnumSource| false);
    if base.bits.is_empty() {
        base.bits = over.bits;
    } else if !over.bits.is_empty() {
        out.push(Finding::new(
            FindingKind::SchemaError,
            over.loc.clone(),
            format!("fixture redefines the bit fields of code {number}"),
            "a fixture may only fill facts the base leaves unset; remove them from the fixture",
        ));
    }
    out
}
