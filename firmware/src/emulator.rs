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
use std::time::{Duration, Instant};

use crate::device::{Device, Link, SessionReport, Waiting};
use crate::memory::HostStorage;

/// How long the camera waits on a quiet link before it gives the link up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Timeouts {
    /// Silence inside a frame (a host that stopped mid-request, a cut cable).
    pub frame: Duration,
    /// Silence between frames; `None` waits for ever (a serial port, where no other host
    /// can come).
    pub idle: Option<Duration>,
    /// Silence between frames after which the link is handed to a host waiting to connect.
    pub hand_over: Duration,
}

impl Default for Timeouts {
    /// 5 s inside a frame, 120 s between frames, the link handed over after 1 s between
    /// frames: a host scanning sends its next row within milliseconds.
    fn default() -> Self {
        Timeouts {
            frame: Duration::from_secs(5),
            idle: Some(Duration::from_secs(120)),
            hand_over: Duration::from_secs(1),
        }
    }
}

/// How often a quiet link looks at its limits (the stream's read time-out).
pub const POLL: Duration = Duration::from_millis(50);

/// Any byte stream as the device's link, with [`Timeouts`]. The stream's reads must time
/// out (every [`POLL`], say) for the limits to be looked at; `waiting_host` says whether
/// another host waits for the camera.
pub struct IoLink<'p, T> {
    stream: T,
    timeouts: Timeouts,
    waiting_host: Option<&'p mut dyn FnMut() -> bool>,
}

impl<'p, T> IoLink<'p, T> {
    /// `stream` with these limits, no other host to hand over to.
    pub fn new(stream: T, timeouts: Timeouts) -> Self {
        IoLink {
            stream,
            timeouts,
            waiting_host: None,
        }
    }

    /// Hands the link over, once quiet between frames for [`Timeouts::hand_over`], when
    /// `waiting_host()` says another host waits.
    pub fn handing_over_to(mut self, waiting_host: &'p mut dyn FnMut() -> bool) -> Self {
        self.waiting_host = Some(waiting_host);
        self
    }
}

/// The error a link given up on ends [`Device::serve`] with.
fn given_up(kind: io::ErrorKind, why: String) -> io::Error {
    io::Error::new(kind, why)
}

impl<T: Read + Write> Link for IoLink<'_, T> {
    type Error = io::Error;

    fn read(&mut self, buf: &mut [u8], waiting: Waiting) -> io::Result<usize> {
        let quiet_since = Instant::now();
        loop {
            match self.stream.read(buf) {
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                    ) =>
                {
                    let quiet = quiet_since.elapsed();
                    let t = &self.timeouts;
                    match waiting {
                        Waiting::RestOfFrame if quiet >= t.frame => {
                            return Err(given_up(
                                io::ErrorKind::TimedOut,
                                format!(
                                    "timed out: no byte for {:.1} s inside a frame",
                                    t.frame.as_secs_f64()
                                ),
                            ))
                        }
                        Waiting::NextFrame if t.idle.is_some_and(|idle| quiet >= idle) => {
                            return Err(given_up(
                                io::ErrorKind::TimedOut,
                                format!("timed out: idle for {:.1} s", quiet.as_secs_f64()),
                            ))
                        }
                        Waiting::NextFrame if quiet >= t.hand_over => {
                            if let Some(waiting_host) = self.waiting_host.as_mut() {
                                if waiting_host() {
                                    return Err(given_up(
                                        io::ErrorKind::ConnectionAborted,
                                        format!(
                                            "handed over to a waiting host after {:.1} s idle",
                                            quiet.as_secs_f64()
                                        ),
                                    ));
                                }
                            }
                        }
                        _ => {}
                    }
                }
                other => return other,
            }
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes)?;
        self.stream.flush()
    }
}

/// Serves `stream` (e.g. a serial port whose reads time out every [`POLL`]) with a fresh
/// camera until it closes or fails. A frame left half sent for [`Timeouts::frame`] ends that
/// session, not the link: the camera then waits for the next request, its plan kept.
/// Returns what the last session saw.
pub fn serve_stream<T: Read + Write>(stream: T, timeouts: Timeouts) -> io::Result<SessionReport> {
    let mut storage = HostStorage::default();
    let mut device = Device::new(storage.memory());
    let mut link = IoLink::new(stream, timeouts);
    loop {
        match device.serve(&mut link) {
            Err(e) if e.kind() == io::ErrorKind::TimedOut => continue,
            other => return other,
        }
    }
}

/// Accepts connections on `listener` and serves each in turn, until `stop` is set (and one
/// more connection arrives to notice it). A connection that fails — reset, timed out, handed
/// over to a waiting host — ends alone: the camera goes on with the next, its plan kept.
/// `log` hears about every connection (its peer, when the socket still knows it) and every
/// failed accept.
pub fn serve_tcp(
    listener: &TcpListener,
    timeouts: Timeouts,
    stop: &AtomicBool,
    mut log: impl FnMut(Option<SocketAddr>, &io::Result<SessionReport>),
) -> io::Result<()> {
    let mut storage = HostStorage::default();
    let mut device = Device::new(storage.memory());
    let mut next: Option<TcpStream> = None;
    loop {
        let stream = match next.take() {
            Some(s) => s,
            None => match listener.accept() {
                Ok((s, _)) => s,
                Err(e) => {
                    if stop.load(Ordering::SeqCst) {
                        break;
                    }
                    log(None, &Err(e));
                    // Out of descriptors, say: give the system a moment.
                    std::thread::sleep(POLL);
                    continue;
                }
            },
        };
        if stop.load(Ordering::SeqCst) {
            break;
        }
        let peer = stream.peer_addr().ok();
        let result = configure(&stream, &timeouts).and_then(|()| {
            let mut waiting = || stop.load(Ordering::SeqCst) || waiting_host(listener, &mut next);
            let mut link = IoLink::new(&stream, timeouts).handing_over_to(&mut waiting);
            device.serve(&mut link)
        });
        log(peer, &result);
    }
    Ok(())
}

fn configure(stream: &TcpStream, timeouts: &Timeouts) -> io::Result<()> {
    stream.set_nonblocking(false)?;
    stream.set_nodelay(true)?;
    stream.set_read_timeout(Some(POLL))?;
    // A host that does not read its answers is given up like one that stopped sending.
    stream.set_write_timeout(Some(timeouts.frame))
}

/// Whether a host waits to connect; if so its connection is taken into `next`.
fn waiting_host(listener: &TcpListener, next: &mut Option<TcpStream>) -> bool {
    if next.is_some() {
        return true;
    }
    if listener.set_nonblocking(true).is_err() {
        return false;
    }
    let accepted = listener.accept();
    let _ = listener.set_nonblocking(false);
    match accepted {
        Ok((s, _)) => {
            *next = Some(s);
            true
        }
        Err(_) => false,
    }
}

/// An emulator serving on a background thread; stopped when dropped.
pub struct Emulator {
    addr: SocketAddr,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<io::Result<()>>>,
}

impl Emulator {
    /// Listens on `addr` (e.g. `127.0.0.1:0` for any free port) and serves in the background
    /// with the default [`Timeouts`].
    pub fn spawn(addr: &str) -> io::Result<Emulator> {
        Emulator::spawn_with(addr, Timeouts::default())
    }

    /// The same with these limits.
    pub fn spawn_with(addr: &str, timeouts: Timeouts) -> io::Result<Emulator> {
        let listener = TcpListener::bind(addr)?;
        let addr = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("camera-emulator".into())
            .spawn(move || serve_tcp(&listener, timeouts, &flag, |_, _| {}))?;
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
