//! Issue 34: encoding and decoding a payload, in this process (no DDS): a generated type
//! (`radar_ros::interfaces`, what `radar_idl::rust::Generator` writes) against the same struct written by hand
//! (the way radar_ros's `msg` types were kept before), and the tools' run-time encoding of the same message
//! from its definition (`radar_ros::codec::Interfaces`: YAML in, JSON out, as `radar inject` and `radar echo`
//! do per message). Each sample times a batch of operations and keeps the time of one.

use std::time::Instant;

use anyhow::{anyhow, Result};
use radar_ros::{
    codec::Interfaces,
    interfaces::{geometry_msgs::msg as geo, sensor_msgs::msg as sensor},
    msg::RosMessage,
    topics::RawMessage,
};
use serde::{Deserialize, Serialize};

use super::{Bench, Latency};
use crate::stats::summarize;

/// The hand-written baselines: field for field what the definitions say, as a person writes them.
mod hand {
    use super::*;

    #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
    pub struct Time {
        pub sec: i32,
        pub nanosec: u32,
    }
    #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
    pub struct Header {
        pub stamp: Time,
        pub frame_id: String,
    }
    #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
    pub struct Point {
        pub x: f64,
        pub y: f64,
        pub z: f64,
    }
    #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
    pub struct Quaternion {
        pub x: f64,
        pub y: f64,
        pub z: f64,
        pub w: f64,
    }
    #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
    pub struct Pose {
        pub position: Point,
        pub orientation: Quaternion,
    }
    #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
    pub struct PoseStamped {
        pub header: Header,
        pub pose: Pose,
    }
    radar_ros::ros_message!(PoseStamped, "geometry_msgs", "PoseStamped");
    #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
    pub struct LaserScan {
        pub header: Header,
        pub angle_min: f32,
        pub angle_max: f32,
        pub angle_increment: f32,
        pub time_increment: f32,
        pub scan_time: f32,
        pub range_min: f32,
        pub range_max: f32,
        pub ranges: Vec<f32>,
        pub intensities: Vec<f32>,
    }
    radar_ros::ros_message!(LaserScan, "sensor_msgs", "LaserScan");
}

/// The time of one call of `f`, `n` samples of `batch` calls each (ns).
fn time_each(n: usize, batch: usize, mut f: impl FnMut()) -> Vec<u64> {
    for _ in 0..batch {
        f(); // warm
    }
    (0..n)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..batch {
                f();
            }
            (t.elapsed().as_nanos() / batch as u128) as u64
        })
        .collect()
}

fn yaml_of(v: &serde_json::Value) -> yaml_serde::Value {
    yaml_serde::to_value(v).expect("JSON is YAML")
}

impl Bench {
    pub(super) async fn codec(&mut self) -> Result<()> {
        let (n, batch) = if self.opts.quick {
            (200, 20)
        } else {
            (2000, 50)
        };
        let types = Interfaces::empty();
        let mut rows: Vec<(String, String, Vec<u64>)> = Vec::new();

        // PoseStamped: a goal
        let mut generated = geo::PoseStamped::default();
        generated.header.frame_id = "map".into();
        generated.header.stamp.sec = 1_700_000_000;
        generated.pose.position.x = 1.5;
        generated.pose.orientation.w = 1.0;
        let handmade = hand::PoseStamped {
            header: hand::Header {
                stamp: hand::Time {
                    sec: 1_700_000_000,
                    nanosec: 0,
                },
                frame_id: "map".into(),
            },
            pose: hand::Pose {
                position: hand::Point {
                    x: 1.5,
                    ..Default::default()
                },
                orientation: hand::Quaternion {
                    w: 1.0,
                    ..Default::default()
                },
            },
        };
        self.codec_rows(
            &mut rows,
            "PoseStamped",
            n,
            batch,
            &types,
            &generated,
            &handmade,
        )?;

        // LaserScan: 360 ranges and intensities
        let mut generated = sensor::LaserScan::default();
        generated.header.frame_id = "laser".into();
        generated.angle_increment = 0.017_453_3;
        generated.ranges = (0..360).map(|i| 1.0 + i as f32 / 100.0).collect();
        generated.intensities = vec![100.0; 360];
        let handmade = hand::LaserScan {
            header: hand::Header {
                frame_id: "laser".into(),
                ..Default::default()
            },
            angle_increment: 0.017_453_3,
            ranges: generated.ranges.clone(),
            intensities: generated.intensities.clone(),
            ..Default::default()
        };
        self.codec_rows(
            &mut rows,
            "LaserScan (360 ranges)",
            n,
            batch / 4,
            &types,
            &generated,
            &handmade,
        )?;

        for (key, label, samples) in rows {
            let summary = summarize(&samples).ok_or_else(|| anyhow!("{label}: no samples"))?;
            self.results.codec.push(Latency {
                key,
                label,
                summary,
                missing: 0,
                note: String::new(),
                usage: None,
                samples,
            });
        }
        Ok(())
    }

    /// Encode and decode rows of one message: hand-written, generated, run-time (the bytes of all three
    /// checked equal first).
    #[allow(clippy::too_many_arguments)]
    fn codec_rows<G: RosMessage + PartialEq, H: RosMessage + PartialEq>(
        &self,
        rows: &mut Vec<(String, String, Vec<u64>)>,
        what: &str,
        n: usize,
        batch: usize,
        types: &Interfaces,
        generated: &G,
        handmade: &H,
    ) -> Result<()> {
        let ty = G::ros_type_name();
        let bytes = RawMessage::encode(generated)?;
        if RawMessage::encode(handmade)? != bytes {
            return Err(anyhow!(
                "{what}: the hand-written struct encodes other bytes"
            ));
        }
        let as_json = types.decode(&ty, &bytes).map_err(|e| anyhow!("{e}"))?;
        let yaml = yaml_of(&as_json);
        if types.encode(&ty, &yaml).map_err(|e| anyhow!("{e}"))? != bytes {
            return Err(anyhow!("{what}: the run-time encoding differs"));
        }
        let key = what.split(' ').next().unwrap_or(what).to_lowercase();
        let mut row = |k: &str, label: &str, s: Vec<u64>| {
            rows.push((format!("codec_{key}_{k}"), format!("{what}: {label}"), s));
        };
        row(
            "encode_hand",
            "encode, hand-written struct",
            time_each(n, batch, || {
                std::hint::black_box(RawMessage::encode(std::hint::black_box(handmade)).unwrap());
            }),
        );
        row(
            "encode_generated",
            "encode, generated type",
            time_each(n, batch, || {
                std::hint::black_box(RawMessage::encode(std::hint::black_box(generated)).unwrap());
            }),
        );
        row(
            "encode_runtime",
            "encode at run time from YAML (radar inject)",
            time_each(n, batch, || {
                std::hint::black_box(types.encode(&ty, std::hint::black_box(&yaml)).unwrap());
            }),
        );
        row(
            "decode_hand",
            "decode, hand-written struct",
            time_each(n, batch, || {
                std::hint::black_box(std::hint::black_box(&bytes).decode::<H>().unwrap());
            }),
        );
        row(
            "decode_generated",
            "decode, generated type",
            time_each(n, batch, || {
                std::hint::black_box(std::hint::black_box(&bytes).decode::<G>().unwrap());
            }),
        );
        row(
            "decode_runtime",
            "decode at run time to JSON (radar echo)",
            time_each(n, batch, || {
                std::hint::black_box(types.decode(&ty, std::hint::black_box(&bytes)).unwrap());
            }),
        );
        Ok(())
    }
}
