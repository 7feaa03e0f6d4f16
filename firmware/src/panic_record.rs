//! The last panic, kept across a reset for the next greeting.
//!
//! The record lives in RAM that cortex-m-rt neither zeroes nor initializes (`.uninit`), so
//! it survives a system reset (not a power cycle). A magic word says whether it holds a
//! record: the panic handler writes the message and then the magic; the next boot reads it
//! once ([`take`]) and clears the magic, so a record is reported exactly once.

use core::cell::UnsafeCell;
use core::fmt;
use core::mem::MaybeUninit;

use heapless::String;
use supine_core::protocol::PANIC_MESSAGE_LEN;

/// Marks a valid record ("PNC!" little-endian).
const MAGIC: u32 = 0x2143_4E50;

#[repr(C)]
struct Record {
    magic: u32,
    len: u32,
    message: [u8; PANIC_MESSAGE_LEN],
}

/// Cell for the record, shared only between the panic handler (interrupts off, never
/// returns) and [`take`] at boot (single-threaded, before any interrupt is enabled).
struct RecordCell(UnsafeCell<MaybeUninit<Record>>);

// SAFETY: the firmware is single-core and the two accessors never run concurrently (see
// `RecordCell`).
unsafe impl Sync for RecordCell {}

#[unsafe(link_section = ".uninit.supine.panic_record")]
static RECORD: RecordCell = RecordCell(UnsafeCell::new(MaybeUninit::uninit()));

fn record() -> *mut Record {
    RECORD.0.get().cast::<Record>()
}

/// Writes `message` (truncated to [`PANIC_MESSAGE_LEN`] bytes on a character boundary)
/// and marks the record valid. Called by the panic handler only.
pub fn store(message: &fmt::Arguments<'_>) {
    let mut text: String<PANIC_MESSAGE_LEN> = String::new();
    let _ = fmt::write(&mut Truncating(&mut text), *message);
    let bytes = text.as_bytes();
    let ptr = record();
    // SAFETY: `ptr` points to the record in `.uninit` RAM, valid for writes of a `Record`
    // (plain integers and bytes: any bit pattern is valid); nothing else accesses it now.
    unsafe {
        let mut message = [0u8; PANIC_MESSAGE_LEN];
        message[..bytes.len()].copy_from_slice(bytes);
        core::ptr::write_volatile(
            ptr,
            Record {
                magic: 0,
                len: bytes.len() as u32,
                message,
            },
        );
        core::ptr::write_volatile(&raw mut (*ptr).magic, MAGIC);
    }
}

/// The message of a panic recorded before the last reset, if any; clears the record.
pub fn take() -> Option<String<PANIC_MESSAGE_LEN>> {
    let ptr = record();
    // SAFETY: as in `store`; the fields are integers and bytes, so reading RAM that was
    // never written (power-on garbage) is defined, and the magic rejects it.
    let (magic, len, message) = unsafe {
        let magic = core::ptr::read_volatile(&raw const (*ptr).magic);
        let len = core::ptr::read_volatile(&raw const (*ptr).len);
        let message = core::ptr::read_volatile(&raw const (*ptr).message);
        core::ptr::write_volatile(&raw mut (*ptr).magic, 0);
        (magic, len, message)
    };
    if magic != MAGIC {
        return None;
    }
    let bytes = message.get(..len as usize)?;
    let text = core::str::from_utf8(bytes).ok()?;
    let mut out = String::new();
    out.push_str(text).ok()?;
    Some(out)
}

/// Writes into a fixed string, silently cutting what does not fit.
struct Truncating<'a>(&'a mut String<PANIC_MESSAGE_LEN>);

impl fmt::Write for Truncating<'_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for c in s.chars() {
            if self.0.push(c).is_err() {
                break;
            }
        }
        Ok(())
    }
}
