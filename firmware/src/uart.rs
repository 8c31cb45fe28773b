//! The CMSDK APB UART of ARM's MPS2 boards (UART0 at `0x4000_4000` on the AN386), a byte at a
//! time, as `embedded-io` `Read` and `Write`: the link the core's worker loop serves.

use core::convert::Infallible;
use core::ptr::{read_volatile, write_volatile};

/// Register offsets and bits.
const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTSTATUS: usize = 0x0C;
const BAUDDIV: usize = 0x10;
const TX_FULL: u32 = 1 << 0;
const RX_FULL: u32 = 1 << 1;
const TX_ENABLE: u32 = 1 << 0;
const RX_ENABLE: u32 = 1 << 1;
const RX_INTERRUPT_ENABLE: u32 = 1 << 3;
const RX_INTERRUPT: u32 = 1 << 1;

/// The NVIC line of UART0's receive interrupt on the MPS2 boards.
#[derive(Clone, Copy)]
struct Uart0Rx;

// SAFETY: 0 is the receive interrupt's line, within the NVIC's range.
unsafe impl cortex_m::interrupt::InterruptNumber for Uart0Rx {
    fn number(self) -> u16 {
        0
    }
}

/// A CMSDK UART at a base address.
pub struct Uart {
    base: usize,
}

impl Uart {
    /// The UART at `base`, with transmit and receive on (the divider must be at least 16).
    ///
    /// # Safety
    /// `base` must be a CMSDK UART that nothing else uses.
    pub unsafe fn new(base: usize, bauddiv: u32) -> Uart {
        let u = Uart { base };
        // SAFETY: the caller vouches for the address; these are the device's registers.
        unsafe {
            write_volatile((base + BAUDDIV) as *mut u32, bauddiv.max(16));
            write_volatile(
                (base + CTRL) as *mut u32,
                TX_ENABLE | RX_ENABLE | RX_INTERRUPT_ENABLE,
            );
        }
        // The receive interrupt only wakes `get`'s WFI: interrupts stay masked, so no handler
        // runs.
        cortex_m::interrupt::disable();
        // SAFETY: with interrupts masked, unmasking the line cannot start a handler.
        unsafe { cortex_m::peripheral::NVIC::unmask(Uart0Rx) };
        u
    }

    fn state(&self) -> u32 {
        // SAFETY: a register of the UART `new` was given.
        unsafe { read_volatile((self.base + STATE) as *const u32) }
    }

    /// Sends one byte, waiting while the transmitter is full.
    pub fn put(&mut self, b: u8) {
        while self.state() & TX_FULL != 0 {}
        // SAFETY: as `state`.
        unsafe { write_volatile((self.base + DATA) as *mut u32, u32::from(b)) }
    }

    /// The next received byte, waiting for one.
    fn get(&mut self) -> u8 {
        while self.state() & RX_FULL == 0 {
            // Clear the interrupt so WFI sleeps until the next byte (one that came since the
            // check above leaves it pending, and WFI returns at once).
            // SAFETY: as `state`.
            unsafe { write_volatile((self.base + INTSTATUS) as *mut u32, RX_INTERRUPT) };
            cortex_m::peripheral::NVIC::unpend(Uart0Rx);
            if self.state() & RX_FULL != 0 {
                break;
            }
            cortex_m::asm::wfi();
        }
        // SAFETY: as `state`.
        unsafe { read_volatile((self.base + DATA) as *const u32) as u8 }
    }
}

impl embedded_io::ErrorType for Uart {
    type Error = Infallible;
}

impl embedded_io::Read for Uart {
    /// Waits for a byte, then takes every byte already there (up to `buf`'s length).
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let Some(first) = buf.first_mut() else {
            return Ok(0);
        };
        *first = self.get();
        let mut n = 1;
        while n < buf.len() && self.state() & RX_FULL != 0 {
            buf[n] = self.get();
            n += 1;
        }
        Ok(n)
    }
}

impl embedded_io::Write for Uart {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        for &b in buf {
            self.put(b);
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}
