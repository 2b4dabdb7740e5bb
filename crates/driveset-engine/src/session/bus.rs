//! Owns the session of one drive on a link the caller keeps (a line's bus,
//! which goes from drive to drive over one link): the drive at an address,
//! its schema learned on the way as [`super::Session::open`] learns it
//! (the same implementation, `reach`), and a client that borrows the link
//! (docs/architecture.md, "One path from a port to a drive").

use std::sync::Arc;

use driveset_link::Link;
use driveset_schema::Schema;

use super::learning::LearnedReport;
use super::reach::{Kept, Reached, connected, reach};
use super::{SessionError, SessionPolicy};
use crate::client::DriveClient;
use crate::connect::ConnectOptions;
use crate::error::EngineError;

/// A drive reached over a link the caller keeps: the client speaking
/// `schema` borrows the link for `'l`, and what was learned on the way.
pub struct BusSession<'l> {
    /// The port as reports name it.
    pub port: String,
    /// The drive's address (node id on CAN).
    pub address: u8,
    /// The schema the client speaks (the learned one, after learning).
    pub schema: Arc<Schema>,
    /// The client.
    pub client: Box<dyn DriveClient + 'l>,
    /// What learning did, when it ran.
    pub learned: Option<LearnedReport>,
}

impl std::fmt::Debug for BusSession<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BusSession")
            .field("port", &self.port)
            .field("address", &self.address)
            .field("schema", &self.schema.id)
            .field("learned", &self.learned.as_ref().map(|l| &l.id))
            .finish_non_exhaustive()
    }
}

impl<'l> BusSession<'l> {
    /// The drive at `address` of `link` (the port `port`), speaking
    /// `schema`: learned from the drive first when `policy` says so and
    /// the schema lacks facts ([`crate::learn::needs_learning`]), as
    /// [`super::Session::open`] does; a schema whose protocol does not run
    /// on the link is refused before anything is sent. The clients are
    /// [`crate::connect::connect_on`]'s (the default connect options;
    /// [`BusSession::open_using`] gives the port's).
    /// `policy.fit` is not asked: there is no [`super::OpenedPort`] to
    /// check ([`super::check_fit`]), a line's drives were checked against
    /// their buses when its manifest loaded.
    pub fn open(
        link: &'l mut Link,
        port: &str,
        schema: Arc<Schema>,
        address: u8,
        policy: &SessionPolicy<'_>,
    ) -> Result<BusSession<'l>, SessionError> {
        BusSession::open_using(
            link,
            port,
            schema,
            address,
            policy,
            ConnectOptions::default(),
        )
    }

    /// As [`BusSession::open`], the clients with `options`, the options of
    /// the port the link was opened from (a line's bus:
    /// `ConnectOptions::of` its port, so its `latency=` reaches every
    /// client as a one-drive command's does).
    pub fn open_using(
        link: &'l mut Link,
        port: &str,
        schema: Arc<Schema>,
        address: u8,
        policy: &SessionPolicy<'_>,
        options: ConnectOptions,
    ) -> Result<BusSession<'l>, SessionError> {
        let reached = reach(Kept { link, options }, port, schema, address, policy)?;
        Ok(BusSession::of(port, address, reached))
    }

    /// The drive at `address` of `link`, speaking `schema` as it is (no
    /// learning: [`SessionPolicy::default`]); only the bus or a refusal
    /// fails it.
    pub fn connect(
        link: &'l mut Link,
        port: &str,
        schema: Arc<Schema>,
        address: u8,
    ) -> Result<BusSession<'l>, EngineError> {
        BusSession::connect_using(link, port, schema, address, ConnectOptions::default())
    }

    /// As [`BusSession::connect`], the client with `options` (as
    /// [`BusSession::open_using`]).
    pub fn connect_using(
        link: &'l mut Link,
        port: &str,
        schema: Arc<Schema>,
        address: u8,
        options: ConnectOptions,
    ) -> Result<BusSession<'l>, EngineError> {
        let reached = connected(Kept { link, options }, schema, address)?;
        Ok(BusSession::of(port, address, reached))
    }

    fn of(port: &str, address: u8, reached: Reached<'l>) -> BusSession<'l> {
        BusSession {
            port: port.to_string(),
            address,
            schema: reached.schema,
            client: reached.client,
            learned: reached.learned,
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};
    use std::time::Duration;

    use driveset_link::VirtualClock;
    use driveset_proto::can::NodeId;
    use driveset_schema::Registry;
    use driveset_sim::drive::{ByteDrive, FrameDrive, ReactionTime};
    use driveset_sim::ecs::EcsDrive;
    use driveset_sim::log::{Dir, EventLog};
    use driveset_sim::lustbus_drive::LustOptions;
    use driveset_sim::mc6000::Mc6000;
    use driveset_sim::vf1000::Vf1000;
    use driveset_test_support::{sim_byte_bus, sim_can_bus, wire_bytes};

    use super::*;
    use crate::env::{Environment, Memory};
    use crate::session::{LearnPolicy, LearnStep, OpenedPort, Session};

    const DIR: &str = "/schemas";

    fn lust(address: u8) -> LustOptions {
        LustOptions::new(address).reaction(ReactionTime::fixed(Duration::from_millis(2)))
    }

    /// A simulated LUSTBUS line with a VF1000 at 5 and an MC6000 at 1.
    fn line() -> (VirtualClock, EventLog, Link) {
        let drives: Vec<Box<dyn ByteDrive>> = vec![
            Box::new(Vf1000::new(lust(5)).expect("vf1000")),
            Box::new(Mc6000::new(lust(1)).expect("mc6000")),
        ];
        let (clock, log, bus) = sim_byte_bus(9600, drives, None);
        (clock, log, Link::Bytes(Box::new(bus)))
    }

    fn builtin(id: &str) -> (Registry, Arc<Schema>) {
        let registry = Registry::builtin().expect("built-in schemas");
        let schema = registry.get(id).expect("built-in schema");
        (registry, schema)
    }

    fn env() -> Memory {
        Memory::at("2031-07-04T12:00:00Z".parse().expect("time"))
    }

    fn learning<'a>(registry: &'a Registry, env: &'a Memory, step: LearnStep) -> SessionPolicy<'a> {
        SessionPolicy {
            learn: Some(LearnPolicy {
                options: Default::default(),
                registry,
                dir: Some(PathBuf::from(DIR)),
                env,
                step,
            }),
        }
    }

    fn file_of(id: &str) -> PathBuf {
        Path::new(DIR).join(format!("{id}.toml"))
    }

    /// The host's SELECTs (STX after the address): what changes a drive.
    fn selects(log: &EventLog) -> usize {
        wire_bytes(log, Dir::Host)
            .iter()
            .filter(|t| t.get(2) == Some(&0x02))
            .count()
    }

    #[test]
    fn a_bus_session_learns_writes_its_file_and_leaves_the_link_to_the_next_drive() {
        let (_clock, _log, mut link) = line();
        let (registry, base) = builtin("lust-vf1000");
        let env = env();
        let policy = learning(&registry, &env, LearnStep::Render);
        let mut s = BusSession::open(&mut link, "sim", base.clone(), 5, &policy).expect("opens");
        let learned = s.learned.clone().expect("learned");
        assert!(
            learned.id.starts_with("learned-vf1000-type"),
            "{}",
            learned.id
        );
        assert_eq!(s.schema.id, learned.id);
        assert_eq!(learned.base, "lust-vf1000");
        assert!(learned.codes > 0);
        assert_eq!(
            learned.file.as_deref(),
            Some(file_of(&learned.id).as_path())
        );
        let text = env.file(&file_of(&learned.id)).expect("file written");
        assert!(text.contains(&learned.id), "{text}");
        // the client speaks the learned schema
        assert_eq!(s.client.schema().id, learned.id);
        s.client.identify().expect("identify");
        s.client.finish().expect("finish");
        drop(s);
        // the link is the caller's again: the next drive's session on it
        let (_, mc) = builtin("lust-mc6000");
        let mut next = BusSession::connect(&mut link, "sim", mc, 1).expect("connects");
        assert!(next.learned.is_none());
        assert_eq!(next.schema.id, "lust-mc6000");
        next.client.identify().expect("identify");
    }

    #[test]
    fn the_borrowed_and_the_owned_session_learn_the_same_file() {
        let (registry, base) = builtin("lust-vf1000");
        let (_c2, _l2, link) = line();
        let spec = driveset_link::PortSpec::parse("tcp://127.0.0.1:9").expect("a port");
        let port = OpenedPort::real(spec, link);
        let name = port.name.clone();
        let (_c1, _l1, mut link) = line();
        let borrowed_env = env();
        let policy = learning(&registry, &borrowed_env, LearnStep::Render);
        let borrowed = BusSession::open(&mut link, &name, base.clone(), 5, &policy)
            .expect("opens")
            .learned
            .expect("learned");
        let owned_env = env();
        let policy = learning(&registry, &owned_env, LearnStep::Render);
        let owned = Session::open(port, base, 5, &policy)
            .expect("opens")
            .learned
            .expect("learned");
        assert_eq!(owned.id, borrowed.id);
        assert_eq!(
            owned_env.file(&file_of(&owned.id)),
            borrowed_env.file(&file_of(&borrowed.id))
        );
    }

    #[test]
    fn reuse_earlier_uses_the_file_a_render_wrote_reads_no_texts_and_writes_nothing() {
        let (registry, base) = builtin("lust-mc6000");
        let env = env();
        let (_clock, rendering, mut link) = line();
        let policy = learning(&registry, &env, LearnStep::Render);
        let first = BusSession::open(&mut link, "sim", base.clone(), 1, &policy)
            .expect("opens")
            .learned
            .expect("learned");
        let written = env.paths();
        assert_eq!(written, [file_of(&first.id)]);

        let (_clock, log, mut link) = line();
        let policy = learning(&registry, &env, LearnStep::ReuseEarlier);
        let s = BusSession::open(&mut link, "sim", base, 1, &policy).expect("opens");
        let again = s.learned.clone().expect("learned");
        assert_eq!(again.id, first.id);
        assert_eq!(again.file, Some(file_of(&first.id)));
        assert_eq!(s.schema.id, first.id);
        // the descriptions only: no texts, so no SELECT of 108-STEXT
        assert_eq!(again.learned.texts_read, 0);
        assert!(first.learned.texts_read > 0);
        assert!(selects(&rendering) > 0);
        assert_eq!(selects(&log), 0);
        assert_eq!(again.codes, again.learned.codes.len());
        assert_eq!(env.paths(), written);
    }

    #[test]
    fn reuse_earlier_without_a_file_renders_and_writes_nothing() {
        let (registry, base) = builtin("lust-vf1000");
        let env = env();
        let (_clock, log, mut link) = line();
        let policy = learning(&registry, &env, LearnStep::ReuseEarlier);
        let s = BusSession::open(&mut link, "sim", base, 5, &policy).expect("opens");
        let learned = s.learned.clone().expect("learned");
        assert_eq!(learned.file, None);
        assert_eq!(s.schema.id, learned.id);
        assert!(env.paths().is_empty());
        assert_eq!(selects(&log), 0);
    }

    #[test]
    fn an_earlier_file_that_does_not_load_is_named() {
        let (registry, base) = builtin("lust-vf1000");
        let env = env();
        let (_clock, _log, mut link) = line();
        let policy = learning(&registry, &env, LearnStep::Render);
        let id = BusSession::open(&mut link, "sim", base.clone(), 5, &policy)
            .expect("opens")
            .learned
            .expect("learned")
            .id;
        env.write_file(&file_of(&id), "not a schema")
            .expect("written");
        let policy = learning(&registry, &env, LearnStep::ReuseEarlier);
        let e = BusSession::open(&mut link, "sim", base, 5, &policy).expect_err("refused");
        assert!(matches!(e, SessionError::Earlier { .. }), "{e:?}");
        assert!(
            e.to_string()
                .starts_with(&format!("learned schema {}: ", file_of(&id).display())),
            "{e}"
        );
        assert_eq!(e.layer(), crate::error::Layer::Input);
    }

    #[test]
    fn without_a_learn_policy_the_session_speaks_the_schema_as_it_is() {
        let (_clock, log, mut link) = line();
        let (_, base) = builtin("lust-vf1000");
        let s =
            BusSession::open(&mut link, "sim", base, 5, &SessionPolicy::default()).expect("opens");
        assert!(s.learned.is_none());
        assert_eq!(s.schema.id, "lust-vf1000");
        assert_eq!(s.port, "sim");
        assert_eq!(s.address, 5);
        // nothing is sent before the client is asked
        assert!(wire_bytes(&log, Dir::Host).is_empty());
    }

    #[test]
    fn a_lustbus_schema_on_a_can_bus_is_refused_before_anything_is_sent() {
        let drive: Box<dyn FrameDrive> = Box::new(
            EcsDrive::new(NodeId::new(3).expect("node"), 1)
                .expect("ecs")
                .with_reaction(ReactionTime::fixed(Duration::from_millis(1))),
        );
        let (_clock, log, bus) = sim_can_bus(vec![drive], None);
        let mut link = Link::Frames(Box::new(bus));
        let (registry, base) = builtin("lust-vf1000");
        let env = env();
        let policy = learning(&registry, &env, LearnStep::Render);
        let e = BusSession::open(&mut link, "can", base.clone(), 3, &policy).expect_err("refused");
        let SessionError::Engine(e) = e else {
            panic!("{e:?}")
        };
        assert!(e.is_refused(), "{e}");
        let e = BusSession::connect(&mut link, "can", base, 3).expect_err("refused");
        assert!(e.is_refused(), "{e}");
        assert!(wire_bytes(&log, Dir::Host).is_empty());
        assert!(env.paths().is_empty());
    }
}
