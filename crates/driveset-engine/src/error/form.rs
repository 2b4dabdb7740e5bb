//! The JSON form of a [`Refusal`], as journals record it (`kind` tagged,
//! one flat list of kinds): [`Refusal`] is written and read through
//! [`RefusalForm`], so its own shape (the one address refusal, the
//! sub-enums beside the rooms that raise them) can change while old
//! journals still read and new ones read the same.

use serde::{Deserialize, Serialize};

use super::*;
use crate::client::lustbus::{LustbusCodeProblem, LustbusRefusal};
use crate::client::{LecomRefusal, SdoRefusal};
use crate::guard::GuardRefusal;
use crate::live::LiveRefusal;
use crate::plan::Problem;
use crate::transfer::TransferRefusal;

/// [`Refusal`]'s JSON form: one variant per `kind`, the fields as named
/// in journals.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub(super) enum RefusalForm {
    Plan {
        problems: Vec<Problem>,
    },
    UnknownCode {
        schema: String,
        code: String,
    },
    ReadOnly {
        code: String,
        schema: String,
    },
    NoDatasetHandshake,
    Broadcast {
        code: String,
        why: String,
    },
    BroadcastNotStaged {
        codes: Vec<String>,
    },
    StepOutOfOrder {
        step: String,
        before: String,
    },
    GuardCommand {
        code: String,
        value: String,
    },
    GuardControlWord {
        code: String,
        value: String,
        why: String,
    },
    GuardPermit {
        permit: String,
        code: String,
        value: String,
    },
    LustbusOnCan,
    WrongClient {
        schema: String,
        family: String,
        protocol: driveset_schema::BusProtocol,
    },
    LinkMisfit {
        schema: String,
        family: String,
        bus: String,
        link: LinkKind,
    },
    LecomAddress {
        address: u8,
    },
    LecomGroup {
        tens: u8,
    },
    LecomUnaddressable {
        code: String,
    },
    LecomValue {
        code: String,
        value: String,
        detail: String,
    },
    Encode {
        what: Option<String>,
        detail: String,
    },
    SdoNode {
        node: u32,
    },
    NoSdoIndex {
        code: String,
        base: u32,
    },
    NotSdoType {
        code: String,
        ty: String,
    },
    NotCanFormat {
        code: String,
        value: String,
    },
    LustbusAddress {
        address: u8,
    },
    LustbusCode {
        code: String,
        problem: LustbusCodeProblem,
    },
    NoWireType {
        code: String,
        schema: String,
        family: String,
    },
    NotInteger {
        code: String,
        value: String,
    },
    DoesNotFit {
        code: String,
        value: String,
        ty: String,
    },
    NotCardWriteable {
        code: String,
    },
    Vf1000NoDataset,
    NoDatasetOpen,
    StextMcOnly,
    NoSload {
        schema: String,
    },
    SetSchema {
        set: String,
        schema: String,
    },
    CodesNotInSchema {
        schema: String,
        codes: Vec<String>,
    },
    Diff {
        detail: String,
    },
    WrongType {
        code: String,
        found: Option<i64>,
        schema: String,
        expected: Vec<i64>,
    },
    ScanLustbusAddress {
        address: u8,
    },
    ScanLecomAddress {
        address: u8,
    },
    ScanCanNode {
        node: u32,
    },
    NoProbeCode {
        schema: String,
    },
    DoctorLustbusAddress {
        address: u8,
    },
    DoctorLecomAddress {
        address: u8,
    },
    DoctorCanPort,
    TransferRate {
        detail: String,
    },
    Assign {
        #[serde(flatten)]
        refusal: crate::assign::AssignRefusal,
    },
}

impl From<Refusal> for RefusalForm {
    fn from(r: Refusal) -> Self {
        match r {
            Refusal::Address(a) => a.form(),
            Refusal::Plan { problems } => RefusalForm::Plan { problems },
            Refusal::UnknownCode { schema, code } => RefusalForm::UnknownCode { schema, code },
            Refusal::ReadOnly { code, schema } => RefusalForm::ReadOnly { code, schema },
            Refusal::NoDatasetHandshake => RefusalForm::NoDatasetHandshake,
            Refusal::BroadcastNotStaged { codes } => RefusalForm::BroadcastNotStaged { codes },
            Refusal::StepOutOfOrder { step, before } => {
                RefusalForm::StepOutOfOrder { step, before }
            }
            Refusal::Guard(GuardRefusal::Command { code, value }) => {
                RefusalForm::GuardCommand { code, value }
            }
            Refusal::Guard(GuardRefusal::ControlWord { code, value, why }) => {
                RefusalForm::GuardControlWord { code, value, why }
            }
            Refusal::Guard(GuardRefusal::Permit {
                permit,
                code,
                value,
            }) => RefusalForm::GuardPermit {
                permit,
                code,
                value,
            },
            Refusal::LustbusOnCan => RefusalForm::LustbusOnCan,
            Refusal::WrongClient {
                schema,
                family,
                protocol,
            } => RefusalForm::WrongClient {
                schema,
                family,
                protocol,
            },
            Refusal::LinkMisfit {
                schema,
                family,
                bus,
                link,
            } => RefusalForm::LinkMisfit {
                schema,
                family,
                bus,
                link,
            },
            Refusal::Lecom(LecomRefusal::Group { tens }) => RefusalForm::LecomGroup { tens },
            Refusal::Lecom(LecomRefusal::Unaddressable { code }) => {
                RefusalForm::LecomUnaddressable { code }
            }
            Refusal::Lecom(LecomRefusal::Value {
                code,
                value,
                detail,
            }) => RefusalForm::LecomValue {
                code,
                value,
                detail,
            },
            Refusal::Encode { what, detail } => RefusalForm::Encode { what, detail },
            Refusal::Sdo(SdoRefusal::NoIndex { code, base }) => {
                RefusalForm::NoSdoIndex { code, base }
            }
            Refusal::Sdo(SdoRefusal::NotSdoType { code, ty }) => {
                RefusalForm::NotSdoType { code, ty }
            }
            Refusal::Sdo(SdoRefusal::NotCanFormat { code, value }) => {
                RefusalForm::NotCanFormat { code, value }
            }
            Refusal::Lustbus(l) => l.into(),
            Refusal::Live(LiveRefusal::SetSchema { set, schema }) => {
                RefusalForm::SetSchema { set, schema }
            }
            Refusal::Live(LiveRefusal::CodesNotInSchema { schema, codes }) => {
                RefusalForm::CodesNotInSchema { schema, codes }
            }
            Refusal::Live(LiveRefusal::Diff { detail }) => RefusalForm::Diff { detail },
            Refusal::WrongType {
                code,
                found,
                schema,
                expected,
            } => RefusalForm::WrongType {
                code,
                found,
                schema,
                expected,
            },
            Refusal::NoProbeCode { schema } => RefusalForm::NoProbeCode { schema },
            Refusal::DoctorCanPort => RefusalForm::DoctorCanPort,
            Refusal::Transfer(TransferRefusal::Rate { detail }) => {
                RefusalForm::TransferRate { detail }
            }
            Refusal::Assign { refusal } => RefusalForm::Assign { refusal },
        }
    }
}

impl TryFrom<RefusalForm> for Refusal {
    type Error = String;

    fn try_from(r: RefusalForm) -> Result<Self, String> {
        Ok(match r {
            RefusalForm::Plan { problems } => Refusal::Plan { problems },
            RefusalForm::UnknownCode { schema, code } => Refusal::UnknownCode { schema, code },
            RefusalForm::ReadOnly { code, schema } => Refusal::ReadOnly { code, schema },
            RefusalForm::NoDatasetHandshake => Refusal::NoDatasetHandshake,
            RefusalForm::BroadcastNotStaged { codes } => Refusal::BroadcastNotStaged { codes },
            RefusalForm::StepOutOfOrder { step, before } => {
                Refusal::StepOutOfOrder { step, before }
            }
            RefusalForm::GuardCommand { code, value } => {
                GuardRefusal::Command { code, value }.into()
            }
            RefusalForm::GuardControlWord { code, value, why } => {
                GuardRefusal::ControlWord { code, value, why }.into()
            }
            RefusalForm::GuardPermit {
                permit,
                code,
                value,
            } => GuardRefusal::Permit {
                permit,
                code,
                value,
            }
            .into(),
            RefusalForm::LustbusOnCan => Refusal::LustbusOnCan,
            RefusalForm::WrongClient {
                schema,
                family,
                protocol,
            } => Refusal::WrongClient {
                schema,
                family,
                protocol,
            },
            RefusalForm::LinkMisfit {
                schema,
                family,
                bus,
                link,
            } => Refusal::LinkMisfit {
                schema,
                family,
                bus,
                link,
            },
            RefusalForm::LecomGroup { tens } => Refusal::Lecom(LecomRefusal::Group { tens }),
            RefusalForm::LecomUnaddressable { code } => {
                Refusal::Lecom(LecomRefusal::Unaddressable { code })
            }
            RefusalForm::LecomValue {
                code,
                value,
                detail,
            } => Refusal::Lecom(LecomRefusal::Value {
                code,
                value,
                detail,
            }),
            RefusalForm::Encode { what, detail } => Refusal::Encode { what, detail },
            RefusalForm::NoSdoIndex { code, base } => {
                Refusal::Sdo(SdoRefusal::NoIndex { code, base })
            }
            RefusalForm::NotSdoType { code, ty } => {
                Refusal::Sdo(SdoRefusal::NotSdoType { code, ty })
            }
            RefusalForm::NotCanFormat { code, value } => {
                Refusal::Sdo(SdoRefusal::NotCanFormat { code, value })
            }
            RefusalForm::SetSchema { set, schema } => LiveRefusal::SetSchema { set, schema }.into(),
            RefusalForm::CodesNotInSchema { schema, codes } => {
                LiveRefusal::CodesNotInSchema { schema, codes }.into()
            }
            RefusalForm::Diff { detail } => LiveRefusal::Diff { detail }.into(),
            RefusalForm::WrongType {
                code,
                found,
                schema,
                expected,
            } => Refusal::WrongType {
                code,
                found,
                schema,
                expected,
            },
            RefusalForm::NoProbeCode { schema } => Refusal::NoProbeCode { schema },
            RefusalForm::DoctorCanPort => Refusal::DoctorCanPort,
            RefusalForm::TransferRate { detail } => TransferRefusal::Rate { detail }.into(),
            RefusalForm::Assign { refusal } => Refusal::Assign { refusal },
            form @ (RefusalForm::Broadcast { .. }
            | RefusalForm::LustbusCode { .. }
            | RefusalForm::NoWireType { .. }
            | RefusalForm::NotInteger { .. }
            | RefusalForm::DoesNotFit { .. }
            | RefusalForm::NotCardWriteable { .. }
            | RefusalForm::Vf1000NoDataset
            | RefusalForm::NoDatasetOpen
            | RefusalForm::StextMcOnly
            | RefusalForm::NoSload { .. }) => Refusal::Lustbus(LustbusRefusal::from_form(form)?),
            address => Refusal::Address(AddressRefused::from_form(address)?),
        })
    }
}

/// The LUSTBUS client's refusals keep their flat kinds (`broadcast`,
/// `lustbus_code`, `no_wire_type` ...).
impl From<LustbusRefusal> for RefusalForm {
    fn from(r: LustbusRefusal) -> Self {
        match r {
            LustbusRefusal::Broadcast { code, why } => RefusalForm::Broadcast { code, why },
            LustbusRefusal::Code { code, problem } => RefusalForm::LustbusCode { code, problem },
            LustbusRefusal::NoWireType {
                code,
                schema,
                family,
            } => RefusalForm::NoWireType {
                code,
                schema,
                family,
            },
            LustbusRefusal::NotInteger { code, value } => RefusalForm::NotInteger { code, value },
            LustbusRefusal::DoesNotFit { code, value, ty } => {
                RefusalForm::DoesNotFit { code, value, ty }
            }
            LustbusRefusal::NotCardWriteable { code } => RefusalForm::NotCardWriteable { code },
            LustbusRefusal::Vf1000NoDataset => RefusalForm::Vf1000NoDataset,
            LustbusRefusal::NoDatasetOpen => RefusalForm::NoDatasetOpen,
            LustbusRefusal::StextMcOnly => RefusalForm::StextMcOnly,
            LustbusRefusal::NoSload { schema } => RefusalForm::NoSload { schema },
        }
    }
}

impl LustbusRefusal {
    /// Back from the flat JSON form.
    fn from_form(form: RefusalForm) -> Result<Self, String> {
        Ok(match form {
            RefusalForm::Broadcast { code, why } => LustbusRefusal::Broadcast { code, why },
            RefusalForm::LustbusCode { code, problem } => LustbusRefusal::Code { code, problem },
            RefusalForm::NoWireType {
                code,
                schema,
                family,
            } => LustbusRefusal::NoWireType {
                code,
                schema,
                family,
            },
            RefusalForm::NotInteger { code, value } => LustbusRefusal::NotInteger { code, value },
            RefusalForm::DoesNotFit { code, value, ty } => {
                LustbusRefusal::DoesNotFit { code, value, ty }
            }
            RefusalForm::NotCardWriteable { code } => LustbusRefusal::NotCardWriteable { code },
            RefusalForm::Vf1000NoDataset => LustbusRefusal::Vf1000NoDataset,
            RefusalForm::NoDatasetOpen => LustbusRefusal::NoDatasetOpen,
            RefusalForm::StextMcOnly => LustbusRefusal::StextMcOnly,
            RefusalForm::NoSload { schema } => LustbusRefusal::NoSload { schema },
            other => return Err(format!("{other:?} is not a LUSTBUS refusal")),
        })
    }
}
