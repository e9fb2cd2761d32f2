//! ARM semihosting (AArch32): console output, host files, exit status, host clock.
//!
//! A semihosting call is `svc #0x123456` in ARM state with the operation number in r0 and a
//! pointer to the argument block (or the single argument) in r1; the result comes back in r0.
//! QEMU implements it with `-semihosting` (`target=native` unless a gdb is attached); file
//! paths are relative to QEMU's working directory. On real hardware a debugger (OpenOCD,
//! Lauterbach, ...) must catch the SVC; without one the SVC vector is taken, and it answers
//! -1 (src/arm/start.rs): every call then fails, and [`host_present`] says so once, so that
//! the firmware boots into its board mode (console on UART1, serving over Ethernet).
//!
//! Exit status as QEMU (7.2, and later) maps it to its own process exit code:
//! - `SYS_EXIT` (0x18) in A32 takes only a reason code: `ADP_Stopped_ApplicationExit`
//!   (0x20026) -> exit code 0, any other reason -> exit code 1.
//! - `SYS_EXIT_EXTENDED` (0x20) takes a block `{reason, subcode}`: with reason 0x20026 QEMU
//!   exits with `subcode` as its exit code. [`exit`] uses it for non-zero codes and falls back
//!   to `SYS_EXIT` with `ADP_Stopped_RunTimeErrorUnknown` (QEMU: exit code 1) if the host
//!   does not implement it.

use core::arch::asm;
use core::sync::atomic::{AtomicU8, Ordering};

/// Semihosting operation numbers (ARM "Semihosting for AArch32 and AArch64", v2).
pub mod op {
    pub const SYS_OPEN: u32 = 0x01;
    pub const SYS_CLOSE: u32 = 0x02;
    pub const SYS_WRITEC: u32 = 0x03;
    pub const SYS_WRITE0: u32 = 0x04;
    pub const SYS_WRITE: u32 = 0x05;
    pub const SYS_REMOVE: u32 = 0x0E;
    pub const SYS_RENAME: u32 = 0x0F;
    pub const SYS_READ: u32 = 0x06;
    pub const SYS_SEEK: u32 = 0x0A;
    pub const SYS_FLEN: u32 = 0x0C;
    pub const SYS_CLOCK: u32 = 0x10;
    pub const SYS_ERRNO: u32 = 0x13;
    pub const SYS_EXIT: u32 = 0x18;
    pub const SYS_EXIT_EXTENDED: u32 = 0x20;
    pub const SYS_ELAPSED: u32 = 0x30;
    pub const SYS_TICKFREQ: u32 = 0x31;
}

/// `ADP_Stopped_ApplicationExit`: normal termination.
pub const ADP_STOPPED_APPLICATION_EXIT: u32 = 0x20026;
/// `ADP_Stopped_RunTimeErrorUnknown`: abnormal termination (QEMU exits with code 1).
pub const ADP_STOPPED_RUNTIME_ERROR_UNKNOWN: u32 = 0x20023;

/// Raw semihosting call.
///
/// # Safety
/// `arg` must be what operation `op` expects (usually a pointer to a valid argument block
/// whose pointers are valid for the access the operation makes).
#[inline(always)]
pub unsafe fn call(op: u32, arg: usize) -> isize {
    let ret: isize;
    // LR is declared clobbered: under a debugger the SVC may really be taken in SVC mode.
    asm!(
        "svc #0x123456",
        inlateout("r0") op as usize => ret,
        in("r1") arg,
        out("lr") _,
        options(nostack, preserves_flags)
    );
    ret
}

/// Whether a semihosting host answers (QEMU's `-semihosting` or a debugger), asked once.
///
/// `SYS_ERRNO` returns the host's errno, never negative; with nobody behind the SVC, the
/// vector answers -1 (src/arm/start.rs). A debugger attached later is not noticed: the
/// answer is kept, so that the firmware's mode does not change under it.
pub fn host_present() -> bool {
    const UNKNOWN: u8 = 0;
    const PRESENT: u8 = 1;
    const ABSENT: u8 = 2;
    static HOST: AtomicU8 = AtomicU8::new(UNKNOWN);
    match HOST.load(Ordering::Relaxed) {
        UNKNOWN => {
            // SAFETY: SYS_ERRNO takes no argument.
            let present = unsafe { call(op::SYS_ERRNO, 0) } >= 0;
            HOST.store(if present { PRESENT } else { ABSENT }, Ordering::Relaxed);
            present
        }
        h => h == PRESENT,
    }
}

/// Write raw bytes to the host console (QEMU's stdout). NULs are skipped.
pub fn write_bytes(bytes: &[u8]) {
    // SYS_WRITE0 wants a NUL-terminated string: send the text in NUL-terminated chunks.
    let mut buf = [0u8; 129];
    let mut n = 0;
    for &b in bytes {
        if b == 0 {
            continue;
        }
        buf[n] = b;
        n += 1;
        if n == buf.len() - 1 {
            buf[n] = 0;
            unsafe { call(op::SYS_WRITE0, buf.as_ptr() as usize) };
            n = 0;
        }
    }
    if n > 0 {
        buf[n] = 0;
        unsafe { call(op::SYS_WRITE0, buf.as_ptr() as usize) };
    }
}

/// Write a string to the host console.
pub fn write_str(s: &str) {
    write_bytes(s.as_bytes());
}

/// Host error: the operation failed; `errno` is the host's errno (SYS_ERRNO) at that time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Error {
    pub errno: i32,
}

impl Error {
    fn last() -> Self {
        Error {
            errno: unsafe { call(op::SYS_ERRNO, 0) } as i32,
        }
    }
}

/// Longest host path accepted by [`File::open`] (the path is copied to add a NUL).
pub const MAX_PATH: usize = 255;

/// File open modes (the ISO C `fopen` mode index that SYS_OPEN takes).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum Mode {
    /// "rb"
    Read = 1,
    /// "r+b"
    ReadWrite = 3,
    /// "wb": create or truncate
    Write = 5,
    /// "ab"
    Append = 9,
}

/// A host file opened through semihosting; closed on drop.
#[derive(Debug)]
pub struct File {
    handle: isize,
}

impl File {
    /// Open `path` (relative to QEMU's working directory) with `mode`.
    /// `":tt"` is the host console (Read: stdin, Write: stdout).
    pub fn open(path: &str, mode: Mode) -> Result<File, Error> {
        if path.len() > MAX_PATH || path.as_bytes().contains(&0) {
            return Err(Error {
                errno: 36, /* ENAMETOOLONG / bad name */
            });
        }
        let mut name = [0u8; MAX_PATH + 1];
        name[..path.len()].copy_from_slice(path.as_bytes());
        let block: [usize; 3] = [name.as_ptr() as usize, mode as usize, path.len()];
        let h = unsafe { call(op::SYS_OPEN, block.as_ptr() as usize) };
        if h < 0 {
            Err(Error::last())
        } else {
            Ok(File { handle: h })
        }
    }

    /// The raw semihosting handle.
    pub fn handle(&self) -> isize {
        self.handle
    }

    /// Write all of `data`.
    pub fn write_all(&mut self, data: &[u8]) -> Result<(), Error> {
        let block: [usize; 3] = [self.handle as usize, data.as_ptr() as usize, data.len()];
        // Returns the number of bytes NOT written.
        let not_written = unsafe { call(op::SYS_WRITE, block.as_ptr() as usize) };
        if not_written == 0 {
            Ok(())
        } else {
            Err(Error::last())
        }
    }

    /// Read up to `buf.len()` bytes; returns how many were read (0 at end of file).
    pub fn read(&mut self, buf: &mut [u8]) -> Result<usize, Error> {
        let block: [usize; 3] = [self.handle as usize, buf.as_mut_ptr() as usize, buf.len()];
        // Returns the number of bytes NOT read (buf.len() at EOF); -1 on error in some hosts.
        let not_read = unsafe { call(op::SYS_READ, block.as_ptr() as usize) };
        if not_read < 0 || not_read as usize > buf.len() {
            Err(Error::last())
        } else {
            Ok(buf.len() - not_read as usize)
        }
    }

    /// Fill `buf` completely or fail (short file -> `Error { errno: 0 }`... see errno).
    pub fn read_exact(&mut self, mut buf: &mut [u8]) -> Result<(), Error> {
        while !buf.is_empty() {
            let n = self.read(buf)?;
            if n == 0 {
                return Err(Error { errno: 0 });
            }
            buf = &mut buf[n..];
        }
        Ok(())
    }

    /// Length of the file in bytes.
    pub fn len(&self) -> Result<usize, Error> {
        let block: [usize; 1] = [self.handle as usize];
        let n = unsafe { call(op::SYS_FLEN, block.as_ptr() as usize) };
        if n < 0 {
            Err(Error::last())
        } else {
            Ok(n as usize)
        }
    }

    /// Seek to an absolute position.
    pub fn seek(&mut self, pos: usize) -> Result<(), Error> {
        let block: [usize; 2] = [self.handle as usize, pos];
        if unsafe { call(op::SYS_SEEK, block.as_ptr() as usize) } == 0 {
            Ok(())
        } else {
            Err(Error::last())
        }
    }
}

impl Drop for File {
    fn drop(&mut self) {
        let block: [usize; 1] = [self.handle as usize];
        unsafe { call(op::SYS_CLOSE, block.as_ptr() as usize) };
    }
}

/// A host path with a NUL added, for the calls that take one.
fn c_path(path: &str) -> Result<[u8; MAX_PATH + 1], Error> {
    if path.len() > MAX_PATH || path.as_bytes().contains(&0) {
        return Err(Error { errno: 36 });
    }
    let mut name = [0u8; MAX_PATH + 1];
    name[..path.len()].copy_from_slice(path.as_bytes());
    Ok(name)
}

/// Renames host file `from` to `to` (relative to QEMU's working directory), replacing `to`.
pub fn rename(from: &str, to: &str) -> Result<(), Error> {
    let (a, b) = (c_path(from)?, c_path(to)?);
    let block: [usize; 4] = [
        a.as_ptr() as usize,
        from.len(),
        b.as_ptr() as usize,
        to.len(),
    ];
    if unsafe { call(op::SYS_RENAME, block.as_ptr() as usize) } == 0 {
        Ok(())
    } else {
        Err(Error::last())
    }
}

/// Deletes host file `path`.
pub fn remove(path: &str) -> Result<(), Error> {
    let name = c_path(path)?;
    let block: [usize; 2] = [name.as_ptr() as usize, path.len()];
    if unsafe { call(op::SYS_REMOVE, block.as_ptr() as usize) } == 0 {
        Ok(())
    } else {
        Err(Error::last())
    }
}

/// Centiseconds since the program started (SYS_CLOCK; QEMU: host real time).
pub fn clock_centis() -> isize {
    unsafe { call(op::SYS_CLOCK, 0) }
}

/// Terminate the program: QEMU exits with `code` (0 = success).
pub fn exit(code: u8) -> ! {
    if code == 0 {
        unsafe { call(op::SYS_EXIT, ADP_STOPPED_APPLICATION_EXIT as usize) };
    } else {
        let block: [usize; 2] = [ADP_STOPPED_APPLICATION_EXIT as usize, code as usize];
        unsafe { call(op::SYS_EXIT_EXTENDED, block.as_ptr() as usize) };
        // Host without SYS_EXIT_EXTENDED: still a failure (QEMU maps this reason to 1).
        unsafe { call(op::SYS_EXIT, ADP_STOPPED_RUNTIME_ERROR_UNKNOWN as usize) };
    }
    // No semihosting host took the exit: stop here.
    loop {
        unsafe { asm!("wfi", options(nomem, nostack, preserves_flags)) };
    }
}

/// Exit code used by the panic handler (like Rust's std on a panic in `main`).
pub const EXIT_PANIC: u8 = 101;
/// Exit code used when an unexpected CPU exception (abort, undefined instruction) is taken.
pub const EXIT_EXCEPTION: u8 = 102;
