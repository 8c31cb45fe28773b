//! Fault injection for any link: a seeded schedule of what goes wrong with the bytes in each
//! direction (dropped, duplicated, corrupted, split into small pieces, delayed, cut off), laid
//! over a [`Link`] of any transport (TCP, serial or in-process). Tests use it to show that for
//! any schedule a render ends with the exact image or with a typed error, never a wrong pixel,
//! a panic or a hang past its time-outs.

use crate::cluster::link::Link;
use std::io::{self, Read, Write};
use std::time::Duration;

/// What goes wrong with the bytes of one direction of a link.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Faults {
    /// Seeds the schedule: the same seed gives the same faults at the same bytes.
    pub seed: u64,
    /// Chance per byte that it is lost.
    pub drop: f64,
    /// Chance per byte that it arrives twice.
    pub duplicate: f64,
    /// Chance per byte that one of its bits is flipped.
    pub corrupt: f64,
    /// Bytes pass in pieces of 1 to 7 bytes.
    pub split: bool,
    /// Each piece waits this long.
    pub delay: Option<Duration>,
    /// The direction ends after this many bytes (end of stream, or a broken pipe).
    pub disconnect_after: Option<u64>,
}

/// A small seeded generator (xorshift64*): the schedule must repeat, not be secure.
#[derive(Clone, Debug)]
struct Dice(u64);

impl Dice {
    fn new(seed: u64) -> Self {
        Dice(seed ^ 0x9E37_79B9_7F4A_7C15 | 1)
    }

    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    /// True with chance `p`.
    fn chance(&mut self, p: f64) -> bool {
        let unit = (self.next() >> 11) as f64 / (1u64 << 53) as f64;
        p > 0.0 && unit < p
    }
}

/// One direction's faults as they happen.
#[derive(Debug)]
struct Schedule {
    faults: Faults,
    dice: Dice,
    passed: u64,
}

impl Schedule {
    fn new(faults: Faults) -> Self {
        Schedule {
            faults,
            dice: Dice::new(faults.seed),
            passed: 0,
        }
    }

    /// Whether the direction has been cut off.
    fn cut(&self) -> bool {
        self.faults
            .disconnect_after
            .is_some_and(|n| self.passed >= n)
    }

    /// `bytes` as they arrive: some lost, some twice, some damaged; up to the cut-off.
    fn apply(&mut self, bytes: &[u8], out: &mut Vec<u8>) {
        let f = self.faults;
        for &b in bytes {
            if self.cut() {
                return;
            }
            self.passed += 1;
            if self.dice.chance(f.drop) {
                continue;
            }
            let b = if self.dice.chance(f.corrupt) {
                b ^ (1 << (self.dice.next() % 8))
            } else {
                b
            };
            out.push(b);
            if self.dice.chance(f.duplicate) {
                out.push(b);
            }
        }
    }

    /// How many bytes the next piece may carry.
    fn piece(&mut self, len: usize) -> usize {
        if let Some(d) = self.faults.delay {
            std::thread::sleep(d);
        }
        if self.faults.split {
            len.min(1 + (self.dice.next() % 7) as usize)
        } else {
            len
        }
    }
}

/// The worker's bytes to the master, through a schedule.
struct FaultyReader {
    inner: Box<dyn Read + Send>,
    schedule: Schedule,
    pending: Vec<u8>,
}

impl Read for FaultyReader {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        while self.pending.is_empty() {
            if self.schedule.cut() {
                return Ok(0);
            }
            let mut raw = [0u8; 4096];
            let n = self.inner.read(&mut raw)?;
            if n == 0 {
                return Ok(0);
            }
            self.schedule.apply(&raw[..n], &mut self.pending);
        }
        let n = self.schedule.piece(buf.len().min(self.pending.len()));
        buf[..n].copy_from_slice(&self.pending[..n]);
        self.pending.drain(..n);
        Ok(n)
    }
}

/// The master's bytes to the worker, through a schedule.
struct FaultyWriter {
    inner: Box<dyn Write + Send>,
    schedule: Schedule,
}

impl Write for FaultyWriter {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        if self.schedule.cut() {
            return Err(io::ErrorKind::BrokenPipe.into());
        }
        let mut out = Vec::with_capacity(buf.len() + 8);
        self.schedule.apply(buf, &mut out);
        let mut rest = &out[..];
        while !rest.is_empty() {
            let n = self.schedule.piece(rest.len());
            self.inner.write_all(&rest[..n])?;
            self.inner.flush()?;
            rest = &rest[n..];
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

/// `link` with `down` applied to the master's bytes to the worker and `up` to the worker's
/// bytes to the master.
pub fn inject(link: Link, down: Faults, up: Faults) -> Link {
    Link {
        reader: Box::new(FaultyReader {
            inner: link.reader,
            schedule: Schedule::new(up),
            pending: Vec::new(),
        }),
        writer: Box::new(FaultyWriter {
            inner: link.writer,
            schedule: Schedule::new(down),
        }),
        ..link
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_seed_gives_the_same_faults() {
        let faults = Faults {
            seed: 7,
            drop: 0.1,
            duplicate: 0.1,
            corrupt: 0.1,
            disconnect_after: Some(900),
            ..Faults::default()
        };
        let bytes: Vec<u8> = (0..=255).cycle().take(1000).collect();
        let run = || {
            let mut out = Vec::new();
            Schedule::new(faults).apply(&bytes, &mut out);
            out
        };
        let (a, b) = (run(), run());
        assert_eq!(a, b);
        assert_ne!(a, bytes[..900], "some bytes were changed");
        assert!((700..1100).contains(&a.len()), "{}", a.len());
    }
}
