//! `driveset commission LINE`: bring every selected drive of a line to its
//! set. Buses run in parallel (a thread per bus, each bus on its own link
//! and clock); the drives of one bus run in turn. Per drive: identify, read
//! back, diff, upload what differs as one transaction
//! ([`crate::upload::upload`]), verify.
//!
//! **Resume.** Every drive that ends holding its set is recorded in the
//! state file [`STATE_FILE`] in the report directory (bus, address, port,
//! set fingerprint, the fingerprint read back, when). A rerun does not
//! trust the file blindly: for a drive recorded at the set's current
//! fingerprint it identifies the drive and reads the set's codes once
//! (the cost of a `status` check, no planning, no journal, no writes); if
//! the drive still holds the set the drive is [`DriveResult::AlreadyVerified`],
//! otherwise it is commissioned again. A drive whose set changed since is
//! commissioned again. `fresh` ignores the file.
//!
//! **Unfinished journals.** Journals go to [`LineOptions::journal_dir`]
//! under the one naming scheme of [`crate::journal::journal_path`] (bus id
//! and address), so `upload` and `commission` see each other's. Before a
//! drive is touched the directory is scanned for unfinished journals of
//! that drive (by recorded bus and address, not file name). `commission`
//! recovers each ([`crate::recover::recover`]: it refuses another drive or
//! a stale journal), warns what it did, then commissions the drive; the
//! drive is then [`DriveResult::Verified`], never `Unchanged`, and its
//! recorded resume state is not trusted. A refused or failed recovery makes
//! the drive [`DriveResult::Failed`]. `status` writes nothing: such a drive
//! is `Failed` (exit 1). A LECOM group or a LUSTBUS bus with an unfinished
//! journal gets no broadcast (`broadcast_common`).
//!
//! **Verdict** ([`LineOutcome::verdict`], which the CLI maps to its exit
//! codes 0, 1 and 3): [`Verdict::Holds`] every selected drive holds its
//! set; [`Verdict::Differs`] a drive does not (drift, refused, rolled back,
//! failed); [`Verdict::BusFailed`] a bus could not be opened, a link
//! failed, a drive did not answer, or the run stopped before every drive
//! was reached ([`LineObserver::before_drive`]). A bus failure wins over a
//! difference.
//!
//! **The world** ([`LineOptions::env`], [`crate::env::Environment`]): the
//! wall-clock times of the report and the state file, the git commit of the
//! sets, and the state and learned-schema files go through it; the run
//! itself does no file IO but the journals'.
//!
//! **Timeline and progress.** Each drive's work is observed
//! ([`crate::observe`]): the transaction runner reports its own phases,
//! the line runner adds `learn`, `recover`, `broadcast` and the `identify` /
//! `read` of `status` and of a resume check. The bus report's timeline
//! holds those spans (zero-length ones, planning and journal writes on a
//! virtual clock, left out). The run's one observer
//! ([`LineOptions::observer`], [`LineObserver`]) gets every event with its
//! bus and drive, and each drive done with its report; asked before each
//! drive, it may stop a bus as if the run had been killed there (the CLI's
//! hidden `--stop-after`, tests).
//!
//! **Broadcast** (`broadcast_common`; LECOM and LUSTBUS buses; CAN buses
//! fall back to per-drive writes with a warning).
//!
//! LECOM: values every selected drive of a LECOM group (addresses x1..x9)
//! sets identically are sent once per group with MULTICAST to x0 before
//! the drives are done one by one; each drive's own transaction then reads
//! every code back, writes what did not land and verifies, so the
//! broadcast only saves telegrams. MULTICAST is unacknowledged and has no
//! journal backup; drives of the group that the line does not list receive
//! it too.
//!
//! LUSTBUS (sections 2.1, 4.2, 9.1, 11.4): a SELECT to address 31 is
//! executed by every device on the bus, listed in the manifest or not, and
//! none gives a receipt. The common values are the codes every selected
//! MC6000/7000 drive's set gives the same value that are CardWriteable
//! (the ones the SLOAD dataset stages, [`crate::plan::Phase::Dataset`]) and
//! that every drive's plan writes; never the numerically compatible codes
//! 81..85 and 91 (SBAUD, SADDR, SDMMY, SWDGT, SERR, TYPE), never a code
//! with a role (address, baud rate, control, command, mode ...), never
//! SLOAD itself. They go out once, inside every drive's dataset download:
//! 1. every drive is taken through its own [`Transaction`] to "dataset
//!    open": identify, read back, plan (the running check), journal with
//!    backup, SERR cleared, SLOAD = -1 (taken at standstill only; the
//!    drive is then secured against being started until the download
//!    ends, 11.4);
//! 2. each journal records the codes the broadcast sends (its `broadcast`
//!    field) and is made durable;
//! 3. one SELECT per value to address 31 (`_`), nothing awaited but the
//!    longest MC reaction time (timeline phase `broadcast`, drive
//!    `address 31`);
//! 4. each drive in turn: SERR read (the new session's first read: clears
//!    what a broadcast may have latched), its own remaining dataset writes,
//!    SLOAD = -2 and the poll, the writes after the dataset, and the
//!    verification of every code one by one, broadcast ones included. A
//!    broadcast value that did not land is written on its own (after the
//!    commit, as a plain SELECT) and verified; the run warns which.
//!
//! No broadcast (the drives are done one by one, with a warning saying
//! why) when the bus also lists VF1000 drives (a VF1000 executes the
//! SELECT as a write of its own parameter of that number), when a drive
//! the manifest puts on the bus is not selected (`--only` / `--skip`), when
//! the drives do not share one schema or learn theirs first, when any
//! address 0..30 of the bus has an unfinished journal, when a drive does
//! not reach "dataset open" (it runs, refuses, fails, or already holds its
//! set: address 31 would reach it outside a dataset download), and when
//! the observer may stop the bus ([`LineObserver::may_stop`]). A drive's `codes_written` counts its own SELECTs, not the
//! broadcast; its `elapsed_ms` is the time of its own exchanges.
//!
//! **Learning the schema.** A drive whose set names a built-in LUSTBUS
//! schema that lacks facts ([`Drive::learn_from`], see
//! [`crate::learn::needs_learning`]) is learned first, as `pull` and
//! `upload` do and by the same code (the drive's session on the bus's own
//! link, [`crate::session::BusSession`]): before anything else is done to
//! the drive, its descriptions (VF1000 specifier 1, MC specifier 3) are
//! read and interpreted by [`crate::learn::learn`], rendered and checked by
//! [`crate::learn::render_schema`] (the built-in schema's spec facts stand),
//! and the set is resolved again against the learned schema; its findings
//! then fail the drive. `commission` also reads the MC unit strings and
//! value substitution texts (this selects texts with the RAM selector
//! 108-STEXT and sets it back) and writes the learned schema to
//! `LineLearn::schema_dir/<id>.toml`. `status` writes nothing: it reads the
//! descriptions only (ENQUIRY), and uses the file an earlier `commission`
//! wrote for the same descriptions (same id: the id holds their hash) when
//! there is one, else the schema learned without texts (the session's
//! [`crate::session::LearnStep::ReuseEarlier`]). The drive's report
//! names the learned schema ([`LearnedSchemaReport`]); the run's timeline
//! has a `learn` phase. Without [`LineOptions::learn`] such a drive fails.
//!
//! **One loop, two walks.** Every line run goes through the same loop:
//! select, open each bus, take its drives in turn, learn, connect, look up
//! the unfinished journals, count, record. What is done with each drive is
//! the run's walk (`walk`): `commission`'s (`commissioning`: resume state,
//! recovery, resume check, upload, broadcasts) or `status`'s, a read-only
//! walk of its own ([`crate::line::status`]). No flag tells them apart
//! inside the loop.
//!
//! **Modules**, one job each: `options` (what a run is told and gives
//! back, its observer), `walk` (what a run does with each drive),
//! `commissioning` (`commission`'s walk), `resume` (the state file and the
//! resume check), `select` (`--only` / `--skip`), `run` (the run, a thread
//! per bus, the line report), `bus` (one bus thread), `drive` (one drive's
//! turn drive by drive), `recovery` (unfinished journals), `learning`
//! (learning a schema), `multicast` (LECOM), `broadcast` and `parked`
//! (LUSTBUS address 31 and the drives' transactions around it), `timeline`
//! (the bus clock, the drives' observers, the report's timeline).
//!
//! [`DriveResult::AlreadyVerified`]: super::report::DriveResult::AlreadyVerified
//! [`DriveResult::Verified`]: super::report::DriveResult::Verified
//! [`DriveResult::Failed`]: super::report::DriveResult::Failed
//! [`Transaction`]: crate::upload::Transaction
//! [`Drive::learn_from`]: super::manifest::Drive::learn_from
//! [`LearnedSchemaReport`]: super::report::LearnedSchemaReport

mod broadcast;
mod bus;
mod commissioning;
mod drive;
mod learning;
mod multicast;
mod options;
mod parked;
mod recovery;
mod resume;
mod run;
mod select;
mod timeline;
mod walk;

pub use broadcast::lustbus_common_values;
pub use drive::diff_lines;
pub(super) use drive::{Job, blank_report, fill_from_upload};
pub use options::{
    DriveDone, Flow, LineError, LineLearn, LineObserver, LineOptions, LineOutcome, Opener,
    StopAfter, Verdict,
};
pub use resume::{CommissionState, STATE_FILE, STATE_VERSION, StateEntry, StateFileError};
pub use run::commission;
pub(super) use run::run_walk;
pub use select::select;
pub(super) use walk::Walk;
