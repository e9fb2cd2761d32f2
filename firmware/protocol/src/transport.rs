//! Links to a camera: TCP (`tcp://host:port`) or a serial port (`/dev/ttyUSB0`,
//! `/dev/ttyUSB0@921600`).

use std::fmt;
use std::io::{self, Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// A byte stream to a camera.
pub trait Link: Read + Write + Send {}

impl<T: Read + Write + Send> Link for T {}

/// Baud rate of a serial port given without `@baud`.
pub const DEFAULT_BAUD: u32 = 921_600;

/// Where the camera is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeviceAddress {
    /// `tcp://host:port`.
    Tcp {
        /// `host:port`.
        host_port: String,
    },
    /// A serial port path, optionally `@baud`.
    Serial {
        /// Device path.
        path: String,
        /// Baud rate.
        baud: u32,
    },
}

/// A device address that does not parse.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AddressError {
    /// The address as given.
    pub address: String,
    /// What is wrong with it.
    pub reason: &'static str,
}

impl fmt::Display for AddressError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "device address '{}': {} (expected tcp://HOST:PORT or a serial port path, \
             optionally PATH@BAUD)",
            self.address, self.reason
        )
    }
}

impl std::error::Error for AddressError {}

impl DeviceAddress {
    /// Parses `tcp://host:port`, `PATH` or `PATH@BAUD`.
    pub fn parse(address: &str) -> Result<Self, AddressError> {
        let err = |reason| AddressError {
            address: address.to_string(),
            reason,
        };
        if let Some(host_port) = address.strip_prefix("tcp://") {
            let (host, port) = host_port.rsplit_once(':').ok_or(err("no :PORT"))?;
            if host.is_empty() {
                return Err(err("no host"));
            }
            port.parse::<u16>()
                .map_err(|_| err("port is not 1..=65535"))?;
            if port == "0" {
                return Err(err("port is not 1..=65535"));
            }
            return Ok(DeviceAddress::Tcp {
                host_port: host_port.to_string(),
            });
        }
        if address.contains("://") {
            return Err(err("unknown scheme"));
        }
        if address.is_empty() {
            return Err(err("empty"));
        }
        let (path, baud) = match address.rsplit_once('@') {
            Some((path, baud)) => (
                path,
                baud.parse::<u32>()
                    .ok()
                    .filter(|&b| b > 0)
                    .ok_or(err("baud rate is not a positive integer"))?,
            ),
            None => (address, DEFAULT_BAUD),
        };
        if path.is_empty() {
            return Err(err("empty serial port path"));
        }
        Ok(DeviceAddress::Serial {
            path: path.to_string(),
            baud,
        })
    }

    /// Opens the link; reads wait at most `timeout` for the next bytes.
    pub fn open(&self, timeout: Duration) -> io::Result<Box<dyn Link>> {
        match self {
            DeviceAddress::Tcp { host_port } => {
                let mut last = None;
                for addr in host_port.to_socket_addrs()? {
                    match TcpStream::connect_timeout(&addr, timeout) {
                        Ok(stream) => {
                            stream.set_nodelay(true)?;
                            stream.set_read_timeout(Some(timeout))?;
                            stream.set_write_timeout(Some(timeout))?;
                            return Ok(Box::new(stream));
                        }
                        Err(e) => last = Some(e),
                    }
                }
                Err(last.unwrap_or_else(|| {
                    io::Error::new(io::ErrorKind::NotFound, format!("{host_port}: no address"))
                }))
            }
            DeviceAddress::Serial { path, baud } => {
                let port = serialport::new(path, *baud)
                    .timeout(timeout)
                    .open()
                    .map_err(io::Error::from)?;
                Ok(Box::new(port))
            }
        }
    }
}

impl fmt::Display for DeviceAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DeviceAddress::Tcp { host_port } => write!(f, "tcp://{host_port}"),
            DeviceAddress::Serial { path, baud } => write!(f, "{path}@{baud}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn addresses() {
        assert_eq!(
            DeviceAddress::parse("tcp://127.0.0.1:7070"),
            Ok(DeviceAddress::Tcp {
                host_port: "127.0.0.1:7070".into()
            })
        );
        assert_eq!(
            DeviceAddress::parse("tcp://[::1]:7070"),
            Ok(DeviceAddress::Tcp {
                host_port: "[::1]:7070".into()
            })
        );
        assert_eq!(
            DeviceAddress::parse("/dev/ttyUSB0"),
            Ok(DeviceAddress::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: DEFAULT_BAUD
            })
        );
        assert_eq!(
            DeviceAddress::parse("/dev/ttyUSB0@115200"),
            Ok(DeviceAddress::Serial {
                path: "/dev/ttyUSB0".into(),
                baud: 115_200
            })
        );
        for bad in [
            "tcp://host",
            "tcp://:80",
            "tcp://h:0",
            "tcp://h:99999",
            "udp://h:1",
            "",
            "/dev/x@fast",
            "@9600",
        ] {
            let e = DeviceAddress::parse(bad).unwrap_err();
            assert!(e.to_string().contains(bad), "{e}");
        }
    }
}
