//! The camera emulator (host only): the firmware's [`Device`] loop, with the camera's buffer
//! sizes, behind a TCP listener (or any byte stream, e.g. a serial port).
//!
//! Connections are served one at a time, like the camera's single link; the loaded plan
//! carries over from one connection to the next.

use std::io::{self, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;

use crate::device::{Device, Link, SessionReport};
use crate::memory::HostStorage;

/// Any byte stream as the device's link; read time-outs are waited through.
pub struct IoLink<T>(pub T);

impl<T: Read + Write> Link for IoLink<T> {
    type Error = io::Error;

    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            match self.0.read(buf) {
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::Interrupted
                            | io::ErrorKind::TimedOut
                            | io::ErrorKind::WouldBlock
                    ) =>
                {
                    continue
                }
                other => return other,
            }
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.0.write_all(bytes)?;
        self.0.flush()
    }
}

/// Serves `stream` with a fresh camera (its own buffers, no plan) until it closes.
pub fn serve_stream<T: Read + Write>(stream: T) -> io::Result<SessionReport> {
    let mut storage = HostStorage::default();
    let mut device = Device::new(storage.memory());
    device.serve(&mut IoLink(stream))
}

/// Accepts connections on `listener` and serves each in turn, until `stop` is set (and one
/// more connection arrives to notice it). `log` hears about every connection.
pub fn serve_tcp(
    listener: &TcpListener,
    stop: &AtomicBool,
    mut log: impl FnMut(SocketAddr, &io::Result<SessionReport>),
) -> io::Result<()> {
    let mut storage = HostStorage::default();
    let mut device = Device::new(storage.memory());
    for stream in listener.incoming() {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let stream: TcpStream = stream?;
        let peer = stream.peer_addr()?;
        stream.set_nodelay(true)?;
        let result = device.serve(&mut IoLink(stream));
        log(peer, &result);
    }
    Ok(())
}

/// An emulator serving on a background thread; stopped when dropped.
pub struct Emulator {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<()>>>,
}

impl Emulator {
    /// Listens on `addr` (e.g. `127.0.0.1:0` for any free port) and serves in the background.
    pub fn spawn(addr: &str) -> io::Result<Emulator> {
        let listener = TcpListener::bind(addr)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("camera-emulator".into())
            .spawn(move || serve_tcp(&listener, &flag, |_, _| {}))?;
        Ok(Emulator {
            addr,
            stop,
            thread: Some(thread),
        })
    }

    /// The address it listens on.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// `tcp://host:port` of it, for `Client::connect`.
    pub fn url(&self) -> String {
        format!("tcp://{}", self.addr)
    }
}

impl Drop for Emulator {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::SeqCst);
        // Wake the accept loop so that it sees the flag.
        let _ = TcpStream::connect(self.addr);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
