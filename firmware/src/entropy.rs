//! Nonces for the handshake on a board without a random source.
//!
//! A worker's nonce must not repeat, or a recorded session could be replayed to it (a master's
//! proof covers both nonces). A counter alone repeats after every reset, and this board's
//! cycle counter is not emulated. What cannot be predicted is when bytes arrive: the link is
//! driven by another machine's clock and scheduler. [`Stirred`] samples the free-running
//! SysTick counter (24 bits at the core clock) after every read from the link and folds each
//! sample into a pool; [`nonce`] is the SHA-256 of the pool, the handshake count and the time.
//! The master's `Hello` alone is about 50 bytes, each arriving at its own time. A board with a
//! hardware RNG should take its nonces from that instead.

use core::sync::atomic::{AtomicU32, Ordering};
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use strahl_core::wire::auth::Nonce;
use strahl_core::wire::scene_blob::digest;

/// Words of the pool.
const POOL_WORDS: usize = 8;

static POOL: [AtomicU32; POOL_WORDS] = [const { AtomicU32::new(0) }; POOL_WORDS];

/// Samples folded in so far (which word the next goes to).
static SAMPLES: AtomicU32 = AtomicU32::new(0);

/// Handshakes so far.
static HANDSHAKES: AtomicU32 = AtomicU32::new(0);

/// Starts SysTick counting down from its largest reload, never interrupting.
pub fn start(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.clear_current();
    syst.enable_counter();
}

/// Folds the time now, and `word`, into the pool.
fn stir(word: u32) {
    let i = SAMPLES.fetch_add(1, Ordering::Relaxed) as usize % POOL_WORDS;
    let sample = SYST::get_current() ^ word.rotate_left(24);
    let old = POOL[i].load(Ordering::Relaxed);
    POOL[i].store(old.rotate_left(7) ^ sample, Ordering::Relaxed);
}

/// A fresh nonce for a handshake.
pub fn nonce() -> Nonce {
    let mut bytes = [0u8; 4 * (POOL_WORDS + 2)];
    let words = POOL.iter().map(|w| w.load(Ordering::Relaxed)).chain([
        HANDSHAKES.fetch_add(1, Ordering::Relaxed),
        SYST::get_current(),
    ]);
    for (chunk, w) in bytes.chunks_exact_mut(4).zip(words) {
        chunk.copy_from_slice(&w.to_le_bytes());
    }
    digest(&bytes)
}

/// A link whose reads stir the pool with the time each one returned.
pub struct Stirred<L>(pub L);

impl<L: embedded_io::ErrorType> embedded_io::ErrorType for Stirred<L> {
    type Error = L::Error;
}

impl<L: embedded_io::Read> embedded_io::Read for Stirred<L> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let n = self.0.read(buf)?;
        stir(buf.first().map_or(0, |&b| u32::from(b)) ^ n as u32);
        Ok(n)
    }
}

impl<L: embedded_io::Write> embedded_io::Write for Stirred<L> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0.write(buf)
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        self.0.flush()
    }
}
