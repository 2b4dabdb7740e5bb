//! Learning a schema from a LUSTBUS drive: reading its own parameter
//! descriptions (VF1000 specifier 1, section 11.1; MC6000/7000 specifier
//! 3, section 11.2), the unit strings (107-UNIT) and value substitution
//! texts (108-STEXT + `61ppp`, section 11.3), interpreting them whatever
//! layout and type characters the drive uses (errata L22, L23), and writing
//! the result as a schema file that `extends` the built-in schema.
//!
//! # Merge rule
//!
//! The learned file `extends` the built-in schema (`lust-vf1000` /
//! `lust-mc6000`) and so merges like a fixture: **a fact the built-in schema
//! gives (from the spec) stands**; the drive's description only fills the
//! facts it leaves unset (type, unit, min, max, default, kind, width,
//! card_writeable, access, value texts), and adds the parameters the spec
//! does not name. Where the drive contradicts a spec fact (another kind,
//! type, unit, min, max or default; an actual value where the spec has a
//! command, control word or setpoint), the spec's fact stands for that
//! code, the drive's is recorded as a guess in a `# drive says:` comment
//! above the entry, and a [`KEPT_SPEC`] finding names the code, both facts
//! and the spec section (docs/file-formats.md, "Learned schemas").
//!
//! # A learned schema is a schema
//!
//! The file carries `[schema.learned] asked` (the parameters asked for).
//! [`needs_learning`] is false for a learned schema that asked for every
//! parameter of its family; one that did not is learned on top of for the
//! others only ([`options_for`]), and the result is the earlier file's own
//! text with the new entries appended, so it extends the same base (an id
//! every reader resolves).
//!
//! # Markers
//!
//! Every learned code carries a `# learned: ...` comment listing the facts
//! taken from the drive; a code the spec does not name has
//! `spec = "learned from the drive's description ..."`; whatever is a
//! guess rather than read (the layout or type-character reading chosen by
//! content, a type kept as a raw integer because its character is unknown,
//! a range left out because the description contradicts itself) is said in
//! `note = "guessed: ..."` (or a `# guessed:` comment where the spec has a
//! note).
//!
//! # Descriptions that contradict themselves
//!
//! Minimum above maximum: the range is left out. Default outside the
//! range: the default is left out. A bound the type cannot hold: the type
//! is downgraded to the raw integer the bounds need. An unknown type
//! character: the code is kept as a raw integer of the width its min / max
//! / default need (PT_USIGN8, PT_USIGN16 or PT_INTEGER16; a code that needs
//! 32 bits is kept without a type, since LUSTBUS has no raw 32-bit type).
//! A description that does not decode at all is left out. Each case is a
//! [`LearnFinding`] naming the parameter and why. After rendering, the
//! schema is parsed and checked ([`driveset_schema::check_schema`]); a code
//! the check still objects to (the objection's line in its learned entry,
//! or in the base entry a learned fact merged into) is left out, and the
//! finding names the code and the check, so a learned file always passes
//! `driveset schema check`; only an objection outside every code fails.

//!
//! # Rooms
//!
//! - `model.rs`: what the drive sent and what was learned from it
//!   ([`RawDescription`], [`LearnedCode`], [`Learned`], [`LearnFinding`]);
//! - `scope.rs`: whether a schema needs learning and which parameters a run
//!   asks for ([`needs_learning`], [`unasked`], [`options_for`]), and
//!   which schema a bus command would talk with ([`learned_use`]);
//! - `read.rs`: the learn run on the bus (descriptions, MC unit and value
//!   texts; [`learn`]);
//! - `interpret.rs`, `mc.rs`, `vf.rs`: the pure reading of the descriptions
//!   ([`interpret`]; MC layouts and type characters, VF1000 descriptions);
//!   `bounds.rs`: a description's type and bounds, downgraded where they
//!   contradict themselves;
//! - `contradict.rs`: where the drive contradicts its base schema (merge
//!   rule);
//! - `render.rs`: the learned file's text; `file.rs`: its id, and rendering
//!   it until it checks ([`render_schema`]);
//! - `pull.rs`: identify, learn and render in one ([`pull_schema`]).

use driveset_proto::lustbus::Dialect;
use driveset_proto::lustbus::description::{McLayout, McTypeChars};
use driveset_schema::Family;

mod bounds;
mod contradict;
mod file;
mod interpret;
mod mc;
mod model;
mod pull;
mod read;
mod render;
mod scope;
mod vf;

pub use file::{LearnSource, LearnedSchema, learned_id, render_schema};
pub use interpret::interpret;
pub use model::{KEPT_SPEC, LearnFinding, Learned, LearnedCode, RawDescription};
pub use pull::{PullSchemaError, PulledDescriptions, PulledSchema, pull_descriptions, pull_schema};
pub use read::{learn, read_descriptions, read_texts};
pub use scope::{
    LearnOptionError, LearnedUse, ParamsError, default_params, learned_use, max_parameter,
    needs_learning, options_for, params_to_ask, parse_params, unasked,
};

/// How to learn.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LearnOptions {
    /// Parameters to ask for (default VF1000 1..=99, MC6000/7000 1..=999).
    pub params: Option<Vec<u32>>,
    /// MC: read every description in this layout instead of telling the
    /// layout by length and content.
    pub layout: Option<McLayout>,
    /// MC: read type characters this way instead of guessing the reading
    /// from the descriptions' content.
    pub type_chars: Option<McTypeChars>,
    /// Do not read units and substitution texts (no 108-STEXT writes).
    pub no_texts: bool,
}

/// The LUSTBUS dialect `protocol`'s descriptions are read in, as its
/// descriptor says ([`driveset_schema::Descriptor::dialect`]): MC6000/7000
/// the MC one (specifier 3, section 11.2, with 107-UNIT and 108-STEXT
/// texts); every other family is read as a VF1000 (specifier 1, section
/// 11.1), as before the descriptor was asked.
fn dialect(protocol: Family) -> Dialect {
    protocol.descriptor().dialect.unwrap_or(Dialect::Vf1000)
}

/// Whether `protocol`'s descriptions are read in the MC dialect
/// ([`dialect`]).
fn speaks_mc(protocol: Family) -> bool {
    dialect(protocol) == Dialect::Mc
}

/// The spec section of `protocol`'s parameter descriptions (LUSTBUS 11.2
/// for the MC dialect, 11.1 for the VF1000 one), as learned files cite it.
fn description_section(protocol: Family) -> &'static str {
    match dialect(protocol) {
        Dialect::Mc => "11.2",
        Dialect::Vf1000 => "11.1",
    }
}
