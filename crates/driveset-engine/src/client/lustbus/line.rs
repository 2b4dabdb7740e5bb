//! The LUSTBUS line under a [`super::LustbusClient`] and the scan and
//! assignment probes: the link, the codec's master-side [`ReplyDecoder`],
//! the counters and the link's measured latency, and one exchange
//! (`lustbus-protocol.txt` section 3: a telegram out, its reply awaited,
//! a late reply listened for and dropped, [`super::super::timing`]).

use std::time::Duration;

use driveset_link::{ByteLink, LinkError};
use driveset_proto::lustbus::{Address, ParameterCode, Reply, ReplyDecoder};

use super::MIN_REACTION;
use crate::client::ClientStats;
use crate::client::timing::{AnswerWait, LinkLatency};

/// What one exchange gave.
#[derive(Debug)]
pub(super) enum Outcome {
    Reply(Reply),
    NoAnswer,
    Garbled(String),
}

/// The line: link, reply decoder, counters, the link's latency. Shared by
/// the client and scan.
#[derive(Debug)]
pub struct LustLine<L> {
    pub(crate) link: L,
    decoder: ReplyDecoder,
    pub(crate) stats: ClientStats,
    /// A telegram went out since the last lone EOT.
    open: bool,
    /// Send a lone EOT after every reply ([`LustbusOptions::eot_after_reply`]).
    pub(crate) eot_after_reply: bool,
    /// The link's measured latency ([`super::timing`]).
    pub(crate) latency: LinkLatency,
    /// Listen for a late reply after a timeout (scan probes do not: they
    /// move on to another address, whose reply tells itself apart).
    pub(crate) wait_late: bool,
}

impl<L: ByteLink> LustLine<L> {
    pub(crate) fn new(link: L) -> Self {
        LustLine {
            link,
            decoder: ReplyDecoder::new(),
            stats: ClientStats::default(),
            open: false,
            eot_after_reply: false,
            latency: LinkLatency::new(None),
            wait_late: true,
        }
    }

    /// Send one telegram: drop unread input first (a late answer to an
    /// earlier request is not this one's reply), send, wait until it has
    /// left, count it.
    pub(super) fn send_telegram(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        self.link.discard_input()?;
        self.link.send(bytes)?;
        self.link.flush()?;
        self.open = true;
        self.stats.telegrams += 1;
        self.stats.sent += bytes.len() as u64;
        Ok(())
    }

    /// Sends `bytes` (a complete telegram, leading EOT included) and waits
    /// `timeout` from the end of the send for a reply from `address`
    /// (`expect_code`: the CODE a value reply must carry). `known_delay`
    /// is what the drive is known to add to its reaction (VF1000 EEPROM ACK
    /// delay), left out of the latency sample. After a timeout, listens
    /// for a late reply for as long again (see [`super::timing`]).
    pub(super) fn exchange(
        &mut self,
        bytes: &[u8],
        address: Address,
        expect_code: Option<ParameterCode>,
        timeout: Duration,
        known_delay: Duration,
    ) -> Result<Outcome, LinkError> {
        self.decoder.reset();
        self.send_telegram(bytes)?;
        let mut wait = AnswerWait::begin(self.link.clock().now(), timeout);
        let mut garbled: Option<String> = None;
        let mut buf = [0u8; 128];
        loop {
            let n = self.link.recv(&mut buf, wait.until())?;
            if n == 0 {
                // Timed out: a reply may still be on its way. Listen as
                // long again so that it cannot be taken for the answer to
                // the next telegram.
                if wait.nothing_came(&mut self.latency, self.wait_late) {
                    continue;
                }
                for ev in self.decoder.finish() {
                    if let Err(e) = ev.result {
                        garbled = Some(e.to_string());
                    }
                }
                return Ok(match garbled {
                    Some(g) => Outcome::Garbled(g),
                    None => Outcome::NoAnswer,
                });
            }
            let got = buf.get(..n).unwrap_or(&[]);
            self.stats.received += got.len() as u64;
            wait.came(got.len());
            for ev in self.decoder.feed(got) {
                match ev.result {
                    Ok(reply) => {
                        if address != Address::ALL && reply.address() != address {
                            // A late reply of another drive (or a drive
                            // with a wrong address): never this answer.
                            self.stats.late += 1;
                            garbled = Some(format!(
                                "a reply from address {} (a late reply, or another drive with a wrong address?)",
                                reply.address()
                            ));
                            continue;
                        }
                        if let (Reply::Value(v), Some(code)) = (&reply, expect_code)
                            && v.code != code
                        {
                            // A late reply to an earlier ENQUIRY.
                            self.stats.late += 1;
                            garbled = Some(format!(
                                "a value reply for CODE {} instead of {code} (late, discarded)",
                                v.code
                            ));
                            continue;
                        }
                        let elapsed = wait.answered(
                            &mut self.latency,
                            self.link.clock().now(),
                            self.link.baud(),
                            MIN_REACTION.saturating_add(known_delay),
                        );
                        if wait.is_late() {
                            // The answer to this telegram, after its
                            // timeout: dropped, the telegram is repeated.
                            self.stats.late += 1;
                            return Ok(Outcome::Garbled(format!(
                                "a reply {} ms after the request, later than the answer timeout of {} ms (late, discarded)",
                                elapsed.as_millis(),
                                wait.timeout().as_millis()
                            )));
                        }
                        if self.eot_after_reply {
                            self.link.send(&[driveset_proto::ascii::EOT])?;
                            self.link.flush()?;
                            self.stats.sent += 1;
                        }
                        return Ok(Outcome::Reply(reply));
                    }
                    Err(e) => garbled = Some(e.to_string()),
                }
            }
        }
    }

    /// Forget a partly decoded reply (after a rate change).
    pub(crate) fn reset_decoder(&mut self) {
        self.decoder.reset();
    }

    /// The lone EOT that ends a session, if a telegram went out.
    pub(crate) fn finish(&mut self) -> Result<(), LinkError> {
        if self.open {
            self.link.send(&[driveset_proto::ascii::EOT])?;
            self.link.flush()?;
            self.stats.sent += 1;
            self.open = false;
        }
        Ok(())
    }
}
