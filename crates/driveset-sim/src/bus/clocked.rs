//! Owns [`SimByteBus`]: a [`ByteLine`] driven by a [`VirtualClock`], the
//! host side as a [`ByteLink`] (timing: the module docs of [`crate::bus`]).

use super::*;

/// A simulated RS-485 line on a [`VirtualClock`], the host side as a
/// [`ByteLink`] (see the module docs for timing).
#[derive(Debug)]
pub struct SimByteBus {
    line: ByteLine,
    clock: VirtualClock,
    name: String,
    /// [`ByteLink::bus_id`]; `None`: `sim:` and the name.
    bus_id: Option<String>,
    host_busy_until: Instant,
}

impl SimByteBus {
    /// A bus at `baud` on `clock` with `drives`, named `sim`; the bus
    /// starts (for time-triggered faults) at the clock's current instant.
    pub fn new(
        clock: &VirtualClock,
        baud: u32,
        drives: Vec<Box<dyn ByteDrive>>,
    ) -> Result<Self, BusError> {
        Ok(Self::from_line(clock, ByteLine::new(baud, drives)?))
    }

    /// A bus around a configured core.
    pub fn from_line(clock: &VirtualClock, mut line: ByteLine) -> Self {
        line.set_origin(clock.now());
        SimByteBus {
            line,
            clock: clock.clone(),
            name: "sim".into(),
            bus_id: None,
            host_busy_until: Instant::ZERO,
        }
    }

    /// Inject the faults of `plan` (seed: the plan's, else `run_seed`).
    pub fn with_faults(mut self, plan: FaultPlan, run_seed: u64) -> Self {
        self.line = self.line.with_faults(plan, run_seed);
        self
    }

    /// Record into `log`.
    pub fn with_log(mut self, log: EventLog) -> Self {
        self.line = self.line.with_log(log);
        self
    }

    /// Name the port (as errors and reports show it).
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// Give the bus its identity ([`ByteLink::bus_id`], default `sim:` and
    /// the port name): two buses with the same id are one bus to journals.
    pub fn with_bus_id(mut self, id: impl Into<String>) -> Self {
        self.bus_id = Some(id.into());
        self
    }

    /// The core.
    pub fn line(&self) -> &ByteLine {
        &self.line
    }

    /// The core, mutable.
    pub fn line_mut(&mut self) -> &mut ByteLine {
        &mut self.line
    }

    /// The drives, in the order given.
    pub fn drives(&self) -> &[Box<dyn ByteDrive>] {
        self.line.drives()
    }

    /// The drive at `address`.
    pub fn drive_mut(&mut self, address: u8) -> Option<&mut (dyn ByteDrive + 'static)> {
        self.line.drive_mut(address)
    }

    /// See [`ByteLine::state_dump`].
    pub fn state_dump(&self) -> serde_json::Value {
        self.line.state_dump()
    }

    /// The host reopens its port at `baud` (after an SBAUD change).
    pub fn set_baud(&mut self, baud: u32) -> Result<(), BusError> {
        self.line.set_baud(baud)
    }

    /// Restart the drive at `address` now ([`ByteLine::power_cycle`]) and
    /// wait until it has booted.
    pub fn restart(&mut self, address: u8, off: Duration) {
        let now = self.clock.now();
        self.line.power_cycle(now, Some(address), off);
        self.clock.sleep(off + Duration::from_millis(100));
        let now = self.clock.now();
        self.line.advance(now);
    }

    /// The bus's clock.
    pub fn virtual_clock(&self) -> &VirtualClock {
        &self.clock
    }

    /// Give the drives back.
    pub fn into_drives(self) -> Vec<Box<dyn ByteDrive>> {
        self.line.into_drives()
    }
}

impl ByteLink for SimByteBus {
    fn port(&self) -> &str {
        &self.name
    }

    fn bus_id(&self) -> String {
        self.bus_id
            .clone()
            .unwrap_or_else(|| format!("sim:{}", self.name))
    }

    fn baud(&self) -> u32 {
        self.line.baud()
    }

    fn clock(&self) -> &dyn Clock {
        &self.clock
    }

    fn send(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        if let Some((offset, &byte)) = bytes.iter().enumerate().find(|(_, b)| **b & 0x80 != 0) {
            return Err(LinkError::NotSevenBit {
                port: self.name.clone(),
                offset,
                byte,
            });
        }
        if bytes.is_empty() {
            return Ok(());
        }
        let start = self.clock.now().max(self.host_busy_until);
        let end = self.line.host_send_paced(start, bytes);
        self.host_busy_until = end;
        self.clock.sleep_until(end);
        Ok(())
    }

    fn recv(&mut self, buf: &mut [u8], deadline: Instant) -> Result<usize, LinkError> {
        if buf.is_empty() {
            return Ok(0);
        }
        loop {
            let now = self.clock.now();
            self.line.advance(now);
            if self.line.next_arrival().is_some_and(|a| a <= now) {
                return Ok(self.line.take_arrived(now, buf));
            }
            match self.line.next_wakeup() {
                Some(t) if t > now && t <= deadline => {
                    self.clock.sleep_until(t);
                }
                _ => {
                    self.clock.sleep_until(deadline);
                    self.line.advance(deadline);
                    return Ok(0);
                }
            }
        }
    }

    fn discard_input(&mut self) -> Result<(), LinkError> {
        let now = self.clock.now();
        self.line.advance(now);
        self.line.discard_arrived(now);
        Ok(())
    }

    fn flush(&mut self) -> Result<(), LinkError> {
        // `send` returns when the last character is through.
        Ok(())
    }

    /// The host reopens its side at `baud`: from the next character on it
    /// sends and listens at that rate; each drive keeps its own (a
    /// mismatch garbles both ways, module docs).
    fn set_baud(&mut self, baud: u32) -> Result<(), LinkError> {
        self.line
            .set_baud(baud)
            .map_err(|_| LinkError::UnsupportedBaud {
                port: self.name.clone(),
                baud,
            })
    }
}
