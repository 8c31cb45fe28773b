//! Strahl's worker on a Cortex-M4F: the unchanged `strahl-core` worker loop ([`serve`]) over the
//! board's UART ([`uart`]), with a fixed heap for the scene and its octree.
//!
//! The board announces the heap it can give a scene in its `Hello` (`scene_memory`), so a
//! master refuses it a scene that would not fit and gives its lines to the others. A shared
//! secret is built in (`STRAHL_FIRMWARE_SECRET_FILE`), and the handshake's nonces come from
//! [`entropy`]. A panic sends its message to the master as the protocol's `Panicked` frame,
//! built without the heap (the master drops the worker at once and shows why), and halts.
//! Built for QEMU's `mps2-an386` (`memory.x`, UART0 at `0x4000_4000`, a heap of
//! `STRAHL_FIRMWARE_HEAP_KIB`); README, "A microcontroller in the cluster", says how to build
//! it for a real board of the family.
#![no_std]
#![no_main]

extern crate alloc;

mod entropy;
mod uart;

use core::mem::MaybeUninit;
use cortex_m_rt::entry;
use embedded_alloc::LlffHeap as Heap;
use strahl_core::wire::auth::MIN_SECRET_LEN;
use strahl_core::wire::frame::encode_into;
use strahl_core::wire::message::WorkerMessage;
use strahl_core::wire::{frame_len, MAX_PANIC_LEN};
use strahl_core::worker::{serve, NodeInfo, SceneCache};

/// UART0 of the MPS2 AN386.
const UART0: usize = 0x4000_4000;

/// Bytes of RAM given to the heap: `STRAHL_FIRMWARE_HEAP_KIB` KiB when the firmware was built,
/// by default 3840 (the rest of the board's 4 MiB, 256 KiB, holds the stack and statics).
const HEAP_SIZE: usize = include!(concat!(env!("OUT_DIR"), "/heap_size.rs"));

/// What the worker keeps for itself out of the heap (buffers of the session, the line).
const HEAP_RESERVE: usize = 256 * 1024;

#[global_allocator]
static HEAP: Heap = Heap::empty();

/// The shared secret masters must prove they hold: the file named by
/// `STRAHL_FIRMWARE_SECRET_FILE` when the firmware was built (its trailing line break dropped, as
/// `strahl` reads a secret file), or none (empty).
const SECRET: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/secret"));

const _: () = assert!(
    SECRET.is_empty() || SECRET.len() >= MIN_SECRET_LEN,
    "the secret in STRAHL_FIRMWARE_SECRET_FILE is shorter than MIN_SECRET_LEN bytes"
);

/// The heap's memory.
static mut HEAP_MEM: [MaybeUninit<u8>; HEAP_SIZE] = [MaybeUninit::uninit(); HEAP_SIZE];

#[entry]
fn main() -> ! {
    // SAFETY: `entry` runs once; the heap is handed its memory before any allocation, and
    // nothing else touches `HEAP_MEM`.
    unsafe { HEAP.init(&raw mut HEAP_MEM as usize, HEAP_SIZE) }
    if let Some(mut p) = cortex_m::Peripherals::take() {
        entropy::start(&mut p.SYST);
    }
    // SAFETY: UART0 is this board's, and only this worker uses it.
    let mut link = entropy::Stirred(unsafe { uart::Uart::new(UART0, 16) });
    let node = NodeInfo {
        name: "mps2-an386",
        arch: "thumbv7em",
        scene_memory: (HEAP_SIZE - HEAP_RESERVE) as u64,
        threads: 1,
        secret: (!SECRET.is_empty()).then_some(SECRET),
        nonce: entropy::nonce,
    };
    let mut cache = SceneCache::new();
    loop {
        // A session ends (the master said so, or its link broke): wait for the next master.
        let _ = serve(&mut link, &node, &mut cache);
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    // SAFETY: the worker loop is gone; the UART is this handler's now.
    let mut link = unsafe { uart::Uart::new(UART0, 16) };
    let mut words = LastWords {
        text: [0; MAX_PANIC_LEN],
        len: 0,
    };
    // A message too long is cut: what fits is sent.
    let _ = core::fmt::Write::write_fmt(&mut words, format_args!("{info}"));
    let message = core::str::from_utf8(&words.text[..words.len]).unwrap_or("");
    let mut payload = [0u8; MAX_PANIC_LEN + 16];
    let mut frame = [0u8; frame_len(MAX_PANIC_LEN + 16)];
    // The frame's leading 0x00 ends whatever frame the panic cut short.
    if let Ok(bytes) = encode_into(
        &WorkerMessage::Panicked { message },
        &mut payload,
        &mut frame,
    ) {
        for &b in bytes {
            link.put(b);
        }
    }
    #[cfg(feature = "semihosting")]
    cortex_m_semihosting::hprintln!("strahl firmware panic: {}", info);
    loop {
        cortex_m::asm::wfi();
    }
}

/// The panic message, on one line (line breaks become spaces), cut at a character boundary to
/// [`MAX_PANIC_LEN`] bytes.
struct LastWords {
    text: [u8; MAX_PANIC_LEN],
    len: usize,
}

impl core::fmt::Write for LastWords {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for c in s.chars() {
            let c = if c == '\n' { ' ' } else { c };
            let mut utf8 = [0u8; 4];
            let bytes = c.encode_utf8(&mut utf8).as_bytes();
            let end = self.len + bytes.len();
            let Some(room) = self.text.get_mut(self.len..end) else {
                return Err(core::fmt::Error);
            };
            room.copy_from_slice(bytes);
            self.len = end;
        }
        Ok(())
    }
}
