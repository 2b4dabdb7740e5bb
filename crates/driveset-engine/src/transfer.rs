//! The transfer rate (`--transfer-baud RATE`): owns switching an
//! MC6000/7000 and the host's port to a faster line rate for one
//! transaction and back (`lustbus-protocol.txt` §11.5), the search for a
//! drive left at another rate (§5.1), the estimate of whether a switch
//! pays, and the switch's record in the journal
//! ([`crate::journal::TransferRecord`]).
//!
//! **The switch** (§11.5: "first set the new Baudrate. Then use the value
//! 111 in the 4-PROG parameter to order the servocontroller to activate
//! the Baudrate"; §4: servocontrollers run at 2400..57600 Bd, inverters at
//! most 9600):
//!
//! 1. at the old rate: read 81-SBAUD (what its EEPROM holds, `before`);
//!    journal the record (`switching`); write SBAUD = RATE; write PROG =
//!    111 (the ACK still comes at the old rate);
//! 2. the host's port to RATE ([`DriveClient::set_line_rate`]); confirm
//!    contact by reading SBAUD (= RATE); write SBAUD = `before` again
//!    **without** activating it, so that the EEPROM never keeps the
//!    transfer rate: a drive restarted in the middle comes back at its own
//!    rate; journal `at-transfer-rate`;
//! 3. the transaction (its read-back sees the drive's own SBAUD; a set
//!    that holds SBAUD writes it as any other code, not activated);
//! 4. back: read SBAUD (`keep`: what the transaction left in EEPROM);
//!    write SBAUD = old rate, PROG = 111 (ACK at RATE), port to the old
//!    rate, confirm (SBAUD = old rate); write SBAUD = `keep` without
//!    activating it and read it back; journal `back`.
//!
//! What stays in EEPROM is therefore the set's SBAUD when the transaction
//! wrote one, else the drive's own. Only the MC6000/7000 family descriptor
//! names an online activation ([`driveset_schema::family::OnlineBaud`]);
//! VF1000, Tmd and ECS are refused. A running drive is refused (the switch
//! needs standstill: the running check of the upload, without override). A
//! bus shared with drives that cannot follow (VF1000: 9600 Bd at most) is
//! refused unless [`Override::AllowSharedTransferBaud`]: while the MC talks
//! at RATE they see garbage, and their watchdog (84-SIOT) may fire.
//!
//! **When it pays.** [`decide`] estimates the exchanges the command cannot
//! avoid (the read-back of every code of the set, every code pulled) at the
//! current rate and at RATE, plus the switch-over exchanges above (with the
//! EEPROM store time of the SBAUD writes, §10.2.2). Wire time scales with
//! the rate, the §10 minimum reaction does not. It switches only when the
//! sum at RATE is smaller; the report says which and why.
//!
//! **Failure.** A link failure after the switch searches for the drive
//! (§5.1: the current rate, the transfer rate, the old rate, then every
//! rate of the family) and switches it back; the upload's backup is never
//! touched. When the drive cannot be found the error says at which rate it
//! may run, and the journal keeps the record open, so `driveset recover`
//! ([`recover_rate`]) searches again before it completes or rolls back.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

use driveset_schema::family::{Family, OnlineBaud};
use driveset_schema::value::Repr;
use driveset_schema::{CodeKey, RawValue, ResolvedSet, Schema};

use crate::client::{DriveClient, Target};
use crate::error::{EngineError, ErrorKind, Refusal};
use crate::guard::Permit;
use crate::journal::{
    JOURNAL_VERSION, Journal, JournalFile, JournalTarget, JournalValue, TransferRecord,
    TransferState, TxnState,
};
use crate::overrides::Override;
use crate::plan::code_label;
use crate::pull::{PullOptions, Pulled};
use crate::upload::{UploadFailure, UploadOptions, UploadReport};

/// What the command asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TransferRequest {
    /// The transfer rate (baud).
    pub rate: u32,
    /// The families of the other drives on the same bus, where known (a
    /// line manifest's bus); empty for a single-drive command.
    pub others: Vec<Family>,
    /// [`Override::AllowSharedTransferBaud`] given.
    pub allow_shared: bool,
}

impl TransferRequest {
    /// A request for `rate` on a bus of one drive.
    pub fn new(rate: u32) -> Self {
        TransferRequest {
            rate,
            others: Vec::new(),
            allow_shared: false,
        }
    }
}

/// Whether a switch pays ([`decide`]).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct Decision {
    /// The rate the line runs at.
    pub old_rate: u32,
    /// The transfer rate asked for.
    pub rate: u32,
    /// Exchanges counted.
    pub exchanges: usize,
    /// Their time at the old rate.
    #[serde(serialize_with = "ser_ms")]
    pub at_old: Duration,
    /// Their time at the transfer rate.
    #[serde(serialize_with = "ser_ms")]
    pub at_rate: Duration,
    /// Switching over and back (exchanges and EEPROM waits).
    #[serde(serialize_with = "ser_ms")]
    pub switch_over: Duration,
    /// Switch (it saves time).
    pub switch: bool,
}

fn ser_ms<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64() * 1000.0)
}

fn exchanges(n: usize) -> String {
    if n == 1 {
        "1 exchange".into()
    } else {
        format!("{n} exchanges")
    }
}

fn secs(d: Duration) -> String {
    if d >= Duration::from_secs(1) {
        format!("{:.1} s", d.as_secs_f64())
    } else {
        format!("{} ms", d.as_millis())
    }
}

impl Decision {
    /// `transfer rate 57600: saves 4.1 s of 6.0 s` or `transfer rate
    /// 57600: not switched: ...`.
    pub fn summary(&self) -> String {
        let with = self.at_rate + self.switch_over;
        if self.old_rate == self.rate {
            return format!(
                "transfer rate {}: not switched: the line already runs at {} baud",
                self.rate, self.old_rate
            );
        }
        if self.switch {
            format!(
                "transfer rate {}: saves {} of {} ({}: {} at {} baud, {} at {} baud plus {} to switch over and back)",
                self.rate,
                secs(self.at_old.saturating_sub(with)),
                secs(self.at_old),
                exchanges(self.exchanges),
                secs(self.at_old),
                self.old_rate,
                secs(self.at_rate),
                self.rate,
                secs(self.switch_over)
            )
        } else {
            format!(
                "transfer rate {}: not switched: it does not pay ({}: {} at {} baud against {} at {} baud plus {} to switch over and back)",
                self.rate,
                exchanges(self.exchanges),
                secs(self.at_old),
                self.old_rate,
                secs(self.at_rate),
                self.rate,
                secs(self.switch_over)
            )
        }
    }
}

/// What a transaction with a transfer rate did about the rate.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct TransferReport {
    /// The estimate.
    pub decision: Decision,
    /// Whether the drive was switched.
    pub switched: bool,
    /// Where the drive's rate stands at the end, for humans (`the drive
    /// runs at 9600 baud again; 81-SBAUD holds 9600 (not active)`).
    pub state: String,
}

impl TransferReport {
    /// Two lines for the report.
    pub fn render(&self) -> String {
        let mut out = String::new();
        let _ = writeln!(out, "{}", self.decision.summary());
        if self.switched {
            let _ = writeln!(out, "line rate: {}", self.state);
        }
        out
    }
}

/// The codes and values of a family's online rate change.
#[derive(Debug, Clone, Copy)]
struct Codes {
    rate: CodeKey,
    online: OnlineBaud,
}

fn refuse(target: &Target, reason: String) -> EngineError {
    EngineError::refused(target.clone(), Refusal::TransferRate { detail: reason })
}

/// Check everything that needs no telegram: the family can switch online,
/// the schema knows how 81-SBAUD codes a rate, RATE is one of the family's
/// rates, the bus is not shared with drives that cannot follow (unless
/// overridden), and the port can change its rate.
pub fn check(client: &mut dyn DriveClient, req: &TransferRequest) -> Result<(), EngineError> {
    let schema = client.schema().clone();
    let target = client.target().clone();
    let family = schema.family;
    let d = family.descriptor();
    let Some(online) = d.line_rates.online else {
        let why = match family {
            Family::Vf1000 => format!(
                "a {} runs at 9600 baud at most (lustbus-protocol.txt §4) and activates a new rate only at a restart (§11.5)",
                d.title
            ),
            _ => format!(
                "a {} cannot activate a new line rate online (only MC6000/7000 servocontrollers can, lustbus-protocol.txt §11.5)",
                d.title
            ),
        };
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: {why}; leave out --transfer-baud",
                req.rate
            ),
        ));
    };
    let Some(rate_number) = d.line_rates.code else {
        return Err(refuse(
            &target,
            format!("--transfer-baud: the {} has no rate code", d.title),
        ));
    };
    let rate_key = CodeKey::new(rate_number);
    let label = code_label(&schema, rate_key);
    if !d.line_rates.rates.contains(&req.rate) {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: a {} runs at {} baud (lustbus-protocol.txt §4); pick one of these",
                req.rate,
                d.title,
                list(d.line_rates.rates)
            ),
        ));
    }
    let Some(code) = schema.code(rate_number) else {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud: schema `{}` has no code {rate_number}; use the drive family's schema",
                schema.id
            ),
        ));
    };
    let figure = schema
        .type_of(code)
        .is_some_and(|t| t.repr() == Repr::Scaled(1))
        && code
            .unit
            .as_deref()
            .is_some_and(|u| u.eq_ignore_ascii_case("baud"))
        && code.values.is_none();
    if !figure {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud: schema `{}` does not say how {label} codes a rate (it needs an integer type with unit Baud: the value is the baud figure); use the schema learned from the drive (the default unless --no-learn) or leave out --transfer-baud",
                schema.id
            ),
        ));
    }
    if schema.code(online.command).is_none() {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud: schema `{}` has no code {} (the command that activates a rate, §11.5)",
                schema.id, online.command
            ),
        ));
    }
    let old = client.line_rate().unwrap_or(0);
    for r in [req.rate, old] {
        if !within(&schema, code, r) {
            return Err(refuse(
                &target,
                format!(
                    "--transfer-baud {}: {r} baud is outside the range of {label} in schema `{}`",
                    req.rate, schema.id
                ),
            ));
        }
    }
    let cannot: Vec<&str> = req
        .others
        .iter()
        .filter(|f| {
            let r = f.descriptor().line_rates;
            r.online.is_none() || !r.rates.contains(&req.rate)
        })
        .map(|f| f.descriptor().title)
        .collect();
    if !cannot.is_empty() && !req.allow_shared {
        let mut names = cannot.clone();
        names.dedup();
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: the bus is shared with {} drive(s) ({}) that cannot follow: while this drive talks at {} baud they hear garbage, and their watchdog (84-SIOT / SWDGT, lustbus-protocol.txt §5.2) may fire; give {} to switch anyway, or leave out --transfer-baud",
                req.rate,
                cannot.len(),
                names.join(", "),
                req.rate,
                Override::AllowSharedTransferBaud.flag()
            ),
        ));
    }
    // The port must be able to follow (raw tcp:// cannot): ask it for
    // the rate it runs at, which changes nothing.
    if old != 0
        && let Err(e) = client.set_line_rate(old)
    {
        let why = match e.kind() {
            ErrorKind::Link(source) => source.to_string(),
            _ => e.to_string(),
        };
        return Err(refuse(
            &target,
            format!("--transfer-baud {}: {why}", req.rate),
        ));
    }
    let _ = (rate_key, online);
    Ok(())
}

fn list(rates: &[u32]) -> String {
    let mut r = rates.to_vec();
    r.sort_unstable();
    r.iter().map(u32::to_string).collect::<Vec<_>>().join(", ")
}

/// Whether `baud` is within the schema's min/max of the rate code.
fn within(schema: &Schema, code: &driveset_schema::Code, baud: u32) -> bool {
    let v = i64::from(baud);
    let lo = code.min.as_ref().map(|f| schema.fact_raw(code, f));
    let hi = code.max.as_ref().map(|f| schema.fact_raw(code, f));
    let ok_lo = !matches!(lo, Some(Ok(RawValue::Int(m))) if v < m);
    let ok_hi = !matches!(hi, Some(Ok(RawValue::Int(m))) if v > m);
    ok_lo && ok_hi
}

fn codes_of(schema: &Schema) -> Option<Codes> {
    let r = schema.family.descriptor().line_rates;
    Some(Codes {
        rate: CodeKey::new(r.code?),
        online: r.online?,
    })
}

/// One exchange's time at `to` baud, given its time at `from` baud: the
/// wire part scales with the rate, the minimum reaction `min` does not.
pub fn at_rate(t: Duration, min: Duration, from: u32, to: u32) -> Duration {
    let wire = t.saturating_sub(min).as_nanos();
    let scaled = wire * u128::from(from) / u128::from(to.max(1));
    min + Duration::from_nanos(u64::try_from(scaled).unwrap_or(u64::MAX))
}

/// Whether switching to `req.rate` pays for `reads` (codes the command
/// reads once each) and `writes` (codes it writes), see the module docs.
pub fn decide(
    client: &dyn DriveClient,
    req: &TransferRequest,
    reads: &[CodeKey],
    writes: &[CodeKey],
) -> Decision {
    let schema = client.schema();
    let old = client.line_rate().unwrap_or(req.rate);
    let min = schema.family.descriptor().reaction.min;
    let scale = |t: Duration| at_rate(t, min, old, req.rate);
    let mut at_old = Duration::ZERO;
    let mut at_new = Duration::ZERO;
    for k in reads {
        let t = client.read_time(*k);
        at_old += t;
        at_new += scale(t);
    }
    for k in writes {
        let t = client.write_time(*k);
        at_old += t;
        at_new += scale(t);
    }
    let switch_over = match codes_of(schema) {
        Some(c) => switch_over_time(client, c, old, req.rate),
        None => Duration::ZERO,
    };
    Decision {
        old_rate: old,
        rate: req.rate,
        exchanges: reads.len() + writes.len(),
        at_old,
        at_rate: at_new,
        switch_over,
        switch: old != req.rate && at_new + switch_over < at_old,
    }
}

/// The switch-over and back of the module docs, on a timeline with the
/// EEPROM store time of the SBAUD writes (§10.2.2: width x 3 x 5 ms).
fn switch_over_time(client: &dyn DriveClient, c: Codes, old: u32, rate: u32) -> Duration {
    let min = client.schema().family.descriptor().reaction.min;
    let store = client
        .schema()
        .code(c.rate.number)
        .and_then(|code| code.width)
        .map_or(Duration::from_millis(60), |w| {
            Duration::from_millis(15 * u64::from(w))
        });
    let r = client.read_time(c.rate);
    let w = client.write_time(c.rate);
    let p = client.write_time(CodeKey::new(c.online.command));
    let new = |t: Duration| at_rate(t, min, old, rate);
    // over: R W(SBAUD) W(PROG) | R, wait store, W(SBAUD before)
    let mut t = r + w;
    let stored = t + store;
    t += p + new(r);
    t = t.max(stored) + new(w);
    // back: R W(SBAUD old) W(PROG) | R (+ W(keep) R when the set changes it)
    t += new(r) + new(w) + new(p) + r;
    t
}

/// The rate code's value as a rate.
fn as_rate(v: &RawValue) -> Option<u32> {
    match v {
        RawValue::Int(i) => u32::try_from(*i).ok(),
        _ => None,
    }
}

fn value_text(v: &JournalValue) -> String {
    match v {
        JournalValue::Int(i) => i.to_string(),
        JournalValue::Text(t) => t.clone(),
        JournalValue::Octets(o) => o.clone(),
    }
}

/// A placeholder journal of the transaction, before anything is sent:
/// the rate switch is recorded in it; an upload that plans writes replaces
/// it, keeping the record.
fn placeholder(
    client: &dyn DriveClient,
    identity: &crate::client::Identity,
    set_fingerprint: String,
    record: TransferRecord,
) -> Journal {
    let schema = client.schema();
    Journal {
        journal_version: JOURNAL_VERSION,
        state: TxnState::Planned,
        target: JournalTarget::of(client),
        identity: identity.into(),
        schema: schema.id.clone(),
        schema_source: crate::journal::SchemaSource::of(schema),
        set_fingerprint,
        fingerprint_before: String::new(),
        dataset: false,
        attempt: 0,
        backup: Vec::new(),
        plan: Vec::new(),
        unchanged: Vec::new(),
        written: Vec::new(),
        transitions: Vec::new(),
        failure: None,
        failure_cause: None,
        holding: Vec::new(),
        broadcast: Vec::new(),
        transfer: Some(record),
        assign: None,
    }
}

/// Update the record in the journal file (whoever wrote it last).
fn persist_record(path: &Path, record: &TransferRecord) -> Result<(), EngineError> {
    let mut jf = JournalFile::open(path)?;
    jf.journal.transfer = Some(record.clone());
    jf.persist()
}

/// Write `raw` to the rate code.
fn write_rate(client: &mut dyn DriveClient, c: Codes, baud: u32) -> Result<(), EngineError> {
    client.write_named(c.rate, &RawValue::Int(i64::from(baud)), Permit::RATE_SWITCH)
}

/// Tell the drive to activate the rate its rate code holds (§11.5).
fn activate(client: &mut dyn DriveClient, c: Codes) -> Result<(), EngineError> {
    client.write_named(
        CodeKey::new(c.online.command),
        &RawValue::Int(c.online.activate),
        Permit::ACTIVATE_RATE,
    )
}

/// Read the rate code at the host's current rate, expecting `want`.
fn confirm(client: &mut dyn DriveClient, c: Codes, want: u32) -> Result<(), EngineError> {
    let got = client.read(c.rate)?;
    if as_rate(&got) == Some(want) {
        Ok(())
    } else {
        Err(EngineError::protocol(
            client.target().clone(),
            format!("confirm the line rate {want}"),
            format!(
                "{} reads {got:?} at {want} baud instead of {want}",
                code_label(client.schema(), c.rate)
            ),
        ))
    }
}

/// §5.1: "the connection will be attempted using all possible transfer
/// rates": probe the drive (a read of the rate code) at `first` rates in
/// order, then at every rate of the family, highest first. The host is
/// left at the rate that answered. `Ok(None)`: no rate answers.
pub fn search(client: &mut dyn DriveClient, first: &[u32]) -> Result<Option<u32>, EngineError> {
    let schema = client.schema().clone();
    let Some(c) = codes_of(&schema) else {
        return Ok(None);
    };
    let mut order: Vec<u32> = first.to_vec();
    for r in schema.family.descriptor().line_rates.rates {
        if !order.contains(r) {
            order.push(*r);
        }
    }
    for r in order {
        if client.line_rate() != Some(r)
            && let Err(e) = client.set_line_rate(r)
        {
            if matches!(
                e.kind(),
                ErrorKind::Link(driveset_link::LinkError::UnsupportedBaud { .. })
            ) {
                continue;
            }
            return Err(e);
        }
        match client.read(c.rate) {
            Ok(_) => return Ok(Some(r)),
            Err(e) => match e.kind() {
                ErrorKind::NoAnswer { .. } | ErrorKind::Protocol { .. } => continue,
                ErrorKind::Device { .. } => return Ok(Some(r)),
                _ => return Err(e),
            },
        }
    }
    Ok(None)
}

/// Where the switch stands after a failure, for messages; `state`: where
/// the record stood when the failing step began.
fn whereabouts(rec: &TransferRecord, state: TransferState, found: Option<u32>) -> String {
    let keep = value_text(rec.keep.as_ref().unwrap_or(&rec.before));
    match found {
        Some(r) if r == rec.old_rate => format!("the drive runs at {r} baud again"),
        Some(r) => format!(
            "the drive answers at {r} baud, not at the port's {} baud",
            rec.old_rate
        ),
        None if state == TransferState::AtTransferRate => format!(
            "the drive answers at no rate (it may still run at the transfer rate {} baud; its {} holds {} in EEPROM, so a restart brings it to that rate)",
            rec.transfer_rate,
            rec.code,
            value_text(&rec.before)
        ),
        None => format!(
            "the drive answers at no rate (it may run at the transfer rate {} baud or at {} baud, and its {} may hold {} in EEPROM until the switch back is finished: run `driveset recover` as soon as the drive is reachable again; it searches every rate and leaves {} holding {keep})",
            rec.transfer_rate, rec.old_rate, rec.code, rec.transfer_rate, rec.code
        ),
    }
}

/// Switch the drive and the port to `rec.transfer_rate` (module docs, steps
/// 1-2), recording every step in the journal at `journal`. On failure the
/// drive is searched for and switched back; the error says where it is.
fn switch_over(
    client: &mut dyn DriveClient,
    c: Codes,
    rec: &mut TransferRecord,
    journal: &Path,
) -> Result<(), EngineError> {
    let rate = rec.transfer_rate;
    let step =
        |client: &mut dyn DriveClient, rec: &mut TransferRecord| -> Result<(), EngineError> {
            write_rate(client, c, rate)?;
            rec.switched_at_ns = Some(client.clock().now().as_nanos());
            activate(client, c)?;
            client.set_line_rate(rate)?;
            confirm(client, c, rate)?;
            if as_rate_j(&rec.before) != Some(rate) {
                let before = rec.before.to_raw().unwrap_or(RawValue::Int(0));
                client.write(c.rate, &before)?;
            }
            Ok(())
        };
    match step(client, rec) {
        Ok(()) => {
            rec.state = TransferState::AtTransferRate;
            persist_record(journal, rec)
        }
        Err(e) => {
            // Back to the old rate, whatever happened.
            let back = switch_back(client, c, rec, journal);
            Err(with_rate_note(e, &back))
        }
    }
}

fn as_rate_j(v: &JournalValue) -> Option<u32> {
    v.to_raw().as_ref().and_then(as_rate)
}

/// The outcome of [`switch_back`], for messages: `Ok(state text)`.
type Back = Result<String, String>;

/// What the rate code is to hold once the drive runs at the old rate again
/// ([`TransferRecord::keep`]), given what it holds `now` and the value the
/// transaction plans for it (`planned`): the recorded decision when there
/// is one; `before` while the switch-over was under way (the transfer rate
/// or `before` is in EEPROM, nothing of the set); else what the
/// transaction left there (its old or its new value), but never the
/// transfer rate unless that is the set's own value.
fn keep_value(rec: &TransferRecord, planned: Option<&RawValue>, now: &RawValue) -> RawValue {
    if let Some(k) = rec.keep.as_ref().and_then(JournalValue::to_raw) {
        return k;
    }
    let before = rec.before.to_raw().unwrap_or_else(|| now.clone());
    if rec.state == TransferState::Switching
        || (as_rate(now) == Some(rec.transfer_rate) && planned != Some(now))
    {
        return before;
    }
    now.clone()
}

/// The value the journal at `path` plans for the rate code, if any.
fn planned_rate(journal: &crate::journal::Journal, c: Codes) -> Option<RawValue> {
    journal
        .plan
        .iter()
        .find(|p| p.number == c.rate.number && p.subcode == c.rate.subcode)
        .and_then(|p| p.new.to_raw())
}

/// What the rate code keeps once recover settled the transaction with
/// `action`: the planned new value (completed) or the backup (rolled back)
/// when the transaction has the code, else the drive's own `before`.
fn settled_keep(
    journal: &crate::journal::Journal,
    c: Codes,
    rec: &TransferRecord,
    action: crate::recover::RecoverAction,
) -> JournalValue {
    use crate::recover::RecoverAction;
    let backup = journal
        .backup
        .iter()
        .find(|b| b.number == c.rate.number && b.subcode == c.rate.subcode)
        .map(|b| b.old.clone());
    let planned = journal
        .plan
        .iter()
        .find(|p| p.number == c.rate.number && p.subcode == c.rate.subcode)
        .map(|p| p.new.clone());
    let unchanged = journal
        .unchanged
        .iter()
        .find(|b| b.number == c.rate.number && b.subcode == c.rate.subcode)
        .map(|b| b.old.clone());
    let chosen = match action {
        RecoverAction::Completed => planned.or(unchanged),
        RecoverAction::RolledBack | RecoverAction::Nothing => backup.or(unchanged),
    };
    chosen.unwrap_or_else(|| rec.before.clone())
}

/// While a switch back is open, the rate code may hold the old rate (the
/// switch back writes it on the way) or the transfer rate (the
/// switch-over): recover judges the code by the value the upload decided
/// it keeps ([`TransferRecord::keep`]) instead, so that a cut in the switch
/// back does not make a landed transaction look rolled back. `None`: judge
/// what the drive holds.
pub(crate) fn judged_rate(
    journal: &crate::journal::Journal,
    schema: &Schema,
    key: CodeKey,
    holds: &RawValue,
) -> Option<RawValue> {
    let rec = journal.transfer.as_ref().filter(|t| !t.is_back())?;
    let c = codes_of(schema)?;
    let keep = rec.keep.as_ref()?.to_raw()?;
    let switch_wrote = as_rate(holds).is_some_and(|r| r == rec.old_rate || r == rec.transfer_rate);
    (key == c.rate && switch_wrote).then_some(keep)
}

/// Mark the record `switching-back`, deciding [`TransferRecord::keep`]
/// right away when the switch-over itself was cut (then it is `before`).
fn start_back(rec: &mut TransferRecord) {
    if rec.state == TransferState::Switching && rec.keep.is_none() {
        rec.keep = Some(rec.before.clone());
    }
    rec.state = TransferState::SwitchingBack;
}

/// Switch the drive back to `rec.old_rate` (module docs, step 4), searching
/// for it first if it does not answer at the host's rate. The rate code
/// gets [`TransferRecord::keep`] ([`keep_value`]), journalled before the
/// first write of the switch back.
fn switch_back(
    client: &mut dyn DriveClient,
    c: Codes,
    rec: &mut TransferRecord,
    journal: &Path,
) -> Back {
    let planned = JournalFile::open(journal)
        .ok()
        .and_then(|jf| planned_rate(&jf.journal, c));
    let state0 = rec.state;
    start_back(rec);
    persist_record(journal, rec).map_err(|e| e.to_string())?;
    let old = rec.old_rate;
    let mut tried_search = false;
    let mut persist = |r: &TransferRecord| persist_record(journal, r);
    loop {
        match switch_back_once(client, c, rec, planned.as_ref(), &mut persist) {
            Ok(state) => {
                rec.state = TransferState::Back;
                rec.back_at_ns = Some(client.clock().now().as_nanos());
                persist_record(journal, rec).map_err(|e| e.to_string())?;
                return Ok(state);
            }
            Err(e) if !tried_search => {
                tried_search = true;
                let first = [client.line_rate().unwrap_or(old), rec.transfer_rate, old];
                match search(client, &first) {
                    Ok(Some(_)) => continue,
                    Ok(None) => return Err(format!("{e}; {}", whereabouts(rec, state0, None))),
                    Err(e2) => return Err(format!("{e}; searching the drive: {e2}")),
                }
            }
            Err(e) => {
                return Err(format!(
                    "{e}; the drive answered at {} baud before this failure and may run at {} or {} baud now",
                    client.line_rate().unwrap_or(old),
                    rec.transfer_rate,
                    old
                ));
            }
        }
    }
}

/// One attempt at the switch back from wherever the host reaches the
/// drive: decide and journal the value to keep (through `persist`) before
/// the first write, activate the old rate if the drive is not at it, write
/// the value to keep without activating it and read it back.
fn switch_back_once(
    client: &mut dyn DriveClient,
    c: Codes,
    rec: &mut TransferRecord,
    planned: Option<&RawValue>,
    persist: &mut dyn FnMut(&TransferRecord) -> Result<(), EngineError>,
) -> Result<String, EngineError> {
    let old = rec.old_rate;
    let label = rec.code.clone();
    let now = client.read(c.rate)?;
    let keep = keep_value(rec, planned, &now);
    if rec.keep.is_none() {
        rec.keep = Some(JournalValue::from(&keep));
        persist(rec)?;
    }
    // What the rate code holds, read at the old rate: the confirm's read
    // after a switch, else the read above (the drive answered at the old
    // rate already).
    let holds = if client.line_rate() != Some(old) {
        write_rate(client, c, old)?;
        activate(client, c)?;
        client.set_line_rate(old)?;
        confirm(client, c, old)?;
        RawValue::Int(i64::from(old))
    } else {
        now
    };
    if holds != keep {
        client.write(c.rate, &keep)?;
        let got = client.read(c.rate)?;
        if got != keep {
            return Err(EngineError::protocol(
                client.target().clone(),
                format!("verify {label}"),
                format!("reads back {got:?} instead of {keep:?}"),
            ));
        }
    }
    let stored = JournalValue::from(&keep);
    let text = value_text(&stored);
    rec.stored = Some(stored);
    Ok(if as_rate(&keep) == Some(old) {
        format!("the drive runs at {old} baud again; {label} = {text}")
    } else {
        format!(
            "the drive runs at {old} baud again; {label} holds {text} (not active: in effect after the drive's next restart)"
        )
    })
}

/// Add where the drive's rate stands to an error's text.
fn with_rate_note(mut e: EngineError, back: &Back) -> EngineError {
    let note = match back {
        Ok(s) => s.clone(),
        Err(s) => format!("switching back from the transfer rate failed: {s}"),
    };
    match &mut *e.kind {
        ErrorKind::RolledBack { detail, .. }
        | ErrorKind::Inconsistent { detail, .. }
        | ErrorKind::Protocol { detail, .. } => {
            let _ = write!(detail, "; {note}");
        }
        ErrorKind::NoAnswer { what, .. } | ErrorKind::Device { what, .. } => {
            let _ = write!(what, " ({note})");
        }
        ErrorKind::Refused(Refusal::TransferRate { detail }) => {
            let _ = write!(detail, "; {note}");
        }
        _ => {
            return EngineError::protocol(
                target_of(&e),
                "the transaction at the transfer rate",
                format!("{e}; {note}"),
            );
        }
    }
    e
}

fn target_of(e: &EngineError) -> Target {
    e.target.clone().unwrap_or_else(|| Target {
        port: String::new(),
        address: 0,
    })
}

/// A switched session: what [`begin`] did, for [`end`].
#[derive(Debug)]
pub struct Session {
    codes: Option<Codes>,
    record: Option<TransferRecord>,
    decision: Decision,
}

impl Session {
    /// The record to give the upload ([`UploadOptions::transfer`]).
    pub fn record(&self) -> Option<&TransferRecord> {
        self.record.as_ref()
    }

    /// The estimate.
    pub fn decision(&self) -> &Decision {
        &self.decision
    }
}

/// Check, decide, and when it pays switch (module docs, steps 1-2): the
/// journal at `journal` is created (placeholder, `set_fingerprint`) before
/// the first telegram of the switch. `reads` / `writes`: the exchanges
/// the command cannot avoid, for [`decide`].
pub fn begin(
    client: &mut dyn DriveClient,
    req: &TransferRequest,
    journal: &Path,
    set_fingerprint: String,
    reads: &[CodeKey],
    writes: &[CodeKey],
) -> Result<Session, EngineError> {
    check(client, req)?;
    crate::upload::check_unfinished(&*client, journal)?;
    let decision = decide(&*client, req, reads, writes);
    let Some(c) = codes_of(client.schema()).filter(|_| decision.switch) else {
        return Ok(Session {
            codes: None,
            record: None,
            decision,
        });
    };
    let target = client.target().clone();
    let identity = client.identify()?;
    if client.running()? != Some(false) {
        return Err(refuse(
            &target,
            format!(
                "--transfer-baud {}: the drive reports a running motor (or its running state cannot be read); the line rate is switched only at standstill, and no override lifts that: stop the drive, or leave out --transfer-baud",
                req.rate
            ),
        ));
    }
    let before = client.read(c.rate)?;
    let mut record = TransferRecord {
        code: code_label(client.schema(), c.rate),
        old_rate: decision.old_rate,
        transfer_rate: req.rate,
        before: JournalValue::from(&before),
        state: TransferState::Switching,
        switched_at_ns: None,
        back_at_ns: None,
        stored: None,
        keep: None,
    };
    if let Some(dir) = journal.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::journal::ensure_dir(dir)?;
    }
    let mut j = placeholder(&*client, &identity, set_fingerprint, record.clone());
    j.transition(
        TxnState::Planned,
        client.clock().now().as_nanos(),
        Some(format!(
            "switching to the transfer rate {} baud (from {})",
            req.rate, decision.old_rate
        )),
    );
    JournalFile::create(journal, j)?;
    switch_over(client, c, &mut record, journal).map_err(|e| {
        let j = journal.display();
        with_rate_note(e, &Ok(format!("journal {j}: run `driveset recover {j}`")))
    })?;
    Ok(Session {
        codes: Some(c),
        record: Some(record),
        decision,
    })
}

/// Switch back (module docs, step 4) and settle the journal: a placeholder
/// nobody replaced becomes `complete` when `ok`, else `rolled-back`
/// (nothing but the rate was written). Returns the report, or the error
/// text when the drive could not be switched back (the journal then keeps
/// the record open for `driveset recover`).
pub fn end(
    client: &mut dyn DriveClient,
    session: Session,
    journal: &Path,
    ok: bool,
) -> Result<TransferReport, Box<(TransferReport, String)>> {
    let (Some(c), Some(mut rec)) = (session.codes, session.record) else {
        return Ok(TransferReport {
            decision: session.decision,
            switched: false,
            state: String::new(),
        });
    };
    // The upload may have rewritten the journal (with this record in it).
    let back = switch_back(client, c, &mut rec, journal);
    let report = |state: String| TransferReport {
        decision: session.decision.clone(),
        switched: true,
        state,
    };
    match back {
        Ok(state) => {
            if let Ok(mut jf) = JournalFile::open(journal)
                && jf.journal.plan.is_empty()
                && jf.journal.state == TxnState::Planned
            {
                let (st, note) = if ok {
                    (
                        TxnState::Complete,
                        "nothing to write; line rate switched back",
                    )
                } else {
                    (
                        TxnState::RolledBack,
                        "nothing written; line rate switched back",
                    )
                };
                jf.journal
                    .transition(st, client.clock().now().as_nanos(), Some(note.into()));
                if let Err(e) = jf.persist() {
                    return Err(Box::new((report(state), e.to_string())));
                }
            }
            Ok(report(state))
        }
        Err(why) => Err(Box::new((report(why.clone()), why))),
    }
}

/// The exchanges an upload of `set` cannot avoid: the read-back of every
/// code (the writes are not known before it, and only add to the saving).
pub fn upload_exchanges(set: &ResolvedSet) -> Vec<CodeKey> {
    set.values.keys().copied().collect()
}

/// `upload` with a transfer rate (module docs): the upload runs between
/// [`begin`] and [`end`]; the report says whether the rate was switched.
pub fn upload(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    opts: &UploadOptions,
    req: &TransferRequest,
) -> Result<UploadReport, UploadFailure> {
    let session = begin(
        client,
        req,
        &opts.journal,
        set.fingerprint(),
        &upload_exchanges(set),
        &[],
    )?;
    let mut o = opts.clone();
    o.transfer = session.record().cloned();
    let result = crate::upload::upload(client, set, &o);
    let ok = result.is_ok();
    let back = end(client, session, &opts.journal, ok).map_err(|b| *b);
    match (result, back) {
        (Ok(mut report), Ok(t)) => {
            let verified = final_verify(client, set, &report, &opts.journal);
            report.transfer = Some(t);
            match verified {
                Ok(()) => Ok(report),
                Err(e) => {
                    report.state = TxnState::Failed;
                    Err(UploadFailure {
                        error: Box::new(e),
                        report: Some(Box::new(report)),
                    })
                }
            }
        }
        (Ok(mut report), Err((t, why))) => {
            report.transfer = Some(t);
            Err(UploadFailure {
                error: Box::new(EngineError::no_answer(
                    client.target().clone(),
                    format!(
                        "switching back from the transfer rate (the drive holds the set, verified; {why}; journal {}: run `driveset recover {}`)",
                        opts.journal.display(),
                        opts.journal.display()
                    ),
                    1,
                )),
                report: Some(Box::new(report)),
            })
        }
        (Err(mut f), back) => {
            let (t, note): (TransferReport, Back) = match back {
                Ok(t) => {
                    let s = t.state.clone();
                    (t, Ok(s))
                }
                Err((t, why)) => (t, Err(why)),
            };
            if t.switched {
                f.error = Box::new(with_rate_note(*f.error, &note));
            }
            if let Some(r) = &mut f.report {
                r.transfer = Some(t);
            }
            Err(f)
        }
    }
}

/// The last step of a switched upload: read every code of the set the
/// upload verified or found unchanged back again, at the rate the drive
/// runs at now (the switch back came after the upload's own verify, and a
/// restart in between loses RAM values and activates whatever the rate
/// code held). Only then is the upload complete. A code that reads
/// otherwise (or not at all) fails the upload: the journal goes to
/// `failed` with what each planned code holds, for `driveset recover`.
fn final_verify(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    report: &UploadReport,
    journal: &Path,
) -> Result<(), EngineError> {
    use crate::upload::CodeOutcome;
    let schema = client.schema().clone();
    let rate = client.line_rate();
    let mut differ: Vec<String> = Vec::new();
    let mut failure: Option<EngineError> = None;
    for c in &report.codes {
        if !matches!(c.outcome, CodeOutcome::Verified | CodeOutcome::Unchanged) {
            continue;
        }
        let key = CodeKey {
            number: c.number,
            subcode: c.subcode,
        };
        let Some(want) = set.values.get(&key) else {
            continue;
        };
        match client.read(key) {
            Ok(got) if &got == want => {}
            Ok(got) => differ.push(format!(
                "{} reads {} instead of {}",
                code_label(&schema, key),
                crate::plan::value_text(&schema, key, &got),
                crate::plan::value_text(&schema, key, want)
            )),
            Err(e) => {
                failure = Some(e);
                break;
            }
        }
    }
    if differ.is_empty() && failure.is_none() {
        return Ok(());
    }
    let at = rate.map_or_else(String::new, |r| format!(" at {r} baud"));
    let what = match &failure {
        Some(e) => format!("the final read-back{at} after the switch back failed: {e}"),
        None => format!(
            "after the switch back, the final read-back{at} finds {} (did the drive restart?)",
            differ.join(", ")
        ),
    };
    let mut detail = what.clone();
    if let Ok(mut jf) = JournalFile::open(journal) {
        let backup: std::collections::BTreeMap<CodeKey, RawValue> = jf
            .journal
            .backup_values()
            .unwrap_or_default()
            .into_iter()
            .collect();
        let new_values: std::collections::BTreeMap<CodeKey, RawValue> = jf
            .journal
            .new_values()
            .unwrap_or_default()
            .into_iter()
            .collect();
        if failure.is_none() {
            let holding = crate::upload::holdings(client, &schema, &backup, &new_values);
            detail = format!("{what}; {}", crate::upload::describe_holdings(&holding));
            jf.journal.holding = holding;
        }
        jf.journal.failure = Some(detail.clone());
        jf.journal.transition(
            TxnState::Failed,
            client.clock().now().as_nanos(),
            Some(detail.clone()),
        );
        jf.persist()?;
    }
    Err(EngineError::inconsistent(
        client.target().clone(),
        journal.display().to_string(),
        detail,
    ))
}

/// The codes [`crate::pull::pull`] reads (for [`decide`]): every code
/// and subcode of the schema but those pull leaves out on purpose (see
/// its module docs).
pub fn pull_exchanges(schema: &Schema, opts: &PullOptions) -> Vec<CodeKey> {
    let mut out = Vec::new();
    for code in &schema.codes {
        if crate::pull::left_out_reason(schema, code, opts).is_some() {
            continue;
        }
        match code.subcodes {
            Some(n) if n > 0 => out.extend((1..=n).map(|s| CodeKey::sub(code.number, s))),
            _ => out.push(CodeKey::new(code.number)),
        }
    }
    out
}

/// `pull` with a transfer rate: the journal at `journal` records the
/// switch (nothing else is written).
pub fn pull(
    client: &mut dyn DriveClient,
    opts: &PullOptions,
    req: &TransferRequest,
    journal: &Path,
    hook: &crate::observe::Hook,
) -> Result<(Pulled, TransferReport), EngineError> {
    let reads = pull_exchanges(client.schema(), opts);
    let session = begin(client, req, journal, String::new(), &reads, &[])?;
    read_only(client, session, journal, "the pull itself completed", |c| {
        crate::pull::pull_observed(c, opts, hook)
    })
}

/// A live diff ([`crate::live::live_diff`]) with a transfer rate; the
/// journal at `journal` records the switch.
pub fn live_diff(
    client: &mut dyn DriveClient,
    set: &ResolvedSet,
    req: &TransferRequest,
    journal: &Path,
) -> Result<(driveset_schema::Diff, TransferReport), EngineError> {
    let keys = upload_exchanges(set);
    let session = begin(client, req, journal, set.fingerprint(), &keys, &[])?;
    read_only(client, session, journal, "the values were read", |c| {
        crate::live::live_diff(c, set)
    })
}

/// Run the reads of a command that writes nothing but the rate inside
/// `session`, then switch back; `done` says what completed when only the
/// switch back failed.
fn read_only<T>(
    client: &mut dyn DriveClient,
    session: Session,
    journal: &Path,
    done: &str,
    work: impl FnOnce(&mut dyn DriveClient) -> Result<T, EngineError>,
) -> Result<(T, TransferReport), EngineError> {
    let result = work(&mut *client);
    let back = end(client, session, journal, result.is_ok()).map_err(|b| *b);
    match (result, back) {
        (Ok(v), Ok(t)) => Ok((v, t)),
        (Ok(_), Err((_, why))) => Err(EngineError::no_answer(
            client.target().clone(),
            format!(
                "switching back from the transfer rate ({done}; {why}; journal {}: run `driveset recover {}`)",
                journal.display(),
                journal.display()
            ),
            1,
        )),
        (Err(e), Ok(t)) => Err(with_rate_note(e, &Ok(t.state))),
        (Err(e), Err((_, why))) => Err(with_rate_note(e, &Err(why))),
    }
}

/// `recover`'s first step for a journal that records a transfer-rate
/// switch: find the drive at whatever rate it answers (§5.1: the port's
/// rate, the transfer rate, the old rate, then every rate of the family)
/// and leave the host there; `Ok(None)` when the journal records no
/// switch. The transaction is then settled at that rate, and
/// [`finish_rate`] switches back.
pub fn find_drive(
    client: &mut dyn DriveClient,
    jf: &JournalFile,
) -> Result<Option<u32>, EngineError> {
    let Some(rec) = jf.journal.transfer.clone() else {
        return Ok(None);
    };
    let schema = client.schema().clone();
    let target = client.target().clone();
    if codes_of(&schema).is_none() {
        return Err(refuse(
            &target,
            format!(
                "the journal records a transfer-rate switch, but schema `{}` has no online rate change",
                schema.id
            ),
        ));
    }
    let here = client.line_rate().unwrap_or(rec.old_rate);
    match search(client, &[here, rec.transfer_rate, rec.old_rate])? {
        Some(found) => Ok(Some(found)),
        None => {
            let _ = client.set_line_rate(here);
            Err(EngineError::no_answer(
                target,
                format!(
                    "the search for the drive over every rate (lustbus-protocol.txt §5.1; the journal records a switch from {} to {} baud); {}",
                    rec.old_rate,
                    rec.transfer_rate,
                    whereabouts(&rec, rec.state, None)
                ),
                1,
            ))
        }
    }
}

/// `recover`'s last step for a journal that records a transfer-rate
/// switch, after the transaction was settled (`result`) with the drive
/// found at `found` baud: an open switch is switched back to the old rate,
/// the rate code keeping what a successful settle left in it
/// ([`keep_value`]: never the transfer rate unless the set's), or after a
/// failed one the [`TransferRecord::keep`] the upload recorded when it had
/// settled the transaction itself (`settled_before`).
/// This is done after a failed settle too, so that the drive is not left
/// at the transfer rate, but never when the drive is not the journal's.
/// A switch already back with the drive found at another rate (it
/// restarted at what its rate code held) is switched back the same way.
pub fn finish_rate(
    client: &mut dyn DriveClient,
    journal: &Path,
    found: u32,
    settled_before: bool,
    result: Result<crate::recover::RecoverReport, EngineError>,
) -> Result<crate::recover::RecoverReport, EngineError> {
    if let Err(e) = &result
        && matches!(e.kind(), ErrorKind::NotJournalDrive { .. })
    {
        return result;
    }
    let mut jf = match JournalFile::open(journal) {
        Ok(jf) => jf,
        Err(e) => return result.and(Err(e)),
    };
    let Some(mut rec) = jf.journal.transfer.clone() else {
        return result;
    };
    let Some(c) = codes_of(client.schema()) else {
        return result;
    };
    let back: Back = if rec.is_back() && found == rec.old_rate {
        Ok(format!("the drive runs at {found} baud"))
    } else {
        // A drive found elsewhere though the switch was back has
        // restarted since at what its rate code held: it is switched back
        // too, keeping what the settle left there.
        // After a successful settle the outcome says what the rate code
        // keeps: the set's value (completed) or the old one (rolled back)
        // when the set has the code, else the drive's own `before`; after a
        // failed one, the decision the upload recorded stands.
        match result.as_ref().map(|r| r.action) {
            Ok(action) => rec.keep = Some(settled_keep(&jf.journal, c, &rec, action)),
            Err(_) if !settled_before || rec.is_back() => rec.keep = None,
            Err(_) => {}
        }
        let planned = planned_rate(&jf.journal, c);
        let state0 = rec.state;
        start_back(&mut rec);
        let mut persist = |r: &TransferRecord| {
            jf.journal.transfer = Some(r.clone());
            jf.persist()
        };
        match persist(&rec)
            .and_then(|()| switch_back_once(client, c, &mut rec, planned.as_ref(), &mut persist))
        {
            Ok(state) => {
                rec.state = TransferState::Back;
                rec.back_at_ns = Some(client.clock().now().as_nanos());
                jf.journal.transfer = Some(rec);
                match jf.persist() {
                    Ok(()) => Ok(format!("found at {found} baud; {state}")),
                    Err(e) => Err(e.to_string()),
                }
            }
            Err(e) => Err(format!(
                "{e}; {}",
                whereabouts(&rec, state0, client.line_rate())
            )),
        }
    };
    match (result, back) {
        (Ok(mut r), Ok(text)) => {
            r.transfer = Some(text);
            Ok(r)
        }
        (Ok(_), Err(why)) => Err(EngineError::no_answer(
            client.target().clone(),
            format!(
                "switching back from the transfer rate (the transaction was settled; {why}; run `driveset recover {}` again)",
                journal.display()
            ),
            1,
        )),
        (Err(e), back) => Err(with_rate_note(e, &back)),
    }
}
