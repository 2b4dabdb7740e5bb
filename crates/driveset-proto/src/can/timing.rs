//! Wire time of a classic CAN frame: owns [`frame_bits`] and
//! [`frame_time_ns`], for the simulator's wire timing and the engine's
//! timeouts. (ISO 11898-1 frame format; not in the ECS excerpt.)
//!
//! Counted: SOF through EOF plus the 3-bit intermission, i.e. the time from
//! one frame's start to the earliest start of the next. Data frame without
//! stuffing: 47 + 8n bits (11-bit id) or 67 + 8n bits (29-bit id); a remote
//! frame has no data field. Stuff bits occur from SOF to the end of the CRC
//! sequence (34 + 8n resp. 54 + 8n bits); [`Stuffing`] chooses how they are
//! counted. Error frames, overload frames and retransmissions are not
//! included.

use super::frame::{CanFrame, FrameError};

/// How stuff bits are counted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stuffing {
    /// None: the nominal lower bound.
    None,
    /// The worst case any frame of this format and length can take:
    /// `floor((g - 1) / 4)` for `g` stuffable bits (Davis/Tindell et al.,
    /// "Controller Area Network (CAN) schedulability analysis", 2007):
    /// 135 bits for an 11-bit frame with 8 bytes, 160 for a 29-bit one.
    /// Use it for timeouts.
    WorstCase,
    /// The stuff bits this very frame gets: the bit stream with its CRC-15
    /// is built and stuffed. Deterministic; use it to simulate the wire.
    Exact,
}

/// Bits on the wire for `frame` (SOF..EOF + 3 intermission bits).
pub fn frame_bits(frame: &CanFrame, stuffing: Stuffing) -> Result<u32, FrameError> {
    frame.validate()?;
    let data_bits = if frame.rtr {
        0
    } else {
        8 * u32::from(frame.len)
    };
    let stuffable = if frame.extended { 54 } else { 34 } + data_bits;
    let fixed = stuffable + 13; // CRC delim, ACK slot, ACK delim, EOF 7, IFS 3
    let stuff = match stuffing {
        Stuffing::None => 0,
        Stuffing::WorstCase => (stuffable - 1) / 4,
        Stuffing::Exact => exact_stuff_bits(frame),
    };
    Ok(fixed + stuff)
}

/// Nanoseconds for `bits` at `bits_per_second`, rounded up; `None` for a
/// zero bitrate.
pub fn frame_time_ns(bits: u32, bits_per_second: u32) -> Option<u64> {
    if bits_per_second == 0 {
        return None;
    }
    Some((u64::from(bits) * 1_000_000_000).div_ceil(u64::from(bits_per_second)))
}

/// Pushes the `n` low bits of `v`, MSB first.
fn push_bits(bits: &mut Vec<bool>, v: u32, n: u32) {
    for i in (0..n).rev() {
        bits.push((v >> i) & 1 != 0);
    }
}

/// The unstuffed bit stream SOF..CRC sequence.
fn stuffable_bits(frame: &CanFrame) -> Vec<bool> {
    let mut b = Vec::with_capacity(128);
    b.push(false); // SOF, dominant
    if frame.extended {
        push_bits(&mut b, frame.id >> 18, 11);
        b.push(true); // SRR
        b.push(true); // IDE
        push_bits(&mut b, frame.id & 0x3FFFF, 18);
        b.push(frame.rtr);
        b.push(false); // r1
        b.push(false); // r0
    } else {
        push_bits(&mut b, frame.id, 11);
        b.push(frame.rtr);
        b.push(false); // IDE
        b.push(false); // r0
    }
    push_bits(&mut b, u32::from(frame.len), 4);
    for &byte in frame.payload() {
        push_bits(&mut b, u32::from(byte), 8);
    }
    let mut crc: u16 = 0;
    for &bit in &b {
        let next = bit ^ (crc & 0x4000 != 0);
        crc = (crc << 1) & 0x7FFF;
        if next {
            crc ^= 0x4599;
        }
    }
    push_bits(&mut b, u32::from(crc), 15);
    b
}

/// Stuff bits: after five equal bits the transmitter inserts one of the
/// opposite level, which itself starts the next run. A stuff bit after the
/// last CRC bit is counted too.
fn exact_stuff_bits(frame: &CanFrame) -> u32 {
    let mut count = 0;
    let mut run = 0;
    let mut level = None;
    for bit in stuffable_bits(frame) {
        if Some(bit) == level {
            run += 1;
        } else {
            level = Some(bit);
            run = 1;
        }
        if run == 5 {
            count += 1;
            level = Some(!bit);
            run = 1;
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nominal_and_worst_case() {
        let f8 = CanFrame::new(0x605, &[0; 8]).unwrap();
        assert_eq!(frame_bits(&f8, Stuffing::None), Ok(111));
        assert_eq!(frame_bits(&f8, Stuffing::WorstCase), Ok(135));
        let e8 = CanFrame::new_extended(0x605, &[0; 8]).unwrap();
        assert_eq!(frame_bits(&e8, Stuffing::None), Ok(131));
        assert_eq!(frame_bits(&e8, Stuffing::WorstCase), Ok(160));
        let f0 = CanFrame::new(0x000, &[]).unwrap();
        assert_eq!(frame_bits(&f0, Stuffing::None), Ok(47));
        assert_eq!(frame_bits(&f0, Stuffing::WorstCase), Ok(55));
        let r = CanFrame::new_remote(0x605, 8).unwrap();
        assert_eq!(frame_bits(&r, Stuffing::None), Ok(47));
    }

    #[test]
    fn exact_stuffing() {
        // id 0, dlc 0: SOF..DLC are 19 dominant bits, the CRC of zeros is 0:
        // 34 dominant bits -> a stuff bit after every 5th: 6.
        let f0 = CanFrame::new(0x000, &[]).unwrap();
        assert_eq!(frame_bits(&f0, Stuffing::Exact), Ok(47 + 6));
        for f in [
            CanFrame::new(0x605, &[0x23, 0xF4, 0x5F, 0x00, 0x20, 0xA1, 0x07, 0x00]).unwrap(),
            CanFrame::new(0x7FF, &[0xFF; 8]).unwrap(),
            CanFrame::new_extended(0x1FFF_FFFF, &[0; 8]).unwrap(),
            CanFrame::new_remote_extended(0x123, 3).unwrap(),
        ] {
            let n = frame_bits(&f, Stuffing::None).unwrap();
            let e = frame_bits(&f, Stuffing::Exact).unwrap();
            let w = frame_bits(&f, Stuffing::WorstCase).unwrap();
            assert!(n <= e && e <= w, "{f:?}: {n} {e} {w}");
        }
    }

    #[test]
    fn time() {
        assert_eq!(frame_time_ns(135, 1_000_000), Some(135_000));
        assert_eq!(frame_time_ns(135, 125_000), Some(1_080_000));
        assert_eq!(frame_time_ns(1, 3), Some(333_333_334));
        assert_eq!(frame_time_ns(1, 0), None);
        let bad = CanFrame {
            len: 9,
            ..CanFrame::default()
        };
        assert_eq!(
            frame_bits(&bad, Stuffing::Exact),
            Err(FrameError::TooLong(9))
        );
    }
}
