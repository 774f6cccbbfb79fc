//! TensorBoard event files (`events.out.tfevents.*`), written directly: no maintained crate
//! writes them (`tensorboard-rs` is archived and pulls protobuf 2 and image 0.23), and scalars
//! need only a few protobuf fields.
//!
//! A file is a sequence of TFRecords — `u64` length, masked CRC-32C of the length, the bytes,
//! masked CRC-32C of the bytes — each holding one `tensorflow.Event` message: `wall_time`
//! (field 1, double), `step` (2, int64) and either `file_version` (3, string) or a `Summary`
//! (5) of `Summary.Value`s with `tag` (1, string) and `simple_value` (2, float).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use crate::RlError;

/// Appends scalar summaries to one event file in a run directory.
pub struct EventWriter {
    path: PathBuf,
    out: BufWriter<File>,
}

impl EventWriter {
    /// Creates `events.out.tfevents.<unix seconds>.orbit-rs` in `dir` and writes the file
    /// version record TensorBoard expects first.
    pub fn create(dir: &Path) -> Result<Self, RlError> {
        let now = unix_time();
        let path = dir.join(format!("events.out.tfevents.{}.orbit-rs", now as u64));
        let file = File::create(&path).map_err(RlError::io(&path))?;
        let mut writer = Self {
            path,
            out: BufWriter::new(file),
        };
        let mut event = Vec::new();
        event_header(&mut event, now, 0);
        put_bytes(&mut event, 3, b"brain.Event:2");
        writer.record(&event)?;
        writer.flush()?;
        Ok(writer)
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends one event holding the scalars `(tag, value)` at `step`, stamped with the
    /// current time.
    pub fn add_scalars<'a>(
        &mut self,
        step: u64,
        scalars: impl IntoIterator<Item = (&'a str, f32)>,
    ) -> Result<(), RlError> {
        let event = scalar_event(unix_time(), step, scalars);
        self.record(&event)
    }

    /// Flushes buffered records to the file.
    pub fn flush(&mut self) -> Result<(), RlError> {
        self.out.flush().map_err(RlError::io(&self.path))
    }

    fn record(&mut self, data: &[u8]) -> Result<(), RlError> {
        let len = (data.len() as u64).to_le_bytes();
        let mut bytes = Vec::with_capacity(data.len() + 16);
        bytes.extend_from_slice(&len);
        bytes.extend_from_slice(&masked_crc(&len).to_le_bytes());
        bytes.extend_from_slice(data);
        bytes.extend_from_slice(&masked_crc(data).to_le_bytes());
        self.out.write_all(&bytes).map_err(RlError::io(&self.path))
    }
}

fn unix_time() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

/// TFRecord's checksum: CRC-32C rotated right by 15 bits plus a constant.
fn masked_crc(data: &[u8]) -> u32 {
    let crc = crc32c::crc32c(data);
    crc.rotate_right(15).wrapping_add(0xa282_ead8)
}

/// An `Event` with a `Summary` of simple values.
fn scalar_event<'a>(
    wall_time: f64,
    step: u64,
    scalars: impl IntoIterator<Item = (&'a str, f32)>,
) -> Vec<u8> {
    let mut summary = Vec::new();
    let mut value = Vec::new();
    for (tag, x) in scalars {
        value.clear();
        put_bytes(&mut value, 1, tag.as_bytes());
        put_key(&mut value, 2, WIRE_FIXED32);
        value.extend_from_slice(&x.to_le_bytes());
        put_bytes(&mut summary, 1, &value);
    }
    let mut event = Vec::new();
    event_header(&mut event, wall_time, step);
    put_bytes(&mut event, 5, &summary);
    event
}

const WIRE_VARINT: u64 = 0;
const WIRE_FIXED64: u64 = 1;
const WIRE_LEN: u64 = 2;
const WIRE_FIXED32: u64 = 5;

fn put_varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn put_key(out: &mut Vec<u8>, field: u64, wire: u64) {
    put_varint(out, (field << 3) | wire);
}

fn put_bytes(out: &mut Vec<u8>, field: u64, bytes: &[u8]) {
    put_key(out, field, WIRE_LEN);
    put_varint(out, bytes.len() as u64);
    out.extend_from_slice(bytes);
}

/// `wall_time` and `step` of an `Event`.
fn event_header(out: &mut Vec<u8>, wall_time: f64, step: u64) {
    put_key(out, 1, WIRE_FIXED64);
    out.extend_from_slice(&wall_time.to_le_bytes());
    put_key(out, 2, WIRE_VARINT);
    put_varint(out, step);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CRC-32C's published check value, and TFRecord's mask applied to it by hand:
    /// 0xe3069283 rotated right by 15 is 0x2507c60d, plus 0xa282ead8 is 0xc78ab0e5 (mod 2³²).
    #[test]
    fn masked_crc_of_the_check_string() {
        assert_eq!(crc32c::crc32c(b"123456789"), 0xe306_9283);
        assert_eq!(masked_crc(b"123456789"), 0xc78a_b0e5);
    }

    /// An event's bytes against the protobuf wire format worked out by hand.
    #[test]
    fn scalar_event_wire_format() {
        let event = scalar_event(1.5, 300, [("a/b", 2.0f32)]);
        let mut expected = vec![0x09];
        expected.extend_from_slice(&1.5f64.to_le_bytes());
        // step 300 = 0b1_0010_1100: varint bytes 0xac 0x02.
        expected.extend_from_slice(&[0x10, 0xac, 0x02]);
        // summary (field 5) of one value (field 1): tag (field 1) "a/b", simple_value (field 2).
        expected.extend_from_slice(&[0x2a, 12, 0x0a, 10, 0x0a, 3, b'a', b'/', b'b', 0x15]);
        expected.extend_from_slice(&2.0f32.to_le_bytes());
        assert_eq!(event, expected);
    }

    /// A written file is a sequence of records whose lengths and checksums verify.
    #[test]
    fn records_verify() {
        let dir = std::env::temp_dir().join(format!("orbit-tb-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut w = EventWriter::create(&dir).unwrap();
        w.add_scalars(1, [("x", 1.0), ("y", -2.5)]).unwrap();
        w.add_scalars(2, [("x", 3.0)]).unwrap();
        w.flush().unwrap();
        let bytes = std::fs::read(w.path()).unwrap();
        let mut at = 0;
        let mut records = Vec::new();
        while at < bytes.len() {
            let len_bytes = &bytes[at..at + 8];
            let len = u64::from_le_bytes(len_bytes.try_into().unwrap()) as usize;
            let crc = u32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
            assert_eq!(crc, masked_crc(len_bytes));
            let data = &bytes[at + 12..at + 12 + len];
            let crc = u32::from_le_bytes(bytes[at + 12 + len..at + 16 + len].try_into().unwrap());
            assert_eq!(crc, masked_crc(data));
            records.push(data.to_vec());
            at += 16 + len;
        }
        assert_eq!(at, bytes.len());
        assert_eq!(records.len(), 3);
        assert!(records[0].ends_with(b"brain.Event:2"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
