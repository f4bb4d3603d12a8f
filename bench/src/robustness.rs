//! Child roles of the robustness scenarios: how radar_ros fares with what ROS users really do to it, a fresh
//! process per one-shot publish, a long run of state changes, a deliberative program killed with SIGKILL.

use std::time::Duration;

use anyhow::{anyhow, bail, Result};
use radar_ros::{
    msg::{
        ConnectRequest, ConnectResponse, Connection as ConnectionMsg, Empty, Header, RosMessage,
    },
    FnResponse, Radar, SlotError,
};
use ros2_client::{dds::ServiceMapping, Name, NodeName, NodeOptions, ServiceTypeName};
use serde_json::json;

use crate::{
    baseline::{raw_node, WAIT},
    clock::{now_ns, stamped},
    proto::{reply, rss_bytes, Commands},
};

/// RSS samples `(work done, bytes)` at ten evenly spaced points of `steps` steps of `per_step` work each.
struct RssSamples {
    steps: u64,
    per_step: u64,
    every: u64,
    taken: Vec<(u64, u64)>,
}

impl RssSamples {
    fn new(total: u64, per_step: u64) -> RssSamples {
        let steps = total.div_ceil(per_step);
        RssSamples {
            steps,
            per_step,
            every: (steps / 10).max(1),
            taken: vec![(0, rss_bytes())],
        }
    }

    /// Call after step `i` (0-based).
    fn after(&mut self, i: u64) {
        if (i + 1).is_multiple_of(self.every) || i + 1 == self.steps {
            self.taken.push(((i + 1) * self.per_step, rss_bytes()));
        }
    }
}

/// Runs per second of [`state_churn`]: 3,000 state changes a second, far more than a robot's responses
/// make, yet slow enough that RustDDS's periodic cache cleaning (every 4 s) runs many times during the run,
/// so the RSS shows the steady state rather than what is waiting for the next cleaning.
const CHURN_RUNS_PER_SECOND: u64 = 1000;

/// A response whose start behaviour returns at once, driven from this process through `changes` state
/// changes (3 per run: running, exiting, idle; [`CHURN_RUNS_PER_SECOND`] runs a second) with nobody
/// subscribed to its `state`. Answers `run` with the process's RSS along the way.
pub async fn state_churn(changes: u64) -> Result<()> {
    let radar = Radar::new()?;
    let resp = radar.spawn_response(
        "/bench/churn",
        FnResponse::new(|_: Empty| async { Ok::<_, SlotError>(Empty::default()) }),
    )?;
    let start = radar.signal_publisher::<Empty>("/bench/churn/start")?;
    start.wait_for_subscribers(1).timeout(WAIT).await?;
    let mut state = resp.watch_state();
    reply("ready");
    let mut cmds = Commands::new();
    while let Some(w) = cmds.next().await {
        if w[0] != "run" {
            reply(format!("error unknown command {}", w[0]));
            continue;
        }
        let t = now_ns();
        let mut rss = RssSamples::new(changes, 3);
        let begin = tokio::time::Instant::now();
        let period = Duration::from_secs(1) / CHURN_RUNS_PER_SECOND as u32;
        for i in 0..rss.steps {
            tokio::time::sleep_until(begin + period * i as u32).await;
            start.publish(Empty::default())?;
            let done = state.wait_for(|s| s.exits > i && s.state_label == "idle");
            tokio::time::timeout(WAIT, done)
                .await
                .map_err(|_| anyhow!("run {i} did not end within {WAIT:?}"))??;
            rss.after(i);
        }
        let rss = rss.taken;
        reply(json!({ "rss": rss, "secs": (now_ns() - t) as f64 / 1e9 }));
    }
    Ok(())
}

/// The baseline of [`state_churn`]: a raw ros2-client writer with the same QoS as a `state` topic
/// (transient-local, keep-last 1), written `writes` times with nobody subscribed.
pub async fn raw_latched(writes: u64) -> Result<()> {
    let (_ctx, mut node) = raw_node("latched")?;
    let qos = radar_ros::qos::state_qos();
    let t = node
        .create_topic(
            &Name::parse("/bench/latched").map_err(|e| anyhow!("{e:?}"))?,
            Header::message_type_name(),
            &qos,
        )
        .map_err(|e| anyhow!("topic: {e:?}"))?;
    let p = node
        .create_publisher::<Header>(&t, Some(qos))
        .map_err(|e| anyhow!("publisher: {e:?}"))?;
    reply("ready");
    let mut cmds = Commands::new();
    while let Some(w) = cmds.next().await {
        if w[0] != "run" {
            reply(format!("error unknown command {}", w[0]));
            continue;
        }
        let t = now_ns();
        let mut rss = RssSamples::new(writes, 1);
        let begin = tokio::time::Instant::now();
        // as often as the response's state changes in `state_churn`
        let period = Duration::from_secs(1) / (3 * CHURN_RUNS_PER_SECOND) as u32;
        for i in 0..rss.steps {
            if i.is_multiple_of(3) {
                tokio::time::sleep_until(begin + period * i as u32).await;
            }
            p.publish(stamped(i))
                .map_err(|e| anyhow!("publish: {e:?}"))?;
            rss.after(i);
        }
        let rss = rss.taken;
        reply(json!({ "rss": rss, "secs": (now_ns() - t) as f64 / 1e9 }));
    }
    Ok(())
}

/// A standalone connection manager node named `name` (as the `radar_manager` binary). `wait-empty` answers,
/// on the shared clock, when its last connection was removed.
pub async fn service_manager(name: &str) -> Result<()> {
    let radar = Radar::new()?;
    let _m = radar.serve_manager(name)?;
    reply("ready");
    let mut cmds = Commands::new();
    while let Some(w) = cmds.next().await {
        let answer = match w[0].as_str() {
            "count" => Ok(radar.connections().len().to_string()),
            "wait-empty" => wait_until(|| radar.connections().is_empty(), Duration::from_secs(120))
                .await
                .map(|t| t.to_string()),
            c => Err(anyhow!("unknown command {c}")),
        };
        reply(answer.unwrap_or_else(|e| format!("error {e:#}")));
    }
    Ok(())
}

/// Polls `cond` every millisecond; the shared-clock time it first held.
pub async fn wait_until(cond: impl Fn() -> bool, timeout: Duration) -> Result<u64> {
    let deadline = tokio::time::Instant::now() + timeout;
    while !cond() {
        if tokio::time::Instant::now() > deadline {
            bail!("not within {timeout:?}");
        }
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    Ok(now_ns())
}

/// A deliberative program that makes `whenever SOURCE start TARGET` through the `connect` service of the
/// manager node `manager`, then stays (to be killed).
pub async fn service_caller(manager: &str, source: &str, target: &str) -> Result<()> {
    let radar = Radar::new()?;
    let mut node = radar
        .dds_context()
        .ok_or_else(|| anyhow!("the bench runs over DDS"))?
        .new_node(
            NodeName::new("/bench", "caller").map_err(|e| anyhow!("{e:?}"))?,
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .map_err(|e| anyhow!("node: {e:?}"))?;
    let q = radar_ros::qos::signal_qos();
    let client = node
        .create_client::<ConnectRequest, ConnectResponse>(
            ServiceMapping::Enhanced,
            &Name::new(manager, "connect").map_err(|e| anyhow!("{e:?}"))?,
            &ServiceTypeName::new("radar_msgs", "Connect"),
            q.clone(),
            q,
        )
        .map_err(|e| anyhow!("client: {e:?}"))?;
    let req = ConnectRequest {
        kind: ConnectionMsg::WHENEVER,
        source: source.to_owned(),
        target: target.to_owned(),
        ..Default::default()
    };
    // the server may not be discovered yet: ask again until it answers
    let deadline = tokio::time::Instant::now() + WAIT;
    let resp = loop {
        if tokio::time::Instant::now() > deadline {
            bail!("{manager}/connect did not answer within {WAIT:?}");
        }
        let id = client
            .async_send_request(req.clone())
            .await
            .map_err(|e| anyhow!("request: {e:?}"))?;
        if let Ok(Ok(r)) = tokio::time::timeout(
            Duration::from_millis(500),
            client.async_receive_response(id),
        )
        .await
        {
            break r;
        }
    };
    if !resp.ok {
        bail!("connect refused: {}", resp.error);
    }
    reply("ready");
    let mut cmds = Commands::new();
    while cmds.next().await.is_some() {
        reply("error this role only waits to be killed");
    }
    Ok(())
}
