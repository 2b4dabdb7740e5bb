//! The protocol-independent face of a drive: [`DriveClient`]. One
//! implementation per protocol (LUSTBUS for VF1000 and MC6000/7000,
//! LECOM-A/B for Tmd, CAN SDO for ECS) turns reads and writes of schema
//! codes into telegrams, handles the protocol's error indications
//! (docs/architecture.md, "The data path of an upload": the writes) and retries, and exposes what the
//! transaction runner needs for pacing (EEPROM store time). What only some
//! drives have is a capability the client is asked for (`capability.rs`):
//! the MC6000 dataset handshake (SLOAD, [`DatasetDownload`]) and a serial
//! line whose rate can be set ([`SerialLine`]). A client is a [`Drive`]
//! (target, schema, line: link and counters) under a small [`Protocol`]
//! (`drive.rs`); every `Protocol` is a `DriveClient`, implemented once.

use std::fmt;
use std::sync::Arc;
use std::time::Duration;

use driveset_link::{Clock, Instant};
use driveset_schema::{BusProtocol, CodeKey, Family, RawValue, Schema, StoreCommand};

use crate::error::{DeviceCause, EngineError, Refusal};
use crate::guard::Permit;

mod capability;
mod drive;
mod identify;
pub mod lecom;
pub mod lustbus;
mod refusal;
pub mod sdo;
pub mod timing;

pub use capability::{
    DatasetDownload, DatasetOutcome, SerialLine, dataset_or_refuse, set_line_rate,
};
pub use drive::{Drive, DriveLine, Protocol};
pub use lecom::{LecomClient, LecomOptions};
pub use lustbus::{LustbusClient, LustbusOptions};
pub use refusal::{LecomRefusal, SdoRefusal};
pub use sdo::{CanClient, CanOptions};

/// Where a client talks: a port (in the common port syntax) and an address
/// (LUSTBUS 0..30, LECOM 1..99, CAN node id 1..127).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Target {
    /// The port as the user wrote it.
    pub port: String,
    /// Bus address / node id.
    pub address: u8,
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} address {}", self.port, self.address)
    }
}

/// What a drive says it is ([`DriveClient::identify`], or a scan's probe).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Identity {
    /// Who answered: the family (a client knows it from its schema), or
    /// only the bus (a scan's probe).
    pub protocol: IdentProtocol,
    /// Identification codes read and their values (`91-TYPE = 1234`,
    /// `C0200 = 33STMD-M_12000` ...), in the order read.
    pub codes: Vec<IdentCode>,
    /// Software version where the family has one (Tmd C0099).
    pub software: Option<String>,
}

/// Who answered an identification ([`Identity::protocol`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum IdentProtocol {
    /// Not identified (an empty identity).
    #[default]
    Unknown,
    /// A drive of this family.
    Family(Family),
    /// A drive on this bus, family not told apart (a LUSTBUS scan reads
    /// only 91-TYPE).
    Bus(BusProtocol),
}

impl IdentProtocol {
    /// The name journals and reports write: the family's schema protocol
    /// (`lustbus-mc`, `lustbus-vf1000`, `lecom`, `lenze-can-sdo`), the
    /// bus's name (`lustbus`), or `""`.
    pub fn name(self) -> &'static str {
        match self {
            IdentProtocol::Unknown => "",
            IdentProtocol::Family(f) => f.descriptor().schema_protocol,
            IdentProtocol::Bus(b) => b.name(),
        }
    }

    /// The family, where known.
    pub fn family(self) -> Option<Family> {
        match self {
            IdentProtocol::Family(f) => Some(f),
            _ => None,
        }
    }
}

impl fmt::Display for IdentProtocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One identification code read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IdentCode {
    /// The code.
    pub key: CodeKey,
    /// It as the schema spells it (`91-TYPE`, `C0093`).
    pub name: String,
    /// What the drive holds.
    pub value: IdentValue,
}

impl IdentCode {
    /// `key` named `name` holding `value`.
    pub fn new(key: CodeKey, name: impl Into<String>, value: IdentValue) -> Self {
        IdentCode {
            key,
            name: name.into(),
            value,
        }
    }
}

/// An identification value: an integer (LUSTBUS TYPE, CAN codes) or the
/// drive's text (a LECOM VD value in engineering notation, a type string,
/// octets in hex, `NAK` for a probe the drive refused).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum IdentValue {
    /// An integer.
    Int(i64),
    /// Text.
    Text(String),
}

impl IdentValue {
    /// The integer, where it is one (or text that reads as one).
    pub fn as_int(&self) -> Option<i64> {
        match self {
            IdentValue::Int(v) => Some(*v),
            IdentValue::Text(t) => t.trim().parse().ok(),
        }
    }
}

impl fmt::Display for IdentValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            IdentValue::Int(v) => write!(f, "{v}"),
            IdentValue::Text(t) => f.write_str(t),
        }
    }
}

impl Identity {
    /// An identity of `protocol` with nothing read yet.
    pub fn of(protocol: IdentProtocol) -> Self {
        Identity {
            protocol,
            ..Identity::default()
        }
    }

    /// The value of code `number`, where it was read.
    pub fn value_of(&self, number: u32) -> Option<&IdentValue> {
        self.codes
            .iter()
            .find(|c| c.key.number == number && c.key.subcode.is_none())
            .map(|c| &c.value)
    }

    /// The codes and their values as text, in the order read (journals,
    /// line reports).
    pub fn pairs(&self) -> Vec<(String, String)> {
        self.codes
            .iter()
            .map(|c| (c.name.clone(), c.value.to_string()))
            .collect()
    }
}

impl serde::Serialize for Identity {
    /// `{"protocol": "lustbus-mc", "codes": [["91-TYPE", "1234"]], "software": null}`.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut st = s.serialize_struct("Identity", 3)?;
        st.serialize_field("protocol", self.protocol.name())?;
        st.serialize_field("codes", &self.pairs())?;
        st.serialize_field("software", &self.software)?;
        st.end()
    }
}

/// What one client has done so far (for reports and benchmarks).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct ClientStats {
    /// Telegrams (or SDO requests) sent, retries included.
    pub telegrams: u64,
    /// Of those, repetitions after a failure.
    pub retries: u64,
    /// Characters (or frames) sent.
    pub sent: u64,
    /// Characters (or frames) received.
    pub received: u64,
    /// Replies recognised as late (after their answer timeout, or for
    /// another address or code) and dropped ([`timing`]).
    pub late: u64,
    /// 80-SLOAD polls while an MC6000/7000 checked a staged dataset
    /// (LUSTBUS 11.4).
    pub sload_polls: u64,
    /// Restarts of the drive seen (LUSTBUS: a power-on bit in SIOF/SERR
    /// after the session's first read of it, §6, each one
    /// [`crate::error::DeviceFailure::Restarted`] where it was read), also where
    /// the caller recovered from the error; 0 where the protocol shows none.
    /// A switched upload compares it across the switch back
    /// (`crate::transfer`). Not in reports.
    #[serde(skip)]
    pub restarts: u64,
}

/// A drive, reached through one protocol: the face callers use.
///
/// Reads and writes take schema codes and raw values; every method that
/// touches the bus returns an [`EngineError`] naming the target and code.
/// Implementations never write a code the schema does not know. The
/// protocol clients implement the narrower [`Protocol`] over a [`Drive`];
/// this trait is implemented once for every `Protocol` (`drive.rs`), and
/// directly only by tests' fakes.
pub trait DriveClient: Send {
    /// Port and address.
    fn target(&self) -> &Target;

    /// Which bus the client's link reaches, independent of how the port
    /// was spelled ([`driveset_link::bus_id`]: resolved TCP peer, canonical
    /// device path, the simulator's bus id). Journals record it with the
    /// address, so a transaction stays bound to its drive.
    fn bus_id(&self) -> String;

    /// The schema the client converts codes with.
    fn schema(&self) -> &Arc<Schema>;

    /// The link's clock (real or virtual).
    fn clock(&self) -> &dyn Clock;

    /// Read the identification codes ([`Identity`]).
    fn identify(&mut self) -> Result<Identity, EngineError>;

    /// Read one code's raw value.
    fn read(&mut self, key: CodeKey) -> Result<RawValue, EngineError>;

    /// Write one code as an ordinary setting (a set's value, a rollback's
    /// or recover's old value): [`DriveClient::write_named`] with
    /// [`Permit::SETTING`], the write guard's full rules.
    fn write(&mut self, key: CodeKey, raw: &RawValue) -> Result<(), EngineError> {
        self.write_named(key, raw, Permit::SETTING)
    }

    /// Write one code through the write guard ([`crate::guard`]) under
    /// `permit`: [`Permit::SETTING`], or one of the engine's own named
    /// operations (the rate activation 4-PROG = 111, the `--transfer-baud`
    /// rate switch ...), which covers exactly its code and values; only the
    /// engine can name a permit other than `SETTING`. Returns when the
    /// drive has acknowledged it; a write the drive refuses is an
    /// [`DeviceFailure::Refused`](crate::error::DeviceFailure::Refused) with the decoded cause. Waits (on the link's
    /// clock) if the drive cannot take the write yet (MC EEPROM still
    /// storing): correctness never depends on the caller's pacing.
    fn write_named(
        &mut self,
        key: CodeKey,
        raw: &RawValue,
        permit: Permit,
    ) -> Result<(), EngineError>;

    /// The store step of a schema whose drives keep writes only on command
    /// (`[schema.store] keeps = "on-command"`): its store code written with
    /// the one value that stores, under the write guard's store permit,
    /// then, where the schema says what the code reads once stored
    /// (`done`), polled for it ([`poll_store`]). Returns when the drive has
    /// stored (CiA 301 0x1010: the device confirms the SDO download once it
    /// has stored, so the acknowledgement is the completion); a client
    /// whose answers are awaited on its own timeout waits up to
    /// `command.timeout` for this one (`CanClient`
    /// does).
    fn store(&mut self, command: &StoreCommand) -> Result<(), EngineError> {
        let sent = self.clock().now();
        self.write_named(
            CodeKey::new(command.code),
            &RawValue::Int(command.value),
            Permit::STORE,
        )?;
        poll_store(self, command, sent)
    }

    /// The earliest instant a write of `key` will be taken without waiting
    /// (MC6000/7000: the EEPROM is busy width x 3 x 5 ms after an EEPROM
    /// write, LUSTBUS 10.2.2). `None`: now. A runner uses the gap for reads.
    fn ready_for_write(&self, key: CodeKey) -> Option<Instant> {
        let _ = key;
        None
    }

    /// Time one read exchange of `key` takes on the wire (telegrams at 10
    /// bits a character, plus the minimum reaction time), for planning.
    fn read_time(&self, key: CodeKey) -> Duration;

    /// Time one write exchange of `key` takes on the wire, for planning.
    fn write_time(&self, key: CodeKey) -> Duration;

    /// Whether the drive reports a running motor (LUSTBUS control word,
    /// LECOM C0150 / C0068). `None` where the protocol cannot tell.
    fn running(&mut self) -> Result<Option<bool>, EngineError>;

    /// Counters so far.
    fn stats(&self) -> ClientStats;

    /// End the session cleanly (LUSTBUS / LECOM: the trailing EOT).
    fn finish(&mut self) -> Result<(), EngineError>;

    /// The rate the host side of the client's serial line runs at (baud):
    /// [`SerialLine::rate`] where [`DriveClient::line`] has one, asked
    /// without `&mut` (planning, reports). `None`: no line whose rate the
    /// engine controls (CAN; the LECOM client offers none either).
    fn line_rate(&self) -> Option<u32> {
        None
    }

    /// The serial line whose host side rate the engine may set (the
    /// transfer rate, [`crate::transfer`]); `None` without one. Callers that
    /// need it go through [`set_line_rate`], which refuses a client
    /// without one.
    fn line(&mut self) -> Option<&mut dyn SerialLine> {
        None
    }

    /// The dataset download handshake (MC6000/7000 80-SLOAD, LUSTBUS
    /// 11.4), where the drive has one; `None` otherwise (the upload then
    /// plans no staged writes). Callers that need it go through
    /// [`dataset_or_refuse`], which keeps the refusals' words.
    fn dataset(&mut self) -> Option<&mut dyn DatasetDownload> {
        None
    }
}

/// The wait of a store step whose schema gives `done` (`[schema.store]`,
/// docs/file-formats.md): the store code read every `command.poll` until it
/// reads `done`, for at most `command.timeout` from `since` (when the store
/// command was sent). A Lenze device command reports its progress in its own
/// code and 0 ("off / ready") once executed; CiA 301 0x1010 gives no
/// progress (no `done`: nothing is read). `Err` when the time runs out,
/// naming what the code read last.
pub fn poll_store<C: DriveClient + ?Sized>(
    client: &mut C,
    command: &StoreCommand,
    since: Instant,
) -> Result<(), EngineError> {
    let Some(done) = command.done else {
        return Ok(());
    };
    let key = CodeKey::new(command.code);
    let want = RawValue::Int(done);
    loop {
        let got = client.read(key)?;
        if got == want {
            return Ok(());
        }
        let waited = client.clock().now().saturating_duration_since(since);
        if waited >= command.timeout {
            let schema = std::sync::Arc::clone(client.schema());
            let label = schema.code_label(key);
            let text = |v: &RawValue| crate::plan::value_text(&schema, key, v);
            return Err(EngineError::protocol(
                client.target().clone(),
                format!("store ({label} = {})", text(&RawValue::Int(command.value))),
                format!(
                    "{label} still reads {}, not {} (done), {} ms after the store command: the drive did not finish storing within [schema.store] timeout_ms; do not power it off before it has",
                    text(&got),
                    text(&want),
                    command.timeout.as_millis()
                ),
            ));
        }
        let left = command.timeout - waited;
        client.clock().sleep(command.poll.min(left));
    }
}

/// Wait until the drive has saved the last of `keys` it saves in the
/// background (MC6000/7000: an EEPROM value is acknowledged once in RAM and
/// saved to the EEPROM width x 15 ms after, `lustbus-protocol.txt` §3,
/// §10.2.2, §11.2.1; the client knows until when,
/// [`DriveClient::ready_for_write`]): the transaction settles, and the
/// transfer rate's switch back ends, only on what the drive keeps over a
/// power cycle. Nothing to wait for elsewhere (a VF1000 acknowledges once
/// stored, §3).
pub(crate) fn saved(client: &mut dyn DriveClient, keys: impl Iterator<Item = CodeKey>) {
    if let Some(at) = keys.filter_map(|k| client.ready_for_write(k)).max() {
        client.clock().sleep_until(at);
    }
}

// ---------------------------------------------------------------------------
// Helpers the protocol clients share (not part of the contract).
// ---------------------------------------------------------------------------

/// The address a client for `bus` speaks to at `target`: the bus's rule
/// for a client ([`AddressRefused::check_client`](crate::error::AddressRefused::check_client)),
/// then the codec's own address type (`make`; its error is the detail of
/// a [`Refusal::Encode`]). Every refusal is `target`'s.
pub(crate) fn client_address<A>(
    target: &Target,
    bus: BusProtocol,
    make: impl FnOnce(u8) -> Result<A, String>,
) -> Result<A, EngineError> {
    crate::error::AddressRefused::check_client(bus, target.address)
        .and_then(|()| {
            make(target.address).map_err(|detail| Refusal::Encode { what: None, detail })
        })
        .map_err(|refusal| EngineError::refused(target.clone(), refusal))
}

/// The refusal of a client for `protocol` given a schema of a family on
/// another bus.
pub(crate) fn wrong_client(target: Target, schema: &Schema, protocol: BusProtocol) -> EngineError {
    EngineError::refused(
        target,
        Refusal::WrongClient {
            schema: schema.id.clone(),
            family: schema.family.to_string(),
            protocol,
        },
    )
}

/// The schema entry of `key`, or `Refused` (a client never touches a code
/// its schema does not know).
pub(crate) fn schema_code<'s>(
    schema: &'s Schema,
    target: &Target,
    key: CodeKey,
) -> Result<&'s driveset_schema::Code, EngineError> {
    schema.code(key.number).ok_or_else(|| {
        EngineError::refused(
            target.clone(),
            Refusal::UnknownCode {
                schema: schema.id.clone(),
                code: key.canonical(schema.code_style),
            },
        )
    })
}

/// `C0011`, `428-RSIO`, `C0039/1`.
pub(crate) fn code_name(schema: &Schema, key: CodeKey) -> String {
    schema.display_code(key.number, key.subcode)
}

/// A raw value for messages: never a password's.
pub(crate) fn shown_value(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    let secret = schema
        .code(key.number)
        .is_some_and(|c| schema.is_password(c));
    if secret {
        return "(password, not shown)".into();
    }
    match raw {
        RawValue::Int(v) => format!("raw {v}"),
        RawValue::Text(t) => format!("{t:?}"),
        RawValue::Octets(o) => format!("{} octets", o.len()),
    }
}

/// `write 428-RSIO (raw 842666)` / `write 94-PASSWD (password, not shown)`.
pub(crate) fn write_what(schema: &Schema, key: CodeKey, raw: &RawValue) -> String {
    format!(
        "write {} ({})",
        code_name(schema, key),
        shown_value(schema, key, raw)
    )
}

/// Refusal to write a read-only code (nothing is sent).
pub(crate) fn refuse_read_only(
    schema: &Schema,
    target: &Target,
    key: CodeKey,
    code: &driveset_schema::Code,
) -> Result<(), EngineError> {
    if code.access == Some(driveset_schema::schema::Access::Ro) {
        return Err(EngineError::refused(
            target.clone(),
            Refusal::ReadOnly {
                code: code_name(schema, key),
                schema: schema.id.clone(),
            },
        ));
    }
    Ok(())
}

pub(crate) fn device(target: &Target, what: impl Into<String>, cause: DeviceCause) -> EngineError {
    EngineError::device(target.clone(), what, cause)
}

pub(crate) fn link_error(target: &Target, source: driveset_link::LinkError) -> EngineError {
    EngineError::link(target.clone(), source)
}

/// A [`driveset_link::ByteLink`] borrowed for a while (scan, baud
/// detection): lets the protocol clients run on a link they do not own.
#[derive(Debug)]
pub struct BorrowedByteLink<'a>(pub &'a mut dyn driveset_link::ByteLink);

impl driveset_link::ByteLink for BorrowedByteLink<'_> {
    fn port(&self) -> &str {
        self.0.port()
    }
    fn bus_id(&self) -> String {
        self.0.bus_id()
    }
    fn baud(&self) -> u32 {
        self.0.baud()
    }
    fn clock(&self) -> &dyn Clock {
        self.0.clock()
    }
    fn send(&mut self, bytes: &[u8]) -> Result<(), driveset_link::LinkError> {
        self.0.send(bytes)
    }
    fn recv(
        &mut self,
        buf: &mut [u8],
        deadline: Instant,
    ) -> Result<usize, driveset_link::LinkError> {
        self.0.recv(buf, deadline)
    }
    fn discard_input(&mut self) -> Result<(), driveset_link::LinkError> {
        self.0.discard_input()
    }
    fn flush(&mut self) -> Result<(), driveset_link::LinkError> {
        self.0.flush()
    }
    fn set_baud(&mut self, baud: u32) -> Result<(), driveset_link::LinkError> {
        self.0.set_baud(baud)
    }
}

/// A [`driveset_link::FrameLink`] borrowed for a while (scan).
#[derive(Debug)]
pub struct BorrowedFrameLink<'a>(pub &'a mut dyn driveset_link::FrameLink);

impl driveset_link::FrameLink for BorrowedFrameLink<'_> {
    fn port(&self) -> &str {
        self.0.port()
    }
    fn bus_id(&self) -> String {
        self.0.bus_id()
    }
    fn bitrate(&self) -> u32 {
        self.0.bitrate()
    }
    fn clock(&self) -> &dyn Clock {
        self.0.clock()
    }
    fn send(&mut self, frame: &driveset_link::CanFrame) -> Result<(), driveset_link::LinkError> {
        self.0.send(frame)
    }
    fn recv(
        &mut self,
        deadline: Instant,
    ) -> Result<Option<driveset_link::CanFrame>, driveset_link::LinkError> {
        self.0.recv(deadline)
    }
    fn discard_input(&mut self) -> Result<(), driveset_link::LinkError> {
        self.0.discard_input()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_identity_names_its_protocol_and_keeps_typed_values() {
        let mut id = Identity::of(IdentProtocol::Family(Family::Mc6000));
        id.codes.push(IdentCode::new(
            CodeKey::new(91),
            "91-TYPE",
            IdentValue::Int(1234),
        ));
        id.codes.push(IdentCode::new(
            CodeKey::new(200),
            "C0200",
            IdentValue::Text("33STMD-M_12000".into()),
        ));
        assert_eq!(id.protocol.name(), "lustbus-mc");
        assert_eq!(id.protocol.family(), Some(Family::Mc6000));
        assert_eq!(id.value_of(91).and_then(IdentValue::as_int), Some(1234));
        assert_eq!(id.value_of(200).and_then(IdentValue::as_int), None);
        assert_eq!(id.value_of(92), None);
        assert_eq!(
            serde_json::to_string(&id).expect("json"),
            r#"{"protocol":"lustbus-mc","codes":[["91-TYPE","1234"],["C0200","33STMD-M_12000"]],"software":null}"#
        );
        for (p, name) in [
            (IdentProtocol::Family(Family::Vf1000), "lustbus-vf1000"),
            (IdentProtocol::Family(Family::Tmd), "lecom"),
            (IdentProtocol::Family(Family::Ecs), "lenze-can-sdo"),
            (IdentProtocol::Bus(BusProtocol::Lustbus), "lustbus"),
            (IdentProtocol::Unknown, ""),
        ] {
            assert_eq!(p.name(), name);
        }
    }

    #[test]
    fn a_client_address_passes_the_bus_rule_then_the_codec_for_its_target() {
        let at = |address| Target {
            port: "sim://line".into(),
            address,
        };
        // LUSTBUS 0 is a client's (the single drive on the line)
        let ok = client_address(&at(0), BusProtocol::Lustbus, Ok::<u8, String>);
        assert_eq!(ok.ok(), Some(0));
        // the bus's rule first: LECOM 10 is a group address, the codec
        // is not asked
        let e = client_address(&at(10), BusProtocol::Lecom, |_| -> Result<u8, String> {
            panic!("the codec is asked only after the rule")
        })
        .expect_err("refused");
        assert_eq!(e.target, Some(at(10)));
        assert!(matches!(e.refusal(), Some(Refusal::Address(_))), "{e}");
        // then the codec's own type, its error the detail
        let e = client_address(&at(5), BusProtocol::CanSdo, |a| {
            Err::<u8, String>(format!("node {a}"))
        })
        .expect_err("refused");
        assert_eq!(e.target, Some(at(5)));
        assert!(
            matches!(
                e.refusal(),
                Some(Refusal::Encode { what: None, detail }) if detail == "node 5"
            ),
            "{e}"
        );
    }
}
