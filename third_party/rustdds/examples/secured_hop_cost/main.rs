//! What a reliable sample costs on the cores, secured against plain, between two participants of one
//! process (RADAR patch 64): a writer writes one small sample, the reader's task wakes and takes it, and
//! only then the next is written. Prints, for plain and secured participants, the process's CPU time per
//! sample and the one-way time (write called -> sample taken), back to back and paced 1 ms apart (the
//! paced figures carry what cold caches add, as a signal every so often meets them).
//!
//! The secured pair uses the example configuration (`examples/security_configuration_files`), whose
//! governance encrypts topic `Square`'s payload, submessages and messages, and whose permissions grant
//! domain 0 only: run it where domain 0 is private (radar_ros's `tests/isolated.sh`):
//!
//!     tests/isolated.sh cargo run --release --manifest-path third_party/rustdds/Cargo.toml \
//!       --features security --example secured_hop_cost
//!
//! On a noisy machine the times move more than what a change saves; the instructions the security
//! plugins execute per sample do not: run it under `valgrind --tool=callgrind` with
//! `SECURED_HOP_COST_N=1000 --dump-before='*measured_run_begins' --dump-before='*measured_run_ends'`: the
//! parts 2 (plain) and 4 (secured) are the back-to-back runs alone; divide by N. With
//! `SECURED_HOP_COST_IDLE_WRITERS=K`, K idle writers of the topic stand beside the measured one (the
//! reading participant knows K more endpoints of the sending one, and the reader's ACKNACKs have K more
//! writers they could be for).

use std::time::{Duration, Instant};

use futures::StreamExt;
use rustdds::{
  no_key::{DataReader, DataWriter},
  policy, DomainParticipant, DomainParticipantBuilder, DomainParticipantSecurityConfigFiles,
  QosPolicyBuilder, TopicKind,
};
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
struct Shape {
  n: u32,
  stamp_ns: u64,
}

const PROBE: u32 = 1_000_000;

fn participant(secured: bool) -> DomainParticipant {
  if !secured {
    return DomainParticipant::new(0).expect("a plain participant");
  }
  let dir = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/examples/security_configuration_files"
  );
  DomainParticipantBuilder::new(0)
    .builtin_security(DomainParticipantSecurityConfigFiles::with_ros_default_names(
      dir,
      "password123".to_string(),
    ))
    .build()
    .expect("a secured participant from the example configuration")
}

/// CPU time of this process (all threads), in microseconds.
fn cpu_us() -> f64 {
  let mut u: libc::rusage = unsafe { std::mem::zeroed() };
  unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) };
  let t = |tv: libc::timeval| tv.tv_sec as f64 * 1e6 + tv.tv_usec as f64;
  t(u.ru_utime) + t(u.ru_stime)
}

fn now_ns(origin: Instant) -> u64 {
  origin.elapsed().as_nanos() as u64
}

struct Row {
  cpu_per_sample_us: f64,
  p50_us: f64,
  p90_us: f64,
}

fn run(
  writer: &DataWriter<Shape>,
  stream: &mut rustdds::no_key::DataReaderStream<Shape>,
  n: u32,
  pace: Option<Duration>,
  origin: Instant,
) -> Row {
  let mut one_way = Vec::with_capacity(n as usize);
  let cpu0 = cpu_us();
  for i in 0..n {
    if let Some(p) = pace {
      std::thread::sleep(p);
    }
    writer
      .write(
        Shape {
          n: i,
          stamp_ns: now_ns(origin),
        },
        None,
      )
      .unwrap();
    loop {
      let s = futures::executor::block_on(stream.next())
        .expect("the stream goes on")
      .expect("a sample, not an error");
      let v = s.into_value();
      if v.n == i {
        one_way.push((now_ns(origin) - v.stamp_ns) as f64 / 1000.0);
        break;
      }
    }
  }
  let cpu = cpu_us() - cpu0;
  one_way.sort_by(|a, b| a.partial_cmp(b).unwrap());
  let q = |f: f64| one_way[((one_way.len() - 1) as f64 * f) as usize];
  Row {
    cpu_per_sample_us: cpu / f64::from(n),
    p50_us: q(0.5),
    p90_us: q(0.9),
  }
}

/// Marks for callgrind: `--dump-before=*measured_run_begins --dump-before=*measured_run_ends` writes the
/// back-to-back run's instructions (all threads, matching and key exchange left out) as their own part.
#[inline(never)]
fn measured_run_begins() {
  std::hint::black_box(());
}

#[inline(never)]
fn measured_run_ends() {
  std::hint::black_box(());
}

fn pair(secured: bool) -> (Vec<Row>, &'static str) {
  let origin = Instant::now();
  let (a, b) = (participant(secured), participant(secured));
  let qos = QosPolicyBuilder::new()
    .reliability(policy::Reliability::Reliable {
      max_blocking_time: rustdds::Duration::from_secs(1),
    })
    .history(policy::History::KeepLast { depth: 10 })
    .build();
  let topic = |p: &DomainParticipant| {
    p.create_topic(
      "Square".to_string(),
      "ShapeType".to_string(),
      &qos,
      TopicKind::NoKey,
    )
    .unwrap()
  };
  let writer: DataWriter<Shape> = a
    .create_publisher(&qos)
    .unwrap()
    .create_datawriter_no_key_cdr(&topic(&a), None)
    .unwrap();
  // idle writers of the same topic beside the measured one (`SECURED_HOP_COST_IDLE_WRITERS`, default 0):
  // the reading participant then knows that many more endpoints of the sending one
  let idle: usize = std::env::var("SECURED_HOP_COST_IDLE_WRITERS")
    .ok()
    .and_then(|v| v.parse().ok())
    .unwrap_or(0);
  let idle_publisher = a.create_publisher(&qos).unwrap();
  let _idle_writers: Vec<DataWriter<Shape>> = (0..idle)
    .map(|_| {
      idle_publisher
        .create_datawriter_no_key_cdr(&topic(&a), None)
        .unwrap()
    })
    .collect();
  let mut reader: DataReader<Shape> = b
    .create_subscriber(&qos)
    .unwrap()
    .create_datareader_no_key_cdr(&topic(&b), None)
    .unwrap();
  // matching and (secured) the key exchange: until a probe gets through
  let deadline = Instant::now() + Duration::from_secs(120);
  let mut probe = PROBE;
  'matched: loop {
    assert!(Instant::now() < deadline, "matched within 120 s");
    writer
      .write(
        Shape {
          n: probe,
          stamp_ns: 0,
        },
        None,
      )
      .unwrap();
    probe += 1;
    std::thread::sleep(Duration::from_millis(100));
    while let Ok(Some(s)) = reader.take_next_sample() {
      if s.value().n >= PROBE {
        break 'matched;
      }
    }
  }
  // time for the idle writers' matching and key exchange (RustDDS's no_key writer cannot say yet)
  if idle > 0 {
    std::thread::sleep(Duration::from_secs(2) + Duration::from_millis(20) * idle as u32);
  }
  let mut stream = reader.async_sample_stream();
  std::thread::sleep(Duration::from_millis(300));
  // warm-up, then the measured runs (`SECURED_HOP_COST_N` samples back to back, default 5000, and a
  // fifth as many paced: fewer under valgrind)
  let n: u32 = std::env::var("SECURED_HOP_COST_N")
    .ok()
    .and_then(|v| v.parse().ok())
    .unwrap_or(5000);
  run(&writer, &mut stream, n / 10, None, origin);
  measured_run_begins();
  let back_to_back = run(&writer, &mut stream, n, None, origin);
  measured_run_ends();
  let rows = vec![
    back_to_back,
    run(
      &writer,
      &mut stream,
      n / 5,
      Some(Duration::from_millis(1)),
      origin,
    ),
  ];
  (rows, if secured { "secured" } else { "plain" })
}

fn main() {
  println!("| participants | back to back: CPU per sample (us) | p50 / p90 one way (us) | paced 1 ms: CPU per sample (us) | p50 / p90 one way (us) |");
  println!("|---|---:|---:|---:|---:|");
  let mut cpu = Vec::new();
  for secured in [false, true] {
    let (rows, name) = pair(secured);
    println!(
      "| {name} | {:.1} | {:.1} / {:.1} | {:.1} | {:.1} / {:.1} |",
      rows[0].cpu_per_sample_us,
      rows[0].p50_us,
      rows[0].p90_us,
      rows[1].cpu_per_sample_us,
      rows[1].p50_us,
      rows[1].p90_us
    );
    cpu.push((rows[0].cpu_per_sample_us, rows[1].cpu_per_sample_us));
  }
  println!(
    "secured extra CPU per sample: {:.1} us back to back, {:.1} us paced",
    cpu[1].0 - cpu[0].0,
    cpu[1].1 - cpu[0].1
  );
}
