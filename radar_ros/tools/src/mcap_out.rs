//! An MCAP writer for recordings that may be cut off: every chunk it writes leaves a complete, readable file.
//!
//! A recorder that buffers until it is told to stop loses everything when it is killed instead (SIGKILL, the
//! OOM killer, a power cut) and, if it misses SIGTERM, when it is stopped the usual way. This writer holds
//! at most one chunk in memory (its caller commits one at least every second or so, and at
//! [`ChunkLimits::bytes`]). Each commit writes, in one write call at the end of the data section,
//!
//! ```text
//! Chunk (schemas, channels, messages) | MessageIndex per channel | DataEnd | Footer (no summary) | magic
//! ```
//!
//! and syncs the file, so after every commit the file is a whole MCAP file: readers that look for the footer
//! first (the Python `mcap` reader's `make_reader` on a file, Foxglove) find one saying there is no summary
//! and read the data section straight through; stream readers see every chunk. The next commit writes its
//! chunk over the old `DataEnd`/`Footer`. [`McapOut::finish`] writes the summary (schemas, channels,
//! statistics, chunk indexes, summary offsets) so readers can seek, as rosbag2's files allow.
//!
//! What can be lost: the messages of the chunk not yet committed (at most one commit period), and, if the
//! machine loses power during the single write of a commit, that commit (readers that stream still read the
//! chunks before it).

use std::{
    collections::BTreeMap,
    fs::File,
    io::{Seek, SeekFrom, Write},
    time::{Duration, Instant},
};

const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";

mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const STATISTICS: u8 = 0x0b;
    pub const SUMMARY_OFFSET: u8 = 0x0e;
    pub const DATA_END: u8 = 0x0f;
}

/// When the open chunk is committed to the file.
#[derive(Clone, Copy, Debug)]
pub struct ChunkLimits {
    /// Commit once the chunk holds this many bytes.
    pub bytes: usize,
    /// [`McapOut::commit_if_due`] commits a chunk this old.
    pub age: Duration,
}

impl Default for ChunkLimits {
    /// 256 KiB or half a second, whichever comes first.
    fn default() -> ChunkLimits {
        ChunkLimits {
            bytes: 256 * 1024,
            age: Duration::from_millis(500),
        }
    }
}

/// A message to write: on which channel, its times (ns since the epoch) and its encoded bytes.
#[derive(Clone, Copy, Debug)]
pub struct MessageOut<'a> {
    /// From [`McapOut::add_channel`].
    pub channel: u16,
    /// Its number on the channel.
    pub sequence: u32,
    /// When it was received.
    pub log_time: u64,
    /// When it was sent.
    pub publish_time: u64,
    /// The message as its channel encodes it (for `cdr`: the 4-byte encapsulation header, then the body).
    pub data: &'a [u8],
}

/// An MCAP file written chunk by chunk, whole after every commit (see the module docs).
pub struct McapOut {
    file: File,
    /// Where the data section ends: the next chunk (and the rolling DataEnd/Footer) goes here.
    end: u64,
    /// CRC of the data section up to `end`.
    data_crc: crc32fast::Hasher,
    limits: ChunkLimits,
    schemas: Vec<Record>,
    channels: Vec<Record>,
    chunk: OpenChunk,
    chunk_indexes: Vec<Record>,
    stats: Stats,
}

/// An encoded record kept for the summary.
struct Record(Vec<u8>);

#[derive(Default)]
struct OpenChunk {
    records: Vec<u8>,
    /// Per channel: (log time, offset of the message in `records`).
    index: BTreeMap<u16, Vec<(u64, u64)>>,
    times: Option<(u64, u64)>,
    opened: Option<Instant>,
}

#[derive(Default)]
struct Stats {
    messages: u64,
    chunks: u32,
    times: Option<(u64, u64)>,
    per_channel: BTreeMap<u16, u64>,
}

fn widen(times: &mut Option<(u64, u64)>, t: u64) {
    *times = Some(match *times {
        None => (t, t),
        Some((a, b)) => (a.min(t), b.max(t)),
    });
}

/// Little-endian MCAP field encoding.
#[derive(Default)]
struct Body(Vec<u8>);

impl Body {
    fn u8(mut self, v: u8) -> Body {
        self.0.push(v);
        self
    }
    fn u16(mut self, v: u16) -> Body {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u32(mut self, v: u32) -> Body {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn u64(mut self, v: u64) -> Body {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }
    fn str(self, s: &str) -> Body {
        self.u32(s.len() as u32).raw(s.as_bytes())
    }
    fn bytes32(self, b: &[u8]) -> Body {
        self.u32(b.len() as u32).raw(b)
    }
    fn raw(mut self, b: &[u8]) -> Body {
        self.0.extend_from_slice(b);
        self
    }
    /// A map or array: its byte length (u32), then its entries.
    fn prefixed(self, entries: Body) -> Body {
        self.bytes32(&entries.0)
    }
    fn record(self, opcode: u8) -> Vec<u8> {
        let mut r = Vec::with_capacity(9 + self.0.len());
        r.push(opcode);
        r.extend_from_slice(&(self.0.len() as u64).to_le_bytes());
        r.extend_from_slice(&self.0);
        r
    }
}

/// DataEnd, a Footer saying there is no summary, the closing magic.
fn rolling_tail(data_crc: u32) -> Vec<u8> {
    let mut t = Body::default().u32(data_crc).record(op::DATA_END);
    t.extend(Body::default().u64(0).u64(0).u32(0).record(op::FOOTER));
    t.extend_from_slice(MAGIC);
    t
}

impl McapOut {
    /// Starts an MCAP file (profile `ros2`, as rosbag2 writes) in `file`, which must be empty.
    pub fn create(file: File, limits: ChunkLimits) -> std::io::Result<McapOut> {
        let mut start = MAGIC.to_vec();
        let library = format!("radar_tools {}", env!("CARGO_PKG_VERSION"));
        start.extend(Body::default().str("ros2").str(&library).record(op::HEADER));
        let mut data_crc = crc32fast::Hasher::new();
        data_crc.update(&start);
        let mut out = McapOut {
            file,
            end: start.len() as u64,
            data_crc,
            limits,
            schemas: Vec::new(),
            channels: Vec::new(),
            chunk: OpenChunk::default(),
            chunk_indexes: Vec::new(),
            stats: Stats::default(),
        };
        start.extend(rolling_tail(out.data_crc.clone().finalize()));
        out.write_at(0, &start)?;
        Ok(out)
    }

    /// Adds a schema (e.g. `ros2msg`, its definition): its id for [`McapOut::add_channel`]. It goes into the
    /// open chunk, so a reader of any cut-off file meets it before the messages that use it.
    pub fn add_schema(&mut self, name: &str, encoding: &str, data: &[u8]) -> u16 {
        let id = self.schemas.len() as u16 + 1;
        let r = Body::default()
            .u16(id)
            .str(name)
            .str(encoding)
            .bytes32(data)
            .record(op::SCHEMA);
        self.chunk.records.extend_from_slice(&r);
        self.schemas.push(Record(r));
        id
    }

    /// Adds a channel (a topic with its schema and message encoding, e.g. `cdr`): its id for messages.
    pub fn add_channel(&mut self, schema: u16, topic: &str, message_encoding: &str) -> u16 {
        let id = self.channels.len() as u16;
        let r = Body::default()
            .u16(id)
            .u16(schema)
            .str(topic)
            .str(message_encoding)
            .prefixed(Body::default())
            .record(op::CHANNEL);
        self.chunk.records.extend_from_slice(&r);
        self.channels.push(Record(r));
        id
    }

    /// Adds a message to the open chunk; commits the chunk if it reached [`ChunkLimits::bytes`].
    pub fn write(&mut self, m: MessageOut<'_>) -> std::io::Result<()> {
        let c = &mut self.chunk;
        c.opened.get_or_insert_with(Instant::now);
        c.index
            .entry(m.channel)
            .or_default()
            .push((m.log_time, c.records.len() as u64));
        let r = Body::default()
            .u16(m.channel)
            .u32(m.sequence)
            .u64(m.log_time)
            .u64(m.publish_time)
            .raw(m.data)
            .record(op::MESSAGE);
        c.records.extend_from_slice(&r);
        widen(&mut c.times, m.log_time);
        widen(&mut self.stats.times, m.log_time);
        self.stats.messages += 1;
        *self.stats.per_channel.entry(m.channel).or_default() += 1;
        if c.records.len() >= self.limits.bytes {
            self.commit()?;
        }
        Ok(())
    }

    /// Commits the open chunk if it holds a message that waited [`ChunkLimits::age`].
    pub fn commit_if_due(&mut self) -> std::io::Result<()> {
        match self.chunk.opened {
            Some(t) if t.elapsed() >= self.limits.age => self.commit(),
            _ => Ok(()),
        }
    }

    /// Writes the open chunk (if it holds anything) and its message indexes, with a closing DataEnd and
    /// Footer after them, in one write, and syncs the file: the file is whole and holds every message so far.
    pub fn commit(&mut self) -> std::io::Result<()> {
        let c = std::mem::take(&mut self.chunk);
        if c.records.is_empty() {
            return Ok(());
        }
        let (start_time, end_time) = c.times.unwrap_or((0, 0));
        let chunk = Body::default()
            .u64(start_time)
            .u64(end_time)
            .u64(c.records.len() as u64)
            .u32(crc32fast::hash(&c.records))
            .str("")
            .u64(c.records.len() as u64)
            .raw(&c.records)
            .record(op::CHUNK);
        let chunk_start = self.end;
        let mut bytes = chunk;
        let chunk_length = bytes.len() as u64;
        let mut index_offsets = Body::default();
        for (channel, entries) in &c.index {
            index_offsets = index_offsets
                .u16(*channel)
                .u64(chunk_start + bytes.len() as u64);
            let mut list = Body::default();
            for (t, offset) in entries {
                list = list.u64(*t).u64(*offset);
            }
            bytes.extend(
                Body::default()
                    .u16(*channel)
                    .prefixed(list)
                    .record(op::MESSAGE_INDEX),
            );
        }
        let index_length = bytes.len() as u64 - chunk_length;
        self.chunk_indexes.push(Record(
            Body::default()
                .u64(start_time)
                .u64(end_time)
                .u64(chunk_start)
                .u64(chunk_length)
                .prefixed(index_offsets)
                .u64(index_length)
                .str("")
                .u64(c.records.len() as u64)
                .u64(c.records.len() as u64)
                .record(op::CHUNK_INDEX),
        ));
        self.stats.chunks += 1;
        self.data_crc.update(&bytes);
        self.end += bytes.len() as u64;
        bytes.extend(rolling_tail(self.data_crc.clone().finalize()));
        self.write_at(chunk_start, &bytes)
    }

    /// Commits the open chunk and writes the summary and the footer that points at it. The file is complete.
    pub fn finish(mut self) -> std::io::Result<()> {
        self.commit()?;
        let mut tail = Body::default()
            .u32(self.data_crc.clone().finalize())
            .record(op::DATA_END);
        let summary_start = self.end + tail.len() as u64;
        let mut summary = Vec::new();
        let mut groups = Vec::new();
        let stats = self.statistics();
        for (opcode, records) in [
            (op::SCHEMA, &self.schemas),
            (op::CHANNEL, &self.channels),
            (op::STATISTICS, &vec![stats]),
            (op::CHUNK_INDEX, &self.chunk_indexes),
        ] {
            if records.is_empty() {
                continue;
            }
            let start = summary_start + summary.len() as u64;
            for r in records {
                summary.extend_from_slice(&r.0);
            }
            let length = summary_start + summary.len() as u64 - start;
            groups.push((opcode, start, length));
        }
        let summary_offset_start = summary_start + summary.len() as u64;
        for (opcode, start, length) in groups {
            summary.extend(
                Body::default()
                    .u8(opcode)
                    .u64(start)
                    .u64(length)
                    .record(op::SUMMARY_OFFSET),
            );
        }
        // the footer's CRC covers the summary section and the footer's fields before it
        let footer_fields = Body::default().u64(summary_start).u64(summary_offset_start);
        let mut footer = footer_fields.record(op::FOOTER);
        // the record's length counts the CRC too
        footer[1..9].copy_from_slice(&20u64.to_le_bytes());
        let mut crc = crc32fast::Hasher::new();
        crc.update(&summary);
        crc.update(&footer);
        footer.extend_from_slice(&crc.finalize().to_le_bytes());
        tail.extend(summary);
        tail.extend(footer);
        tail.extend_from_slice(MAGIC);
        let at = self.end;
        self.write_at(at, &tail)
    }

    fn statistics(&self) -> Record {
        let (start, end) = self.stats.times.unwrap_or((0, 0));
        let mut counts = Body::default();
        for (channel, n) in &self.stats.per_channel {
            counts = counts.u16(*channel).u64(*n);
        }
        Record(
            Body::default()
                .u64(self.stats.messages)
                .u16(self.schemas.len() as u16)
                .u32(self.channels.len() as u32)
                .u32(0)
                .u32(0)
                .u32(self.stats.chunks)
                .u64(start)
                .u64(end)
                .prefixed(counts)
                .record(op::STATISTICS),
        )
    }

    /// One write at `at`, the file cut just after it, and synced: what is on disk is a whole MCAP file.
    fn write_at(&mut self, at: u64, bytes: &[u8]) -> std::io::Result<()> {
        self.file.seek(SeekFrom::Start(at))?;
        self.file.write_all(bytes)?;
        self.file.set_len(at + bytes.len() as u64)?;
        self.file.sync_data()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str) -> (std::path::PathBuf, File) {
        let dir = std::env::temp_dir().join(format!("mcap_out_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        let f = std::fs::OpenOptions::new()
            .create(true)
            .truncate(true)
            .read(true)
            .write(true)
            .open(&path)
            .unwrap();
        (path, f)
    }

    /// The messages an independent reader (the `mcap` crate) finds: (topic, schema name, log time, data).
    fn read(bytes: &[u8]) -> Vec<(String, String, u64, Vec<u8>)> {
        mcap::MessageStream::new(bytes)
            .unwrap()
            .map(|m| {
                let m = m.unwrap();
                let schema = m.channel.schema.as_ref().unwrap().name.clone();
                (m.channel.topic.clone(), schema, m.log_time, m.data.to_vec())
            })
            .collect()
    }

    fn message(channel: u16, n: u32) -> (MessageOut<'static>, Vec<u8>) {
        let data: &'static [u8] = Box::leak(vec![0, 1, 0, 0, n as u8].into_boxed_slice());
        let m = MessageOut {
            channel,
            sequence: n,
            log_time: 1_000 + n as u64,
            publish_time: 900 + n as u64,
            data,
        };
        (m, data.to_vec())
    }

    #[test]
    fn a_finished_file_has_every_message_and_a_summary_readers_seek_with() {
        let (path, f) = temp("finished.mcap");
        let mut w = McapOut::create(f, ChunkLimits::default()).unwrap();
        let s = w.add_schema("std_msgs/msg/Empty", "ros2msg", b"");
        let a = w.add_channel(s, "/a/started", "cdr");
        let b = w.add_channel(s, "/b/exited", "cdr");
        for n in 0..10 {
            w.write(message(if n % 2 == 0 { a } else { b }, n).0)
                .unwrap();
            if n == 4 {
                w.commit().unwrap();
            }
        }
        w.finish().unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let got = read(&bytes);
        assert_eq!(got.len(), 10);
        assert_eq!(got[3].0, "/b/exited");
        assert_eq!(got[3].1, "std_msgs/msg/Empty");
        assert_eq!(got[3].3, message(b, 3).1);
        let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
        assert_eq!(summary.chunk_indexes.len(), 2);
        assert_eq!(summary.channels.len(), 2);
        let stats = summary.stats.clone().expect("statistics");
        assert_eq!((stats.message_count, stats.chunk_count), (10, 2));
        assert_eq!(
            (stats.message_start_time, stats.message_end_time),
            (1_000, 1_009)
        );
        // the chunk indexes and message indexes point at the right places
        let mut indexed = 0;
        for ci in &summary.chunk_indexes {
            let idx = summary.read_message_indexes(&bytes, ci).unwrap();
            for entries in idx.values() {
                for e in entries {
                    summary.seek_message(&bytes, ci, e).unwrap();
                    indexed += 1;
                }
            }
        }
        assert_eq!(indexed, 10);
    }

    #[test]
    fn a_file_cut_after_a_commit_is_whole_and_holds_what_was_committed() {
        let (path, f) = temp("cut.mcap");
        let mut w = McapOut::create(f, ChunkLimits::default()).unwrap();
        // a file with nothing in it yet is already whole
        assert!(read(&std::fs::read(&path).unwrap()).is_empty());
        let s = w.add_schema("std_msgs/msg/Empty", "ros2msg", b"");
        let a = w.add_channel(s, "/a/started", "cdr");
        for n in 0..3 {
            w.write(message(a, n).0).unwrap();
        }
        w.commit().unwrap();
        for n in 3..5 {
            w.write(message(a, n).0).unwrap();
        }
        // killed here: the file on disk is what a reader gets
        let bytes = std::fs::read(&path).unwrap();
        let got = read(&bytes);
        assert_eq!(
            got.iter().map(|m| m.2).collect::<Vec<_>>(),
            [1_000, 1_001, 1_002]
        );
        assert_eq!(&bytes[bytes.len() - 8..], MAGIC);
        assert!(
            mcap::Summary::read(&bytes).unwrap().is_none(),
            "the footer says there is no summary"
        );
        // the next commit goes over the rolling footer
        w.commit().unwrap();
        assert_eq!(read(&std::fs::read(&path).unwrap()).len(), 5);
        drop(w);
    }

    #[test]
    fn a_chunk_is_committed_when_it_reaches_its_size_or_its_age() {
        let (path, f) = temp("limits.mcap");
        let limits = ChunkLimits {
            bytes: 250,
            age: Duration::from_millis(30),
        };
        let mut w = McapOut::create(f, limits).unwrap();
        let s = w.add_schema("std_msgs/msg/Empty", "ros2msg", b"");
        let a = w.add_channel(s, "/a/started", "cdr");
        // the schema record is 48 bytes, the channel's 38, a message's 36: the 5th message passes 250
        for n in 0..4 {
            w.write(message(a, n).0).unwrap();
        }
        assert!(read(&std::fs::read(&path).unwrap()).is_empty());
        w.write(message(a, 4).0).unwrap();
        assert_eq!(read(&std::fs::read(&path).unwrap()).len(), 5);
        w.write(message(a, 5).0).unwrap();
        w.commit_if_due().unwrap();
        assert_eq!(read(&std::fs::read(&path).unwrap()).len(), 5, "not due yet");
        std::thread::sleep(Duration::from_millis(40));
        w.commit_if_due().unwrap();
        assert_eq!(read(&std::fs::read(&path).unwrap()).len(), 6);
    }
}
