//! The Zenoh baseline's roles (the `zenoh` feature): raw ros2-client over its Zenoh backend, as a user would
//! write it without radar_ros, with the same message, QoS and stamps as the DDS baseline ([`super::raw`]); and
//! a Zenoh router as rmw_zenoh's `rmw_zenohd` configures one. The session of each comes from the environment
//! as rmw_zenoh's does (`ZENOH_CONFIG_OVERRIDE`, set by the coordinator: which router, peer or client).

use super::*;
use radar_ros::msg::RosMessage;
use ros2_client::{
    zenoh::{register_type_hash, Context, ContextOptions, Node, Publisher, Subscription},
    Name, NodeName, NodeOptions,
};

/// A Zenoh context and node in `ROS_DOMAIN_ID`, with the message's rosidl hash given to the backend (as
/// radar_ros gives it), no rosout.
fn zenoh_node(name: &str) -> Result<(Context, Node)> {
    let domain = radar_ros::settings::domain_id_from_env()?;
    let dds_type = Header::message_type_name().dds_msg_type();
    if let Some(hash) = Header::TYPE_HASH {
        register_type_hash(&dds_type, hash).map_err(|e| anyhow!("{e}"))?;
    }
    let ctx = Context::with_options(ContextOptions::new().domain_id(domain))
        .map_err(|e| anyhow!("a Zenoh context: {e:?}"))?;
    let node = ctx
        .new_node(
            NodeName::new("/bench", name).map_err(|e| anyhow!("{e:?}"))?,
            NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow!("a Zenoh node: {e:?}"))?;
    Ok((ctx, node))
}

fn topic(node: &Node, topic: &str) -> Result<ros2_client::zenoh::Topic> {
    Ok(node.create_topic(
        &Name::parse(topic).map_err(|e| anyhow!("{topic}: {e:?}"))?,
        Header::message_type_name(),
        &radar_ros::qos::signal_qos(),
    ))
}

/// Subscribes to `topic` over Zenoh and records each sample's age when it is taken (as `raw-sink`).
pub(super) async fn zenoh_sink(name: &str) -> Result<()> {
    let (_ctx, node) = zenoh_node("zenoh_sink")?;
    let sub: Subscription<Header> = node
        .create_subscription(&topic(&node, name)?, None)
        .map_err(|e| anyhow!("subscription {name}: {e:?}"))?;
    let rec = Record::default();
    let r = rec.clone();
    tokio::spawn(async move {
        let stream = sub.async_stream();
        futures::pin_mut!(stream);
        while let Some(Ok((h, _))) = stream.next().await {
            let age = age_ns(&h);
            r.push(unstamp(&h).0, age);
        }
    });
    serve_reports(rec).await;
    Ok(())
}

/// Publishes stamped samples on `topic` over Zenoh: `wait` (for a subscription in the graph), `run N
/// PERIOD_US` (as `raw-source`).
pub(super) async fn zenoh_source(name: &str) -> Result<()> {
    let (_ctx, node) = zenoh_node("zenoh_source")?;
    let publisher: Arc<Publisher<Header>> = Arc::new(
        node.create_publisher(&topic(&node, name)?, None)
            .map_err(|e| anyhow!("publisher {name}: {e:?}"))?,
    );
    let node = Arc::new(node);
    serve(|w| {
        let (p, node) = (publisher.clone(), node.clone());
        async move {
            match w[0].as_str() {
                "wait" => {
                    tokio::time::timeout(WAIT, p.wait_for_subscription(&node))
                        .await
                        .map_err(|_| anyhow!("no subscription within {WAIT:?}"))?;
                    Ok("ok".into())
                }
                "run" => {
                    let (n, period): (u64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    paced(n, Duration::from_micros(period), |i| {
                        let _ = p.publish(stamped(i));
                    })
                    .await;
                    Ok(format!("sent {n}"))
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// A Zenoh router: a session in router mode whose configuration the coordinator gives in
/// `ZENOH_CONFIG_OVERRIDE` (rmw_zenohd's: gossip on, multicast off, no failover brokering).
pub(super) async fn zenoh_router() -> Result<()> {
    let _router = Context::with_options(ContextOptions::new())
        .map_err(|e| anyhow!("the Zenoh router's session: {e:?}"))?;
    serve(|w| async move { bail!("unknown command {}", w[0]) }).await;
    Ok(())
}

/// The key a floor pair uses for `topic`: outside ROS's key space (no domain, type or hash).
fn floor_key(topic: &str) -> String {
    format!("radar_bench/floor{topic}")
}

/// Zenoh's own floor, without ros2-client: a plain Zenoh subscriber in a session configured as the
/// ros2-client ones are, recording each stamped 100-byte payload's age in Zenoh's callback (as `udp-sink`
/// does in its thread). `report WARMUP`.
pub(super) async fn zenoh_floor_sink(name: &str) -> Result<()> {
    use ::zenoh::Wait;
    let ctx = Context::with_options(ContextOptions::new())
        .map_err(|e| anyhow!("a Zenoh session: {e:?}"))?;
    let rec = Record::default();
    let r = rec.clone();
    let _sub = ctx
        .session()
        .declare_subscriber(floor_key(name))
        .callback(move |sample| {
            let now = now_ns();
            let b = sample.payload().to_bytes();
            if b.len() >= 16 {
                let seq = u64::from_le_bytes(b[0..8].try_into().unwrap_or_default());
                let t0 = u64::from_le_bytes(b[8..16].try_into().unwrap_or_default());
                r.push(seq, now.saturating_sub(t0));
            }
        })
        .wait()
        .map_err(|e| anyhow!("a Zenoh subscriber: {e}"))?;
    serve_reports(rec).await;
    Ok(())
}

/// Puts stamped 100-byte payloads with a plain Zenoh publisher: `wait` (until a subscriber matches), `run N
/// PERIOD_US`.
pub(super) async fn zenoh_floor_source(name: &str) -> Result<()> {
    use ::zenoh::Wait;
    let ctx = Context::with_options(ContextOptions::new())
        .map_err(|e| anyhow!("a Zenoh session: {e:?}"))?;
    let publisher = Arc::new(
        ctx.session()
            .declare_publisher(floor_key(name))
            .wait()
            .map_err(|e| anyhow!("a Zenoh publisher: {e}"))?,
    );
    serve(|w| {
        let p = publisher.clone();
        async move {
            match w[0].as_str() {
                "wait" => {
                    let started = std::time::Instant::now();
                    while !p
                        .matching_status()
                        .wait()
                        .map_err(|e| anyhow!("{e}"))?
                        .matching()
                    {
                        if started.elapsed() > WAIT {
                            bail!("no subscriber within {WAIT:?}");
                        }
                        tokio::time::sleep(Duration::from_millis(10)).await;
                    }
                    Ok("ok".into())
                }
                "run" => {
                    let (n, period): (u64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    paced(n, Duration::from_micros(period), |i| {
                        let mut b = [0u8; 100];
                        b[0..8].copy_from_slice(&i.to_le_bytes());
                        b[8..16].copy_from_slice(&now_ns().to_le_bytes());
                        let _ = p.put(b.to_vec()).wait();
                    })
                    .await;
                    Ok(format!("sent {n}"))
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}
