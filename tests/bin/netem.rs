//! A lossy link between two network namespaces, in user space: the kernel of the test machine has no
//! `sch_netem` (`tc qdisc add ... netem` answers "Specified qdisc kind is unknown"), so this relays IP packets
//! between a TUN device in each namespace and drops, delays and reorders them on the way.
//!
//! ```text
//! radar_test_netem A_PID B_PID LOSS DELAY_MS JITTER_MS SEED
//! ```
//!
//! Creates `tun0` in the network namespace of process `A_PID` and `tun0` in that of `B_PID` (the caller
//! configures addresses and routes), prints `ready`, then forwards every packet from one to the other: each
//! is dropped with probability `LOSS` (0-1), else delivered after `DELAY_MS` plus a uniform `0..JITTER_MS`
//! (so packets overtake each other when the jitter exceeds their spacing). Counts are printed on stderr when
//! it ends (SIGTERM, or stdin closing); with `RADAR_NETEM_TRACE` set, one line per packet on stderr (sent or lost,
//! its port and RTPS submessages). Linux only; needs CAP_NET_ADMIN and CAP_SYS_ADMIN (root in the test
//! namespace).

use std::{
    collections::BinaryHeap,
    os::fd::{AsRawFd, FromRawFd, OwnedFd},
    sync::{
        atomic::{AtomicU64, Ordering},
        mpsc, Arc,
    },
    time::{Duration, Instant},
};

const TUNSETIFF: libc::c_ulong = 0x4004_54ca;
const IFF_TUN: libc::c_short = 0x0001;
const IFF_NO_PI: libc::c_short = 0x1000;

fn fail(what: &str) -> ! {
    eprintln!(
        "radar_test_netem: {what}: {}",
        std::io::Error::last_os_error()
    );
    std::process::exit(2);
}

/// Moves this thread into the network namespace of `pid`.
fn enter_netns(pid: u32) {
    let path = std::ffi::CString::new(format!("/proc/{pid}/ns/net")).unwrap();
    // SAFETY: plain system calls on a path we own and a descriptor we close.
    unsafe {
        let fd = libc::open(path.as_ptr(), libc::O_RDONLY | libc::O_CLOEXEC);
        if fd < 0 {
            fail(&format!("open /proc/{pid}/ns/net"));
        }
        if libc::setns(fd, libc::CLONE_NEWNET) != 0 {
            fail("setns");
        }
        libc::close(fd);
    }
}

/// Opens a TUN device `tun0` in the current network namespace.
fn open_tun() -> OwnedFd {
    #[repr(C)]
    struct IfReq {
        name: [u8; 16],
        flags: libc::c_short,
        _pad: [u8; 22],
    }
    let mut req = IfReq {
        name: [0; 16],
        flags: IFF_TUN | IFF_NO_PI,
        _pad: [0; 22],
    };
    req.name[..4].copy_from_slice(b"tun0");
    // SAFETY: `req` has the layout of `struct ifreq` for TUNSETIFF; the descriptor is owned once opened.
    unsafe {
        let fd = libc::open(c"/dev/net/tun".as_ptr(), libc::O_RDWR | libc::O_CLOEXEC);
        if fd < 0 {
            fail("open /dev/net/tun");
        }
        if libc::ioctl(fd, TUNSETIFF, &mut req as *mut IfReq) < 0 {
            fail("TUNSETIFF");
        }
        OwnedFd::from_raw_fd(fd)
    }
}

/// xorshift64*: reproducible from the seed.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[derive(Default)]
struct Counts {
    forwarded: AtomicU64,
    dropped: AtomicU64,
}

struct Due {
    at: Instant,
    seq: u64,
    packet: Vec<u8>,
}
impl PartialEq for Due {
    fn eq(&self, o: &Self) -> bool {
        (self.at, self.seq) == (o.at, o.seq)
    }
}
impl Eq for Due {}
impl PartialOrd for Due {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Due {
    // a min-heap on (due time, arrival order)
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        (o.at, o.seq).cmp(&(self.at, self.seq))
    }
}

/// A packet for the trace (`RADAR_NETEM_TRACE`): its UDP destination port and RTPS submessages, each with the
/// entity id that says which endpoint it is about (DATA and HEARTBEAT: the writer; ACKNACK: the reader).
fn describe(p: &[u8]) -> String {
    let Some(ihl) = p.first().map(|b| usize::from(b & 0x0f) * 4) else {
        return "empty".into();
    };
    let port = p
        .get(ihl + 2..ihl + 4)
        .map(|b| u16::from_be_bytes([b[0], b[1]]))
        .unwrap_or(0);
    let rtps = p.get(ihl + 8..).unwrap_or_default();
    let mut out = format!("port {port} len {}", p.len());
    if rtps.get(..4) != Some(b"RTPS") {
        return out;
    }
    let mut i = 20;
    while i + 4 <= rtps.len() {
        let (id, flags) = (rtps[i], rtps[i + 1]);
        let le = flags & 1 == 1;
        let len = if le {
            u16::from_le_bytes([rtps[i + 2], rtps[i + 3]])
        } else {
            u16::from_be_bytes([rtps[i + 2], rtps[i + 3]])
        } as usize;
        let body = &rtps[i + 4..(i + 4 + len).min(rtps.len())];
        let entity = |at: usize| {
            body.get(at..at + 4)
                .map(|b| format!("{:02x}{:02x}{:02x}{:02x}", b[0], b[1], b[2], b[3]))
                .unwrap_or_default()
        };
        let seq = |at: usize| -> i64 {
            body.get(at..at + 8)
                .map(|b| {
                    let (hi, lo) = if le {
                        (
                            i32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                            u32::from_le_bytes([b[4], b[5], b[6], b[7]]),
                        )
                    } else {
                        (
                            i32::from_be_bytes([b[0], b[1], b[2], b[3]]),
                            u32::from_be_bytes([b[4], b[5], b[6], b[7]]),
                        )
                    };
                    (i64::from(hi) << 32) | i64::from(lo)
                })
                .unwrap_or(-1)
        };
        let what = match id {
            0x06 => format!(" ACKNACK(r {} w {} base {})", entity(0), entity(4), seq(8)),
            0x07 => format!(" HB(w {} {}..{})", entity(4), seq(8), seq(16)),
            0x08 => format!(" GAP(w {})", entity(4)),
            0x15 => format!(" DATA(w {} sn {})", entity(8), seq(12)),
            0x16 => format!(" DATA_FRAG(w {} sn {})", entity(8), seq(12)),
            0x0e => " DST".to_string(),
            0x09 => String::new(),
            other => format!(" sub{other:#x}"),
        };
        out.push_str(&what);
        if len == 0 {
            break;
        }
        i += 4 + len;
    }
    out
}

/// How a direction impairs packets.
#[derive(Clone, Copy)]
struct Impairment {
    loss: f64,
    delay: Duration,
    jitter: Duration,
    seed: u64,
}

/// One direction (`tag` in the trace): reads packets from `from`, writes them to `to` as impaired.
fn direction(
    tag: &'static str,
    from: Arc<OwnedFd>,
    to: Arc<OwnedFd>,
    how: Impairment,
    counts: Arc<Counts>,
) {
    let Impairment {
        loss,
        delay,
        jitter,
        seed,
    } = how;
    let (tx, rx) = mpsc::channel::<Due>();
    let sent = counts.clone();
    std::thread::spawn(move || {
        let mut heap = BinaryHeap::new();
        loop {
            let wait = heap
                .peek()
                .map(|d: &Due| d.at.saturating_duration_since(Instant::now()))
                .unwrap_or(Duration::from_secs(3600));
            match rx.recv_timeout(wait) {
                Ok(d) => heap.push(d),
                Err(mpsc::RecvTimeoutError::Timeout) => {}
                Err(mpsc::RecvTimeoutError::Disconnected) => return,
            }
            while heap.peek().is_some_and(|d| d.at <= Instant::now()) {
                let d = heap.pop().unwrap();
                // SAFETY: writing a buffer we own to a descriptor we hold.
                unsafe {
                    libc::write(to.as_raw_fd(), d.packet.as_ptr().cast(), d.packet.len());
                }
                sent.forwarded.fetch_add(1, Ordering::Relaxed);
            }
        }
    });
    let mut rng = Rng(seed | 1);
    let trace = std::env::var_os("RADAR_NETEM_TRACE").is_some();
    let t0 = Instant::now();
    let mut buf = vec![0u8; 65536];
    let mut seq = 0u64;
    loop {
        // SAFETY: reading into a buffer we own from a descriptor we hold.
        let n = unsafe { libc::read(from.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
        if n <= 0 {
            return;
        }
        let lost = rng.unit() < loss;
        if trace {
            eprintln!(
                "netem {:>8.3} {tag} {} {}",
                t0.elapsed().as_secs_f64(),
                if lost { "LOST" } else { "sent" },
                describe(&buf[..n as usize])
            );
        }
        if lost {
            counts.dropped.fetch_add(1, Ordering::Relaxed);
            continue;
        }
        let extra = jitter.mul_f64(rng.unit());
        seq += 1;
        let due = Due {
            at: Instant::now() + delay + extra,
            seq,
            packet: buf[..n as usize].to_vec(),
        };
        if tx.send(due).is_err() {
            return;
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 6 {
        eprintln!("usage: radar_test_netem A_PID B_PID LOSS DELAY_MS JITTER_MS SEED");
        std::process::exit(64);
    }
    let pid = |i: usize| args[i].parse::<u32>().expect("a pid");
    let loss: f64 = args[2].parse().expect("LOSS in 0..1");
    let delay = Duration::from_secs_f64(args[3].parse::<f64>().expect("DELAY_MS") / 1000.0);
    let jitter = Duration::from_secs_f64(args[4].parse::<f64>().expect("JITTER_MS") / 1000.0);
    let seed: u64 = args[5].parse().expect("SEED");
    // namespaces are per thread: open each device from inside its namespace, before any thread starts
    enter_netns(pid(0));
    let a = Arc::new(open_tun());
    enter_netns(pid(1));
    let b = Arc::new(open_tun());
    let counts = Arc::new(Counts::default());
    {
        let (a, b, c) = (a.clone(), b.clone(), counts.clone());
        std::thread::spawn(move || {
            direction(
                "a>b",
                a,
                b,
                Impairment {
                    loss,
                    delay,
                    jitter,
                    seed,
                },
                c,
            )
        });
    }
    {
        let (a, b, c) = (a.clone(), b.clone(), counts.clone());
        std::thread::spawn(move || {
            direction(
                "b>a",
                b,
                a,
                Impairment {
                    loss,
                    delay,
                    jitter,
                    seed: seed.rotate_left(17),
                },
                c,
            )
        });
    }
    println!("ready");
    // until stdin closes (the test ends or drops us) or SIGTERM
    let mut line = String::new();
    while std::io::stdin()
        .read_line(&mut line)
        .map(|n| n > 0)
        .unwrap_or(false)
    {
        line.clear();
    }
    eprintln!(
        "radar_test_netem: forwarded {} packets, dropped {}",
        counts.forwarded.load(Ordering::Relaxed),
        counts.dropped.load(Ordering::Relaxed)
    );
}
