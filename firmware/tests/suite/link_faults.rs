//! The camera emulator driven by hostile or broken hosts over raw sockets (loopback only):
//! connections reset before, during and after a frame, a quiet connection holding the camera
//! while another host waits, fifty connections in a row, garbage. After each, a host scans
//! a dump through the camera and must get the host decode's candidates, byte for byte.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

use fsm_core::wire::row_dump::RowDumpHeader;
use fsm_core::wire::HEADER_LEN;
use fsm_core::{GroupCount, ScanPlan};
use fsm_firmware::emulator::{Emulator, Timeouts};
use fsm_firmware::reference;
use fsm_firmware::scene::MirrorScene;
use fsm_protocol::client::{Client, ClientError};
use fsm_protocol::frame;
use fsm_protocol::{Request, RequestKind, Response, RowOutput, ScanSpec};

/// Short limits, so that the tests wait little.
const LIMITS: Timeouts = Timeouts {
    frame: Duration::from_millis(800),
    idle: Some(Duration::from_secs(20)),
    hand_over: Duration::from_millis(300),
};

/// What a well-behaved host allows the camera to answer in.
const HOST_TIMEOUT: Duration = Duration::from_secs(4);

fn plan() -> ScanPlan {
    ScanPlan::paper_efsm(GroupCount::One)
}

fn dump(plan: &ScanPlan) -> Vec<u8> {
    MirrorScene::for_plan(plan, 16, 3).dump(plan)
}

fn records(dump: &[u8]) -> Vec<&[u8]> {
    let len = RowDumpHeader::decode(dump).unwrap().record_len().unwrap();
    dump[HEADER_LEN..].chunks_exact(len).collect()
}

fn encoded(request: &Request<'_>) -> Vec<u8> {
    frame::encode_vec(request).unwrap()
}

/// Closes `stream` with a reset (SO_LINGER 0) instead of a FIN.
fn reset(stream: TcpStream) {
    socket2::SockRef::from(&stream)
        .set_linger(Some(Duration::ZERO))
        .unwrap();
    drop(stream);
}

/// A full scan by a well-behaved host: the camera's candidates are the host decode's, and
/// there are candidates at all.
fn scan_is_host_equal(camera: &Emulator, plan: &ScanPlan) {
    let dump = dump(plan);
    let mut client = Client::connect(&camera.url(), HOST_TIMEOUT).expect("connect");
    let mut received = Vec::new();
    client
        .scan_dump(
            plan,
            &dump,
            "scene.dump",
            RowOutput::Candidates,
            &mut received,
        )
        .expect("scan through the camera");
    let expected = reference::decode_dump(plan, &dump).unwrap();
    if let Err(d) = reference::compare(&expected, &received) {
        panic!("camera and host differ: {d}");
    }
    let census = reference::census(&received).unwrap();
    assert!(census.by_count[1..].iter().sum::<usize>() > 0, "{census}");
}

/// A connection that has loaded the plan and started a scan, as raw bytes.
fn scanning(camera: &Emulator, plan: &ScanPlan, dump: &[u8]) -> TcpStream {
    let header = RowDumpHeader::decode(dump).unwrap();
    let mut s = TcpStream::connect(camera.addr()).unwrap();
    let mut bytes = encoded(&Request::Hello);
    bytes.extend(encoded(&Request::UploadPlan {
        plan: &plan.to_bytes(),
        fingerprint: plan.fingerprint(),
    }));
    bytes.extend(encoded(&Request::StartScan(ScanSpec {
        fingerprint: plan.fingerprint(),
        width: header.width,
        height: header.height,
        bit_depth: header.bit_depth,
        output: RowOutput::Candidates,
    })));
    s.write_all(&bytes).unwrap();
    s
}

#[test]
fn a_reset_ends_one_connection_never_the_camera() {
    let camera = Emulator::spawn_with("127.0.0.1:0", LIMITS).unwrap();
    let plan = plan();
    let dump = dump(&plan);
    let hello = encoded(&Request::Hello);
    let upload = encoded(&Request::UploadPlan {
        plan: &plan.to_bytes(),
        fingerprint: plan.fingerprint(),
    });

    // Reset before a byte.
    reset(TcpStream::connect(camera.addr()).unwrap());
    scan_is_host_equal(&camera, &plan);

    // Reset during Hello: half of its frame sent.
    let mut s = TcpStream::connect(camera.addr()).unwrap();
    s.write_all(&hello[..hello.len() / 2]).unwrap();
    reset(s);
    scan_is_host_equal(&camera, &plan);

    // Reset mid-frame: half of a plan upload.
    let mut s = TcpStream::connect(camera.addr()).unwrap();
    s.write_all(&upload[..upload.len() / 2]).unwrap();
    std::thread::sleep(Duration::from_millis(50));
    reset(s);
    scan_is_host_equal(&camera, &plan);

    // Reset mid-scan, answers unread: the camera is writing when the link goes.
    let mut s = scanning(&camera, &plan, &dump);
    for r in records(&dump) {
        s.write_all(&encoded(&Request::Row { record: r })).unwrap();
    }
    std::thread::sleep(Duration::from_millis(50));
    reset(s);
    scan_is_host_equal(&camera, &plan);

    // Reset mid-scan between rows, after reading some answers.
    let mut s = scanning(&camera, &plan, &dump);
    s.write_all(&encoded(&Request::Row {
        record: records(&dump)[0],
    }))
    .unwrap();
    let mut some = [0u8; 256];
    let n = s.read(&mut some).unwrap();
    assert!(n > 0);
    reset(s);
    scan_is_host_equal(&camera, &plan);

    // And a BFSM scan after all of that.
    scan_is_host_equal(&camera, &ScanPlan::paper_bfsm());
}

#[test]
fn a_quiet_connection_hands_the_camera_to_a_waiting_host() {
    let camera = Emulator::spawn_with("127.0.0.1:0", LIMITS).unwrap();
    let plan = plan();

    // A holder that said Hello and went quiet between frames.
    let mut holder = Client::new(TcpStream::connect(camera.addr()).unwrap());
    holder
        .link_mut()
        .set_read_timeout(Some(HOST_TIMEOUT))
        .unwrap();
    holder.hello().unwrap();
    let t = Instant::now();
    scan_is_host_equal(&camera, &plan);
    let waited = t.elapsed();
    assert!(
        waited < HOST_TIMEOUT,
        "the waiting host was served after {waited:?}"
    );
    // The holder's link was given up: its next request is not answered.
    match holder.hello() {
        Err(ClientError::Closed { .. }) | Err(ClientError::Io { .. }) => {}
        other => panic!("the holder still has the camera: {other:?}"),
    }

    // A holder quiet inside a frame is not handed over, but given up after the frame limit.
    let mut half = TcpStream::connect(camera.addr()).unwrap();
    let hello = encoded(&Request::Hello);
    half.write_all(&hello[..hello.len() - 2]).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    let t = Instant::now();
    scan_is_host_equal(&camera, &plan);
    let waited = t.elapsed();
    assert!(
        waited >= LIMITS.frame - Duration::from_millis(150) && waited < HOST_TIMEOUT,
        "served after {waited:?}; the frame limit is {:?}",
        LIMITS.frame
    );
    // The camera closed it: reading gives the end of the stream, or a reset.
    half.set_read_timeout(Some(HOST_TIMEOUT)).unwrap();
    let mut buf = [0u8; 64];
    assert!(!matches!(half.read(&mut buf), Ok(n) if n > 0));
}

#[test]
fn a_connection_quiet_for_the_idle_limit_is_closed() {
    let limits = Timeouts {
        idle: Some(Duration::from_millis(600)),
        ..LIMITS
    };
    let camera = Emulator::spawn_with("127.0.0.1:0", limits).unwrap();
    let mut holder = TcpStream::connect(camera.addr()).unwrap();
    holder.write_all(&encoded(&Request::Hello)).unwrap();
    holder.set_read_timeout(Some(HOST_TIMEOUT)).unwrap();
    let t = Instant::now();
    let mut buf = vec![0u8; 4096];
    let mut total = 0;
    // The answer to Hello, then the end of the stream once the camera gave the link up.
    loop {
        match holder.read(&mut buf) {
            Ok(0) | Err(_) => break,
            Ok(n) => total += n,
        }
    }
    let waited = t.elapsed();
    assert!(total > 0, "Hello was not answered");
    assert!(
        waited >= Duration::from_millis(500) && waited < HOST_TIMEOUT,
        "closed after {waited:?}"
    );
    scan_is_host_equal(&camera, &plan());
}

#[test]
fn fifty_connections_in_a_row() {
    let camera = Emulator::spawn_with("127.0.0.1:0", LIMITS).unwrap();
    let plan = plan();
    let hello = encoded(&Request::Hello);
    for i in 0..50 {
        let mut s = TcpStream::connect(camera.addr()).unwrap();
        match i % 5 {
            0 => drop(s),
            1 => reset(s),
            2 => {
                s.write_all(&hello[..3]).unwrap();
                reset(s);
            }
            3 => {
                // A whole Hello, its answer read, a clean close.
                s.write_all(&hello).unwrap();
                s.set_read_timeout(Some(HOST_TIMEOUT)).unwrap();
                let mut buf = [0u8; 256];
                assert!(s.read(&mut buf).unwrap() > 0, "connection {i}: no answer");
            }
            _ => {
                s.write_all(&hello).unwrap();
                reset(s);
            }
        }
    }
    scan_is_host_equal(&camera, &plan);
}

#[test]
fn garbage_then_a_good_session() {
    let camera = Emulator::spawn_with("127.0.0.1:0", LIMITS).unwrap();
    let plan = plan();
    // Bytes of every value, delimiters among them, in a fixed pseudo-random order.
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let garbage: Vec<u8> = (0..50_000)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        })
        .collect();

    // Garbage on a connection of its own.
    let mut s = TcpStream::connect(camera.addr()).unwrap();
    s.write_all(&garbage).unwrap();
    drop(s);
    scan_is_host_equal(&camera, &plan);

    // Garbage, then a good session on the same connection: the camera answers the garbage
    // with errors and the Hello after it with its info.
    let mut client = Client::new(TcpStream::connect(camera.addr()).unwrap());
    client
        .link_mut()
        .set_read_timeout(Some(HOST_TIMEOUT))
        .unwrap();
    let mut bytes = garbage.clone();
    bytes.push(0);
    bytes.extend(encoded(&Request::Hello));
    client.send_raw(RequestKind::Hello, &bytes).unwrap();
    let mut errors = 0;
    loop {
        match client.receive(RequestKind::Hello).unwrap() {
            Response::Error(_) => errors += 1,
            Response::Info(_) => break,
            other => panic!("answered garbage with {other:?}"),
        }
    }
    assert!(errors > 0);
    let dump = dump(&plan);
    let mut received = Vec::new();
    client
        .scan_dump(
            plan,
            &dump,
            "scene.dump",
            RowOutput::Candidates,
            &mut received,
        )
        .unwrap();
    assert_eq!(received, reference::decode_dump(plan, &dump).unwrap());
    drop(client);
    scan_is_host_equal(&camera, &plan);
}

/// The client reports a camera that does not answer as a time-out, naming the request.
#[test]
fn a_silent_camera_is_a_time_out() {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("tcp://{}", listener.local_addr().unwrap());
    let mute = std::thread::spawn(move || {
        let (s, _) = listener.accept().unwrap();
        std::thread::sleep(Duration::from_secs(2));
        drop(s);
    });
    let mut client = Client::connect(&url, Duration::from_millis(300)).unwrap();
    let e = client.hello().unwrap_err();
    assert!(matches!(e, ClientError::TimedOut { .. }), "{e:?}");
    assert_eq!(
        e.to_string(),
        "waiting for the answer to Hello: timed out after 0.3 s"
    );
    mute.join().unwrap();
}
