//! TCP/IP over GEM0 with smoltcp: the camera's Ethernet link to the host.
//!
//! One IPv4 address (static: `layout::NetConfig`, QEMU user networking's 10.0.2.15/24 by
//! default; or leased from a DHCP server, kept up to date as the lease renews, see
//! [`Net::new`]), the protocol's port (`fsm_protocol::DEFAULT_TCP_PORT`, 7070) served to one host at
//! a time, like the emulator: [`SOCKETS`] TCP sockets listen on it, so that while one host is
//! served (or its connection closes) the next one's connection is accepted and waits, its
//! first request in the socket's buffer, until the camera turns to it (a TCP backlog of
//! `SOCKETS - 1`; one more host at the same moment is refused with a reset). Allocation-free:
//! the socket storage and every socket's 64 KiB receive and send buffers are statics, taken
//! once ([`Net::new`]). Time for smoltcp (retransmissions, delayed
//! ACKs, ARP) is the MPCore global timer at QEMU's rate (`cpu::QEMU_NS_PER_GTIMER_TICK`; a board's
//! timer runs at CPU/2, 333 MHz on a 667 MHz Zynq, so there every time below passes 3.3 times
//! faster, which TCP tolerates).
//!
//! As the device loop's [`Link`] it keeps the UART's semantics where TCP allows, and the
//! emulator's where TCP adds something:
//! - a read waits for the first byte of a request as long as the connection lives (up to the
//!   idle time-out, [`NetTimeouts::idle_ticks`], since unlike a UART one silent host would hold
//!   the camera), and at most the frame time-out for the rest of a frame begun; a time-out ends
//!   the session (`Device::serve` returns) and drops the half frame; a host quiet between
//!   frames for the hand-over time while another host waits is given up too (the emulator's
//!   `--hand-over`);
//! - a connection the host closed reads as 0 bytes once its data are read (end of session), a
//!   reset one at once: either way the half frame is dropped;
//! - a write that the host does not take within the frame time-out (its window stays shut)
//!   ends the session too.
//! After a session [`Net::disconnect`] closes the connection (FIN, or RST if the host does not
//! finish within [`LINGER_TICKS`]) and [`Net::accept`] listens again: nothing a host sends or
//! does ends the server.
//!
//! The interface is polled from these loops only (no interrupts, no other task): a row being
//! decoded leaves the link alone; TCP's flow control holds the host back meanwhile.

use core::ptr::addr_of_mut;
use core::sync::atomic::{AtomicBool, Ordering};

use smoltcp::iface::{Config, Interface, SocketHandle, SocketSet, SocketStorage};
use smoltcp::socket::dhcpv4;
use smoltcp::socket::tcp::{self, State};
use smoltcp::time::Instant;
use smoltcp::wire::{EthernetAddress, HardwareAddress, IpAddress, IpCidr, Ipv4Address};

use super::cpu::{global_timer_ticks, QEMU_NS_PER_GTIMER_TICK};
use super::gem::Gem;
use crate::device::{Link, Waiting};
use crate::layout::NetConfig;

/// Each of the TCP socket's buffers: 64 KiB, the largest window without window scaling, more
/// than one BFSM row request (37 kB) in flight.
pub const TCP_BUFFER_LEN: usize = 65536;

/// How long [`Net::disconnect`] lets a closing connection finish (FIN and its ACK) before it
/// resets it: 1 s at QEMU's timer rate.
pub const LINGER_TICKS: u64 = 1_000_000_000 / QEMU_NS_PER_GTIMER_TICK;

/// TCP sockets listening on the port: the one served and one waiting host.
pub const SOCKETS: usize = 2;

/// How long [`Net::new`] waits for a DHCP lease before it serves without one (the line says
/// so; the lease is taken whenever it comes): 10 s at QEMU's timer rate.
pub const DHCP_WAIT_TICKS: u64 = 10_000_000_000 / QEMU_NS_PER_GTIMER_TICK;

/// The socket set's slots (the TCP sockets and the DHCP client) and the TCP buffers (taken
/// once, by [`Net::new`]).
static mut SOCKET_STORAGE: [SocketStorage<'static>; SOCKETS + 1] =
    [SocketStorage::EMPTY; SOCKETS + 1];
static mut TCP_RX: [[u8; TCP_BUFFER_LEN]; SOCKETS] = [[0; TCP_BUFFER_LEN]; SOCKETS];
static mut TCP_TX: [[u8; TCP_BUFFER_LEN]; SOCKETS] = [[0; TCP_BUFFER_LEN]; SOCKETS];
static TAKEN: AtomicBool = AtomicBool::new(false);

/// smoltcp's clock: the global timer in microseconds (at QEMU's rate).
pub fn now() -> Instant {
    Instant::from_micros((global_timer_ticks() * QEMU_NS_PER_GTIMER_TICK / 1000) as i64)
}

/// Time-outs of a session, in global-timer ticks.
#[derive(Clone, Copy, Debug)]
pub struct NetTimeouts {
    /// Silence inside a frame, or a host that takes no answer bytes, after which the session
    /// ends.
    pub frame_ticks: u64,
    /// Silence between frames after which the session ends (`None`: wait as long as the
    /// connection lives).
    pub idle_ticks: Option<u64>,
    /// Silence between frames after which the session ends when another host is waiting.
    pub hand_over_ticks: u64,
}

/// Why a session ended other than by the host closing it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NetError {
    /// No byte for the frame time-out inside a frame.
    FrameTimeout,
    /// No request for the idle time-out.
    IdleTimeout,
    /// No request for the hand-over time while another host waits.
    HandOver,
    /// The host took no answer bytes for the frame time-out.
    SendTimeout,
    /// The connection closed or was reset while an answer was being sent.
    Closed,
}

/// The interface, its one TCP socket and GEM0 under it.
pub struct Net {
    gem: Gem,
    iface: Interface,
    sockets: SocketSet<'static>,
    tcp: [SocketHandle; SOCKETS],
    /// The DHCP client, when the address is leased.
    dhcp: Option<SocketHandle>,
    /// The socket served (or last served).
    current: usize,
    config: NetConfig,
    timeouts: NetTimeouts,
    /// Connections accepted so far.
    pub connections: u32,
}

impl Net {
    /// The interface on `gem` with `config`'s address and route, listening on its port; with
    /// `config.dhcp`, the address and route a DHCP server leases, waited for at most
    /// [`DHCP_WAIT_TICKS`] (see [`Net::config`]). Returns `None` if the socket buffers are
    /// already taken.
    pub fn new(
        mut gem: Gem,
        mac: [u8; 6],
        config: NetConfig,
        timeouts: NetTimeouts,
    ) -> Option<Net> {
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        let mut c = Config::new(HardwareAddress::Ethernet(EthernetAddress(mac)));
        // TCP's initial sequence numbers: the start-up time is all the entropy there is.
        c.random_seed = global_timer_ticks() ^ 0x9E37_79B9_7F4A_7C15;
        let mut iface = Interface::new(c, &mut gem, now());
        if !config.dhcp {
            set_address(
                &mut iface,
                config.address,
                config.prefix_len,
                config.gateway,
            );
        }
        // SAFETY: these statics are referenced here only, once (`TAKEN`).
        let (storage, rx, tx) = unsafe {
            (
                &mut *addr_of_mut!(SOCKET_STORAGE),
                &mut *addr_of_mut!(TCP_RX),
                &mut *addr_of_mut!(TCP_TX),
            )
        };
        let mut sockets = SocketSet::new(&mut storage[..]);
        let mut rx = rx.iter_mut();
        let mut tx = tx.iter_mut();
        let tcp = [(); SOCKETS].map(|()| {
            let (Some(rx), Some(tx)) = (rx.next(), tx.next()) else {
                unreachable!("SOCKETS buffers each")
            };
            let mut socket = tcp::Socket::new(
                tcp::SocketBuffer::new(&mut rx[..]),
                tcp::SocketBuffer::new(&mut tx[..]),
            );
            // Answers are whole frames written at once: send them without waiting for an ACK.
            socket.set_nagle_enabled(false);
            sockets.add(socket)
        });
        let dhcp = config.dhcp.then(|| sockets.add(dhcpv4::Socket::new()));
        let mut net = Net {
            gem,
            iface,
            sockets,
            tcp,
            dhcp,
            current: 0,
            config,
            timeouts,
            connections: 0,
        };
        net.listen();
        net.poll();
        let start = global_timer_ticks();
        while net.dhcp.is_some()
            && !net.leased()
            && global_timer_ticks().wrapping_sub(start) < DHCP_WAIT_TICKS
        {
            net.poll();
        }
        Some(net)
    }

    /// Whether the interface has an address: a static one, or a DHCP lease.
    pub fn leased(&self) -> bool {
        self.config.address != [0; 4]
    }

    /// The driver under the interface.
    pub fn gem(&self) -> &Gem {
        &self.gem
    }

    /// The configuration served: with DHCP, the lease's address, prefix and route (0.0.0.0/0
    /// while there is none).
    pub fn config(&self) -> NetConfig {
        self.config
    }

    /// The socket served.
    fn socket(&mut self) -> &mut tcp::Socket<'static> {
        self.sockets.get_mut::<tcp::Socket>(self.tcp[self.current])
    }

    /// Whether socket `i` holds a connection (to serve, or being served).
    fn connected(&self, i: usize) -> bool {
        !matches!(
            self.sockets.get::<tcp::Socket>(self.tcp[i]).state(),
            State::Listen | State::SynReceived | State::Closed | State::TimeWait
        )
    }

    /// Whether a host other than the one served is connected and waiting.
    fn someone_waits(&self) -> bool {
        (0..SOCKETS).any(|i| i != self.current && self.connected(i))
    }

    /// Moves frames in and out, runs TCP's timers and DHCP's: a lease taken, renewed with
    /// other values or lost changes the interface's address and route at once.
    pub fn poll(&mut self) {
        let _ = self.iface.poll(now(), &mut self.gem, &mut self.sockets);
        let Some(h) = self.dhcp else { return };
        let lease = match self.sockets.get_mut::<dhcpv4::Socket>(h).poll() {
            None => return,
            Some(dhcpv4::Event::Configured(c)) => Some((
                c.address.address().octets(),
                c.address.prefix_len(),
                c.router.map(|r| r.octets()),
            )),
            Some(dhcpv4::Event::Deconfigured) => None,
        };
        let (address, prefix_len, gateway) = lease.unwrap_or(([0; 4], 0, None));
        set_address(&mut self.iface, address, prefix_len, gateway);
        self.config.address = address;
        self.config.prefix_len = prefix_len;
        self.config.gateway = gateway;
    }

    /// Every socket not in use listens on the port.
    fn listen(&mut self) {
        let port = self.config.port;
        for &h in &self.tcp {
            let socket = self.sockets.get_mut::<tcp::Socket>(h);
            if !socket.is_open() {
                let _ = socket.listen(port);
            }
        }
    }

    /// Waits for a host to connect: the next socket after the last one served that holds a
    /// connection (so that a waiting host comes before a newer one).
    pub fn accept(&mut self) {
        loop {
            self.listen();
            self.poll();
            if let Some(i) = (1..=SOCKETS)
                .map(|k| (self.current + k) % SOCKETS)
                .find(|&i| self.connected(i))
            {
                self.current = i;
                break;
            }
        }
        self.connections = self.connections.wrapping_add(1);
    }

    /// Ends the connection: sends what is queued and a FIN, gives the host [`LINGER_TICKS`]
    /// to finish, resets what is left; then listens again.
    pub fn disconnect(&mut self) {
        self.socket().close();
        let start = global_timer_ticks();
        while self.socket().is_open() && global_timer_ticks().wrapping_sub(start) < LINGER_TICKS {
            self.poll();
        }
        if self.socket().is_open() {
            self.socket().abort();
        }
        // The reset (if any) goes out before the socket listens again.
        self.poll();
        self.poll();
        self.listen();
        self.poll();
    }
}

/// Gives `iface` the one address `address/prefix_len` (none for 0.0.0.0) and the default
/// route `gateway`.
fn set_address(iface: &mut Interface, address: [u8; 4], prefix_len: u8, gateway: Option<[u8; 4]>) {
    let [a, b, c, d] = address;
    iface.update_ip_addrs(|addrs| {
        addrs.clear();
        if address != [0; 4] {
            let _ = addrs.push(IpCidr::new(
                IpAddress::Ipv4(Ipv4Address::new(a, b, c, d)),
                prefix_len,
            ));
        }
    });
    iface.routes_mut().remove_default_ipv4_route();
    if let Some([a, b, c, d]) = gateway {
        let _ = iface
            .routes_mut()
            .add_default_ipv4_route(Ipv4Address::new(a, b, c, d));
    }
}

impl Link for Net {
    type Error = NetError;

    /// Takes what the socket holds, polling the interface while it waits; 0 once the host
    /// closed or reset the connection.
    fn read(&mut self, buf: &mut [u8], waiting: Waiting) -> Result<usize, NetError> {
        if buf.is_empty() {
            return Ok(0);
        }
        let start = global_timer_ticks();
        let limit = match waiting {
            Waiting::NextFrame => self.timeouts.idle_ticks,
            Waiting::RestOfFrame => Some(self.timeouts.frame_ticks),
        };
        loop {
            self.poll();
            let socket = self.socket();
            if socket.can_recv() {
                if let Ok(n) = socket.recv_slice(buf) {
                    if n > 0 {
                        return Ok(n);
                    }
                }
            }
            if !socket.may_recv() {
                // Closed by the host (its FIN, all data read) or reset.
                return Ok(0);
            }
            let quiet = global_timer_ticks().wrapping_sub(start);
            if let Some(limit) = limit {
                if quiet > limit {
                    return Err(match waiting {
                        Waiting::NextFrame => NetError::IdleTimeout,
                        Waiting::RestOfFrame => NetError::FrameTimeout,
                    });
                }
            }
            if waiting == Waiting::NextFrame
                && quiet > self.timeouts.hand_over_ticks
                && self.someone_waits()
            {
                return Err(NetError::HandOver);
            }
        }
    }

    /// Queues all of `bytes`, polling while the send buffer is full; gives up when the
    /// connection ends or no byte is taken for the frame time-out.
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), NetError> {
        let mut at = 0;
        let mut last_progress = global_timer_ticks();
        while at < bytes.len() {
            let socket = self.socket();
            if !socket.may_send() {
                return Err(NetError::Closed);
            }
            if socket.can_send() {
                if let Ok(n) = socket.send_slice(&bytes[at..]) {
                    if n > 0 {
                        at += n;
                        last_progress = global_timer_ticks();
                    }
                }
            }
            self.poll();
            if global_timer_ticks().wrapping_sub(last_progress) > self.timeouts.frame_ticks {
                return Err(NetError::SendTimeout);
            }
        }
        Ok(())
    }
}
