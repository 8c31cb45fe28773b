//! Strahl's worker on a Cortex-M4F: the unchanged `strahl-core` worker loop ([`serve`]) over the
//! board's UART ([`uart`]), with a fixed heap for the scene and its octree.
//!
//! The board announces the heap it can give a scene in its `Hello` (`scene_memory`), so a
//! master refuses it a scene that would not fit and gives its lines to the others. A shared
//! secret is built in (`STRAHL_FIRMWARE_SECRET_FILE`), and the handshake's nonces come from
//! [`entropy`]. A panic
//! writes its message to the UART (the master drops it as a bad frame and loses the worker)
//! and halts. Built for QEMU's `mps2-an386` (`memory.x`, UART0 at `0x4000_4000`); README,
//! "A microcontroller in the cluster", says how to build it for a real board of the family.
#![no_std]
#![no_main]

extern crate alloc;

mod entropy;
mod uart;

use core::mem::MaybeUninit;
use cortex_m_rt::entry;
use embedded_alloc::LlffHeap as Heap;
use strahl_core::wire::auth::MIN_SECRET_LEN;
use strahl_core::worker::{serve, NodeInfo, SceneCache};

/// UART0 of the MPS2 AN386.
const UART0: usize = 0x4000_4000;

/// Bytes of RAM given to the heap (the rest of the 4 MiB, 256 KiB, holds the stack and statics).
const HEAP_SIZE: usize = 3840 * 1024;

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
    let _ = core::fmt::Write::write_fmt(
        &mut Reporter(&mut link),
        format_args!("\nstrahl firmware panic: {info}\n"),
    );
    #[cfg(feature = "semihosting")]
    cortex_m_semihosting::hprintln!("strahl firmware panic: {}", info);
    loop {
        cortex_m::asm::wfi();
    }
}

/// `core::fmt::Write` over the UART, for the panic message.
struct Reporter<'a>(&'a mut uart::Uart);

impl core::fmt::Write for Reporter<'_> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        for b in s.bytes() {
            self.0.put(b);
        }
        Ok(())
    }
}
