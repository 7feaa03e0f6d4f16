//! The host's files and command line, through semihosting (QEMU runs every mps2 image
//! with `-semihosting-config enable=on,target=native`).
//!
//! Why a replay reads its input from a file: QEMU's CMSDK UART hands the image one byte
//! per turn of QEMU's I/O thread, about 40 us a byte whatever the baud rate, which held
//! `supine replay` near 4 times real time (BENCHMARKS.md, "Replay throughput"). A replay's
//! frames are all known before it starts, so the host writes them to a file and the image
//! reads them a block per call ([`crate::replay_link`]): the same frames, decoder and
//! pipeline, without the one-byte bottleneck. Not for the Black Pill: semihosting without
//! a debugger stops the core.

use cortex_m_semihosting::nr;

/// Longest command line and file path the images take, bytes.
pub const COMMAND_LINE_LEN: usize = 256;

/// The semihosting command line (the `arg=` items of `-semihosting-config`, joined by
/// spaces), read into `buf`; `None` when there is none. Bytes, not `str`: the product
/// image has no other use for UTF-8 checks, and they cost flash.
pub fn command_line(buf: &mut [u8; COMMAND_LINE_LEN]) -> Option<&[u8]> {
    // SYS_GET_CMDLINE's parameter block: buffer address and length (updated by the host).
    let mut block = [buf.as_mut_ptr() as usize, buf.len()];
    // SAFETY: the block and the buffer outlive the call, which writes at most `buf.len()`
    // bytes into `buf` and the used length into `block[1]`.
    let status =
        unsafe { cortex_m_semihosting::syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
    if status != 0 {
        return None;
    }
    let line = buf.get(..block[1])?;
    Some(line.strip_suffix(&[0]).unwrap_or(line))
}

/// Where the value of `flag` starts in `line`: after the flag and one space. The value runs
/// to the line's end, so a path may hold spaces.
pub fn value_start(line: &[u8], flag: &[u8]) -> Option<usize> {
    let at = line.windows(flag.len()).position(|w| w == flag)? + flag.len();
    (line.get(at) == Some(&b' ')).then_some(at + 1)
}

/// A host file open for reading; closed when dropped.
pub struct HostFile {
    handle: usize,
}

impl HostFile {
    /// Opens for binary reading the file named by `path_nul`: the name, then a NUL byte.
    pub fn open(path_nul: &[u8]) -> Option<Self> {
        let (0, name) = path_nul.split_last()? else {
            return None;
        };
        // The host wants the address of a NUL-terminated name and its length without it.
        let block = [path_nul.as_ptr() as usize, nr::open::R_BINARY, name.len()];
        // SAFETY: the block and the name outlive the call, which only reads them.
        let handle = unsafe { cortex_m_semihosting::syscall(nr::OPEN, &block) };
        // -1 is the host's "could not open".
        (handle != usize::MAX).then_some(Self { handle })
    }

    /// Reads into `buf`; returns the bytes read, 0 at the end of the file or on an error.
    pub fn read(&mut self, buf: &mut [u8]) -> usize {
        let block = [self.handle, buf.as_mut_ptr() as usize, buf.len()];
        // SAFETY: the block and the buffer outlive the call, which writes at most
        // `buf.len()` bytes into `buf`.
        let not_read = unsafe { cortex_m_semihosting::syscall(nr::READ, &block) };
        // The host answers with the bytes it did not read (-1 on an error: nothing read).
        buf.len().saturating_sub(not_read)
    }
}

impl Drop for HostFile {
    fn drop(&mut self) {
        // SAFETY: the handle came from SYS_OPEN and is closed once, here.
        unsafe { cortex_m_semihosting::syscall1(nr::CLOSE, self.handle) };
    }
}
