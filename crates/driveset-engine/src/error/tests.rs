//! The errors' messages and JSON forms, one case per variant.

use driveset_proto::can::{AbortCode, Index, Subindex};
use driveset_proto::lecom::{ExtendedError, OperatingStatus};
use driveset_proto::lustbus::Siof;

use driveset_schema::BusProtocol;

use super::*;
use crate::client::lustbus::{LustbusCodeProblem, LustbusRefusal};
use crate::client::{LecomRefusal, SdoRefusal};
use crate::doctor::DoctorRefusal;
use crate::identify::IdentifyRefusal;
use crate::live::LiveRefusal;
use crate::plan::Problem;
use crate::scan::ScanRefusal;
use crate::upload::UploadRefusal;

fn target() -> Target {
    Target {
        port: "sim://demo".into(),
        address: 1,
    }
}

/// The address refusal a client's check gives.
fn client(bus: BusProtocol, address: u8) -> Refusal {
    AddressRefused::check_client(bus, address).expect_err("refused")
}

/// The address refusal a scan's check gives.
fn scan(bus: BusProtocol, address: u8) -> Refusal {
    AddressRefused::check_scan(bus, address).expect_err("refused")
}

/// The address refusal `doctor`'s check gives.
fn doctor(bus: BusProtocol, address: u8) -> Refusal {
    AddressRefused::check_doctor(bus, address).expect_err("refused")
}

fn s(x: &str) -> String {
    x.to_string()
}

#[test]
fn every_refusal_renders_its_message() {
    let cases: Vec<(Refusal, &str)> = vec![
        (
            Refusal::UnknownCode {
                schema: s("lust-mc6000"),
                code: s("999"),
            },
            "schema `lust-mc6000` has no code 999; check the set names the right drive family",
        ),
        (
            Refusal::ReadOnly {
                code: s("91-TYPE"),
                schema: s("lust-mc6000"),
            },
            "91-TYPE is read-only in schema `lust-mc6000`; remove it from the set",
        ),
        (
            Refusal::NoDatasetHandshake,
            "this drive family has no dataset download handshake",
        ),
        (
            LustbusRefusal::Broadcast {
                code: s("85-SERR"),
                why: s(
                    "a numerically compatible code (81..85, 91; section 5.2) is never broadcast",
                ),
            }
            .into(),
            "broadcast (address 31) of 85-SERR: a numerically compatible code (81..85, 91; section 5.2) is never broadcast",
        ),
        (
            UploadRefusal::BroadcastNotStaged {
                codes: vec![s("416-A"), s("417-B")],
            }
            .into(),
            "broadcast of 416-A, 417-B refused: not a value this drive's dataset stages",
        ),
        (
            UploadRefusal::StepOutOfOrder {
                step: s("commit"),
                before: s("open_dataset"),
            }
            .into(),
            "transaction step `commit` called before `open_dataset`",
        ),
        (Refusal::LustbusOnCan, "a LUSTBUS drive on a CAN bus"),
        (
            Refusal::WrongClient {
                schema: s("lenze-tmd"),
                family: s("tmd"),
                protocol: driveset_schema::BusProtocol::Lustbus,
            },
            "schema `lenze-tmd` is not a LUSTBUS family (tmd drives); pick the client of its protocol",
        ),
        (
            Refusal::WrongClient {
                schema: s("lust-mc6000"),
                family: s("mc6000"),
                protocol: driveset_schema::BusProtocol::Lecom,
            },
            "schema `lust-mc6000` is not a LECOM family (mc6000 drives); pick the client of its protocol",
        ),
        (
            Refusal::WrongClient {
                schema: s("lenze-tmd"),
                family: s("tmd"),
                protocol: driveset_schema::BusProtocol::CanSdo,
            },
            "schema `lenze-tmd` is not a CAN SDO family (tmd drives); pick the client of its protocol",
        ),
        (
            Refusal::LinkMisfit {
                schema: s("lenze-ecs"),
                family: s("ecs"),
                bus: s("CAN SDO"),
                link: LinkKind::CharacterLine,
            },
            "schema `lenze-ecs` is for ecs drives (CAN SDO), which do not run on a character line",
        ),
        (
            Refusal::LinkMisfit {
                schema: s("lenze-tmd"),
                family: s("tmd"),
                bus: s("LECOM"),
                link: LinkKind::CanBus,
            },
            "schema `lenze-tmd` is for tmd drives (LECOM), which do not run on a CAN bus",
        ),
        (
            client(BusProtocol::Lecom, 20),
            "LECOM address 20 is not a station: use 01..99 except 00 and the group addresses 10, 20, .. 90 (BROADCAST / MULTICAST, section 8.J; use broadcast() for those)",
        ),
        (
            LecomRefusal::Group { tens: 12 }.into(),
            "group 12 does not exist: groups are 1..9 (addresses 10..90, section 8.J)",
        ),
        (
            LecomRefusal::Unaddressable { code: s("C70000") }.into(),
            "C70000 cannot be addressed on LECOM (code above 65535 or subcode above 255, section 8.D)",
        ),
        (
            LecomRefusal::Value {
                code: s("C0011"),
                value: s("raw 12"),
                detail: s("the schema gives no LECOM format"),
            }
            .into(),
            "C0011 = raw 12: the schema gives no LECOM format",
        ),
        (
            Refusal::Encode {
                what: Some(s("read C0011")),
                detail: s("too long"),
            },
            "read C0011: too long",
        ),
        (
            Refusal::Encode {
                what: None,
                detail: s("too long"),
            },
            "too long",
        ),
        (
            client(BusProtocol::CanSdo, 0),
            "node id 0 is out of range 1..=127: 0 addresses no SDO server (DS301)",
        ),
        (
            SdoRefusal::NoIndex {
                code: s("C30000"),
                base: 24575,
            }
            .into(),
            "C30000 has no SDO index (code above the index base 24575 or subcode above 255)",
        ),
        (
            SdoRefusal::NotSdoType {
                code: s("C0093"),
                ty: s("?"),
            }
            .into(),
            "C0093: type ? does not travel over CAN SDO",
        ),
        (
            SdoRefusal::NotCanFormat {
                code: s("C0011"),
                value: s("\"x\""),
            }
            .into(),
            "C0011 = \"x\" does not fit its CAN format",
        ),
        (
            client(BusProtocol::Lustbus, 31),
            "LUSTBUS address 31 is not a drive address: use 1..30, or 0 with a single drive on the line (31 is the broadcast address, section 4.2)",
        ),
        (
            LustbusRefusal::Code {
                code: s("300-X"),
                problem: LustbusCodeProblem::HasSubcode,
            }
            .into(),
            "300-X has a subcode; LUSTBUS parameters have none (check the schema)",
        ),
        (
            LustbusRefusal::Code {
                code: s("7-X"),
                problem: LustbusCodeProblem::NotAddressable,
            }
            .into(),
            "7-X cannot be addressed",
        ),
        (
            LustbusRefusal::Code {
                code: s("120-X"),
                problem: LustbusCodeProblem::AboveVf1000Range,
            }
            .into(),
            "120-X is above 99, the VF1000 range (section 2.4.1)",
        ),
        (
            LustbusRefusal::Code {
                code: s("1200"),
                problem: LustbusCodeProblem::AboveMcRange,
            }
            .into(),
            "1200 is above 999, the MC6000/7000 range (section 2.4.2)",
        ),
        (
            LustbusRefusal::NoWireType {
                code: s("300-X"),
                schema: s("lust-mc6000"),
                family: s("MC6000/7000"),
            }
            .into(),
            "300-X: schema `lust-mc6000` gives no MC6000/7000 type or width, so the value cannot be encoded; add `type` to the schema",
        ),
        (
            LustbusRefusal::NotInteger {
                code: s("300-X"),
                value: s("\"a\""),
            }
            .into(),
            "300-X: LUSTBUS parameters hold integers, not \"a\"",
        ),
        (
            LustbusRefusal::DoesNotFit {
                code: s("300-X"),
                value: s("raw 70000"),
                ty: s("USIGN16"),
            }
            .into(),
            "300-X: raw 70000 does not fit USIGN16",
        ),
        (
            LustbusRefusal::NotCardWriteable {
                code: s("428-RSIO"),
            }
            .into(),
            "428-RSIO is not CardWriteable: during a dataset download the drive ACKs it but does not take the value (section 11.4); write it after dataset_commit",
        ),
        (
            LustbusRefusal::Vf1000NoDataset.into(),
            "the VF1000 has no dataset download handshake (SLOAD is MC6000/7000 only, section 11.4)",
        ),
        (
            LustbusRefusal::NoDatasetOpen.into(),
            "no dataset download is open; call dataset_begin first",
        ),
        (
            LustbusRefusal::StextMcOnly.into(),
            "108-STEXT substitution texts are MC6000/7000 only (section 11.3)",
        ),
        (
            LustbusRefusal::NoSload { schema: s("x") }.into(),
            "schema `x` has no 80-SLOAD; the dataset download needs it",
        ),
        (
            LiveRefusal::SetSchema {
                set: s("a"),
                schema: s("b"),
            }
            .into(),
            "the set is for schema `a`, the drive is read with schema `b`; compare a set of this drive family",
        ),
        (
            LiveRefusal::CodesNotInSchema {
                schema: s("b"),
                codes: vec![s("7"), s("8")],
            }
            .into(),
            "codes not in schema `b`: 7, 8; remove them from the set",
        ),
        (
            LiveRefusal::Diff {
                detail: s("schemas differ"),
            }
            .into(),
            "schemas differ",
        ),
        (
            IdentifyRefusal::WrongType {
                code: s("91-TYPE"),
                found: Some(9999),
                schema: s("lust-mc6000"),
                expected: vec![1234, 1235],
            }
            .into(),
            "the drive reports 91-TYPE = 9999, which is not a `lust-mc6000` type ([1234, 1235]); use the set and schema of the drive's family",
        ),
        (
            IdentifyRefusal::WrongType {
                code: s("91-TYPE"),
                found: None,
                schema: s("x"),
                expected: vec![1],
            }
            .into(),
            "the drive reports 91-TYPE = nothing, which is not a `x` type ([1]); use the set and schema of the drive's family",
        ),
        (
            scan(BusProtocol::Lustbus, 0),
            "0 is not a scan target: LUSTBUS drive addresses are 1..30 (0 makes every drive answer at once, 31 is the broadcast address, section 4.2)",
        ),
        (
            scan(BusProtocol::Lecom, 0),
            "00 is not a scan target: LECOM stations are 01..99 without 00 and the group addresses 10..90 (section 8.J)",
        ),
        (
            scan(BusProtocol::CanSdo, 0),
            "node id 0 is out of range 1..=127: node 0 is no SDO server and cannot be a scan target (DS301)",
        ),
        (
            ScanRefusal::NoProbeCode { schema: s("x") }.into(),
            "schema `x` has no code to probe with",
        ),
        (
            doctor(BusProtocol::Lustbus, 31),
            "31 is not a LUSTBUS drive address: use 1..30, or 0 (every drive answers, stand-alone operation, section 4.1)",
        ),
        (
            doctor(BusProtocol::Lecom, 0),
            "00 is not a LECOM station: use 01..99 without 00 and the group addresses 10..90 (section 8.J)",
        ),
        (
            DoctorRefusal::CanPort.into(),
            "CAN ports are checked by run_can",
        ),
        (
            Refusal::Plan {
                problems: vec![Problem::Running],
            },
            "the drive reports a running motor; stop it (standstill) before uploading, or pass --allow-running",
        ),
        (
            Refusal::Plan {
                problems: vec![
                    Problem::ReadOnly { code: s("91-TYPE") },
                    Problem::NotInSchema {
                        code: s("999"),
                        schema: s("x"),
                    },
                ],
            },
            "2 problems: 91-TYPE: read-only (an actual value); remove it from the set; code 999 is not in schema `x`; remove it from the set (or fix the number)",
        ),
    ];
    for (refusal, want) in cases {
        assert_eq!(refusal.to_string(), want, "{refusal:?}");
        let e = EngineError::refused(target(), refusal);
        assert_eq!(
            e.to_string(),
            format!("sim://demo address 1: refused: {want}")
        );
    }
}

#[test]
fn every_device_cause_renders_cause_raw_and_remedy() {
    let siof = |bits: u8, verdict| DeviceCause::Siof {
        register: SiofRegister::Serr,
        bits: Siof(bits),
        verdict,
    };
    let cases: Vec<(DeviceCause, &str, &str, &str)> = vec![
        (
            siof(0x80, SiofVerdict::Failed),
            "invalid value (The transfer parameter value is not permissible)",
            "SERR 80H Invalid value",
            "Choose a different value",
        ),
        (
            DeviceCause::Siof {
                register: SiofRegister::Siof,
                bits: Siof(0x21),
                verdict: SiofVerdict::Failed,
            },
            "power on (Bit is set for each ON), no parameter (There is no parameter for the given number)",
            "SIOF 21H Power on, No parameter",
            "General service error or error in the software of the Host computer.",
        ),
        (
            siof(0x04, SiofVerdict::EepromBusy { repeats: 5 }),
            "EEPROM busy",
            "SERR 04H EEPROM busy",
            "the EEPROM stayed busy over 5 repetitions; wait and retry the write",
        ),
        (
            siof(0x00, SiofVerdict::Unrecorded),
            "refused (NAK) without a recorded cause",
            "SERR 00H no error",
            "check the value and the drive's operating state, then retry",
        ),
        (
            siof(0x08, SiofVerdict::Checksum),
            "checksum error",
            "SERR 08H Checksum error",
            "check the line (termination, noise), then retry",
        ),
        (
            siof(0x40, SiofVerdict::NotAtStandstill),
            "the drive is not at standstill: SLOAD = -1 (register a download) is only taken at standstill",
            "SERR 40H No change",
            "stop the drive (section 11.4), then start the download again",
        ),
        (
            siof(0x40, SiofVerdict::NoSubstitutionTexts),
            "refused (NAK)",
            "SERR 40H No change",
            "the drive has no substitution texts (not an MC6000/7000?)",
        ),
        (
            DeviceCause::SiofUnreadable,
            "SIOF/SERR cannot be read",
            "NAK to ENQUIRY 00085",
            "the drive does not answer its error word: check it is a LUSTBUS drive",
        ),
        (
            DeviceCause::NoSuchParameter {
                parameter: s("20300"),
            },
            "no such parameter, or read-protected in the current operating state",
            "NAK to ENQUIRY 20300",
            "check the drive is the family the schema names and the parameter is readable at this user level",
        ),
        (
            DeviceCause::DatasetStillChecking {
                timeout_ms: 10000,
                sload: -2,
            },
            "the drive was still checking the dataset after 10000 ms",
            "SLOAD = -2",
            "repeat the download or restart the drive (section 11.4)",
        ),
        (
            DeviceCause::DatasetRejected {
                parameter: 100,
                name: s("100-KPSC1"),
                backup: false,
            },
            "dataset rejected",
            "SLOAD = 100",
            "fix the value of 100-KPSC1",
        ),
        (
            DeviceCause::DatasetRejected {
                parameter: 100,
                name: s("100-KPSC1"),
                backup: true,
            },
            "dataset rejected",
            "SLOAD = 100",
            "the drive refuses its own old value of 100-KPSC1; restore it by hand",
        ),
        (
            DeviceCause::NoSuchCode { code: s("0B") },
            "no such code in this controller",
            "STX 0B EOT",
            "check the set's schema matches the drive (family, software version)",
        ),
        (
            DeviceCause::LecomNak {
                status: OperatingStatus(0x0050),
                extended: None,
            },
            "invalid variable",
            "NAK; C0068 = H0050, bits 4..7 = 5",
            "the value is not allowed; choose a value inside the code's range",
        ),
        (
            DeviceCause::LecomNak {
                status: OperatingStatus(0x0060),
                extended: Some(ExtendedError::from_code(0)),
            },
            "no access permission",
            "NAK; C0068 = H0060, bits 4..7 = 6; C1962 = no fault (0)",
            "the code cannot be written now: inhibit the controller (many codes are writable only at standstill), check the user password C0094, or set C0001 to 2 or 3 at the keypad so LECOM may program the drive (§4e)",
        ),
        (
            DeviceCause::LecomNak {
                status: OperatingStatus(0x0000),
                extended: None,
            },
            "refused (NAK) without a recorded communication error",
            "NAK; C0068 = H0000, bits 4..7 = 0",
            "the drive refused without recording a cause; check the value against the code's range and the drive's state",
        ),
        (
            DeviceCause::SdoAbort {
                code: AbortCode(0x0601_0002),
                index: Index(0x4C6D),
                subindex: Subindex(0),
            },
            "Attempt to write a read only object",
            "SDO abort 0x06010002 at index 0x4C6D subindex 0",
            AbortCode(0x0601_0002).hint().unwrap_or("?"),
        ),
        (
            DeviceCause::SdoAbort {
                code: AbortCode(0x1234_5678),
                index: Index(0x5FFE),
                subindex: Subindex(3),
            },
            "unknown abort code",
            "SDO abort 0x12345678 at index 0x5FFE subindex 3",
            "not a DS301 abort code; see the drive's manual",
        ),
    ];
    for (c, cause, raw, remedy) in cases {
        assert_eq!(
            (c.cause().as_str(), c.raw().as_str(), c.remedy().as_str()),
            (cause, raw, remedy),
            "{c:?}"
        );
        let e = EngineError::device(target(), "write 100-KPSC1 (raw 2097)", c);
        assert_eq!(
            e.to_string(),
            format!(
                "sim://demo address 1: write 100-KPSC1 (raw 2097) refused: {cause} ({raw}); {remedy}"
            )
        );
    }
}

#[test]
fn device_causes_and_refusals_round_trip_through_json_with_stable_tags() {
    let c = DeviceCause::Siof {
        register: SiofRegister::Serr,
        bits: Siof(0x80),
        verdict: SiofVerdict::Failed,
    };
    let j = serde_json::to_string(&c).expect("json");
    assert_eq!(
        j,
        r#"{"kind":"siof","register":"serr","bits":128,"verdict":{"kind":"failed"}}"#
    );
    assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
    let c = DeviceCause::LecomNak {
        status: OperatingStatus(0x0050),
        extended: Some(ExtendedError::from_code(0)),
    };
    let j = serde_json::to_string(&c).expect("json");
    assert_eq!(j, r#"{"kind":"lecom_nak","status":80,"extended":0}"#);
    assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
    let c = DeviceCause::LecomNak {
        status: OperatingStatus(0x0010),
        extended: None,
    };
    let j = serde_json::to_string(&c).expect("json");
    assert_eq!(j, r#"{"kind":"lecom_nak","status":16,"extended":null}"#);
    assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
    let r = Refusal::WrongClient {
        schema: s("lenze-tmd"),
        family: s("tmd"),
        protocol: driveset_schema::BusProtocol::CanSdo,
    };
    let j = serde_json::to_string(&r).expect("json");
    assert_eq!(
        j,
        r#"{"kind":"wrong_client","schema":"lenze-tmd","family":"tmd","protocol":"can"}"#
    );
    assert_eq!(serde_json::from_str::<Refusal>(&j).expect("back"), r);
    let bad = j.replace(r#""can""#, r#""modbus""#);
    assert_eq!(
        serde_json::from_str::<Refusal>(&bad)
            .expect_err("unknown protocol")
            .to_string(),
        "unknown bus protocol `modbus`"
    );
    let c = DeviceCause::SdoAbort {
        code: AbortCode(0x0601_0002),
        index: Index(0x4C6D),
        subindex: Subindex(0),
    };
    let j = serde_json::to_string(&c).expect("json");
    assert_eq!(
        j,
        r#"{"kind":"sdo_abort","code":100728834,"index":19565,"subindex":0}"#
    );
    assert_eq!(serde_json::from_str::<DeviceCause>(&j).expect("back"), c);
    let r = Refusal::Plan {
        problems: vec![Problem::AddressChange {
            code: s("82-SADDR"),
            old: s("1"),
            new: s("4"),
        }],
    };
    let j = serde_json::to_string(&r).expect("json");
    assert_eq!(
        j,
        r#"{"kind":"plan","problems":[{"kind":"address_change","code":"82-SADDR","old":"1","new":"4"}]}"#
    );
    assert_eq!(serde_json::from_str::<Refusal>(&j).expect("back"), r);
}

#[test]
fn a_journal_error_names_no_drive_and_the_error_stays_small() {
    let e = EngineError::journal("/tmp/j.journal.json", "cannot write: disk full");
    assert_eq!(e.target, None);
    assert_eq!(
        e.to_string(),
        "journal /tmp/j.journal.json: cannot write: disk full"
    );
    // a target and a box: what `Result<_, EngineError>` carries
    assert!(std::mem::size_of::<EngineError>() <= 48);
    let inner = EngineError::no_answer(target(), "read C0011", 3);
    let rolled = EngineError::rolled_back(target(), "j.json", "C0011 failed", inner);
    assert_eq!(
        std::error::Error::source(&rolled).map(ToString::to_string),
        Some(s(
            "sim://demo address 1: no answer to read C0011 after 3 tries; check wiring, address and baud rate"
        ))
    );
}

#[test]
fn an_address_refusal_is_the_rule_s_and_lustbus_0_is_taken_by_a_client_and_doctor_only() {
    for bus in BusProtocol::ALL {
        for a in 0..=255u8 {
            let rule = bus.check_address(i64::from(a));
            let lustbus_zero = bus == BusProtocol::Lustbus && a == 0;
            for (doing, got) in [
                (AddressUse::Client, AddressRefused::check_client(bus, a)),
                (AddressUse::Scan, AddressRefused::check_scan(bus, a)),
                (AddressUse::Doctor, AddressRefused::check_doctor(bus, a)),
            ] {
                let taken = rule.is_ok() || (lustbus_zero && doing != AddressUse::Scan);
                match got {
                    Ok(()) => assert!(taken, "{bus:?} {a} {doing:?}"),
                    Err(Refusal::Address(r)) => {
                        assert!(!taken, "{bus:?} {a} {doing:?}");
                        assert_eq!((r.doing, Err(r.refusal)), (doing, rule));
                        assert_eq!(r.address(), i64::from(a));
                    }
                    Err(other) => panic!("{other:?}"),
                }
            }
        }
    }
}

#[test]
fn address_refusals_keep_the_json_kinds_journals_hold() {
    let cases = [
        (
            client(BusProtocol::Lecom, 20),
            r#"{"kind":"lecom_address","address":20}"#,
        ),
        (
            client(BusProtocol::CanSdo, 0),
            r#"{"kind":"sdo_node","node":0}"#,
        ),
        (
            client(BusProtocol::Lustbus, 31),
            r#"{"kind":"lustbus_address","address":31}"#,
        ),
        (
            scan(BusProtocol::Lustbus, 0),
            r#"{"kind":"scan_lustbus_address","address":0}"#,
        ),
        (
            scan(BusProtocol::Lecom, 50),
            r#"{"kind":"scan_lecom_address","address":50}"#,
        ),
        (
            scan(BusProtocol::CanSdo, 200),
            r#"{"kind":"scan_can_node","node":200}"#,
        ),
        (
            doctor(BusProtocol::Lustbus, 31),
            r#"{"kind":"doctor_lustbus_address","address":31}"#,
        ),
        (
            doctor(BusProtocol::Lecom, 0),
            r#"{"kind":"doctor_lecom_address","address":0}"#,
        ),
    ];
    for (r, want) in cases {
        let j = serde_json::to_string(&r).expect("json");
        assert_eq!(j, want);
        assert_eq!(serde_json::from_str::<Refusal>(&j).expect("back"), r);
    }
    // an address the rule takes is no refusal
    assert!(serde_json::from_str::<Refusal>(r#"{"kind":"lecom_address","address":5}"#).is_err());
}

#[test]
fn the_clients_refusals_keep_the_json_kinds_journals_hold() {
    let cases: [(Refusal, &str); 3] = [
        (
            LecomRefusal::Group { tens: 12 }.into(),
            r#"{"kind":"lecom_group","tens":12}"#,
        ),
        (
            SdoRefusal::NoIndex {
                code: s("C30000"),
                base: 24575,
            }
            .into(),
            r#"{"kind":"no_sdo_index","code":"C30000","base":24575}"#,
        ),
        (
            SdoRefusal::NotCanFormat {
                code: s("C0011"),
                value: s("x"),
            }
            .into(),
            r#"{"kind":"not_can_format","code":"C0011","value":"x"}"#,
        ),
    ];
    for (r, want) in cases {
        let j = serde_json::to_string(&r).expect("json");
        assert_eq!(j, want);
        assert_eq!(serde_json::from_str::<Refusal>(&j).expect("back"), r);
    }
}

/// A journal's refusal that does not read fails as it always has (the
/// kinds listed in their order), and the forms serde has always taken (a
/// kind by its index, a sequence) read the same refusal.
#[test]
fn a_journal_s_refusal_reads_and_fails_as_it_always_has() {
    use crate::journal::FailureCause;
    let read = |refusal: &str| {
        serde_json::from_str::<FailureCause>(&format!(
            r#"{{"kind":"refused","refusal":{refusal}}}"#
        ))
        .map_err(|e| e.to_string())
    };
    let refused = |refusal: Refusal| Ok(FailureCause::Refused { refusal });
    assert_eq!(
        read(r#"{"kind":"bogus"}"#),
        Err(
            "unknown variant `bogus`, expected one of `plan`, `unknown_code`, `read_only`, \
             `no_dataset_handshake`, `broadcast`, `broadcast_not_staged`, `step_out_of_order`, \
             `guard_command`, `guard_control_word`, `guard_permit`, `lustbus_on_can`, \
             `wrong_client`, `link_misfit`, `lecom_address`, `lecom_group`, \
             `lecom_unaddressable`, `lecom_value`, `encode`, `sdo_node`, `no_sdo_index`, \
             `not_sdo_type`, `not_can_format`, `lustbus_address`, `lustbus_code`, \
             `no_wire_type`, `not_integer`, `does_not_fit`, `not_card_writeable`, \
             `vf1000_no_dataset`, `no_dataset_open`, `stext_mc_only`, `no_sload`, `set_schema`, \
             `codes_not_in_schema`, `diff`, `wrong_type`, `scan_lustbus_address`, \
             `scan_lecom_address`, `scan_can_node`, `no_probe_code`, `doctor_lustbus_address`, \
             `doctor_lecom_address`, `doctor_can_port`, `transfer_rate`, `assign`, \
             `guard_running`, `guard_running_unknown`"
                .to_string()
        )
    );
    assert_eq!(
        read(r#"{"code":"7"}"#),
        Err("missing field `kind`".to_string())
    );
    assert_eq!(
        read(r#"{"kind":true}"#),
        Err("invalid type: boolean `true`, expected variant identifier".to_string())
    );
    assert_eq!(
        read(r#"{"kind":"lecom_group","tens":300}"#),
        Err("invalid value: integer `300`, expected u8".to_string())
    );
    assert_eq!(
        read(r#""x""#),
        Err("invalid type: string \"x\", expected internally tagged enum RefusalForm".to_string())
    );
    assert_eq!(
        read(r#"{"kind":29}"#),
        refused(LustbusRefusal::NoDatasetOpen.into())
    );
    assert_eq!(
        read(r#"{"kind":99}"#),
        Err("invalid value: integer `99`, expected variant index 0 <= i < 47".to_string())
    );
    assert_eq!(
        read(r#"["guard_command", "4-PROG", "1"]"#),
        refused(
            crate::guard::GuardRefusal::Command {
                code: s("4-PROG"),
                value: s("1"),
            }
            .into()
        )
    );
    assert_eq!(
        read(r#"["no_probe_code", "x"]"#),
        refused(ScanRefusal::NoProbeCode { schema: s("x") }.into())
    );
}
