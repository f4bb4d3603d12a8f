//! The raw ros2-client roles: the baseline's sink, source and forwarder.

use super::*;

/// Subscribes to `topic` and records each sample's age when it is taken.
pub(super) async fn raw_sink(topic: &str) -> Result<()> {
    let (_ctx, mut node) = raw_node("raw_sink")?;
    let sub = raw_subscription(&mut node, topic)?;
    let rec = Record::default();
    let count = Arc::new(AtomicU64::new(0));
    let (r, c) = (rec.clone(), count.clone());
    tokio::spawn(async move {
        let stream = sub.async_stream();
        futures::pin_mut!(stream);
        while let Some(Ok((h, _))) = stream.next().await {
            let age = age_ns(&h);
            r.push(unstamp(&h).0, age);
            c.fetch_add(1, Ordering::Relaxed);
        }
    });
    serve(|w| {
        let (rec, count) = (rec.clone(), count.clone());
        async move {
            match w[0].as_str() {
                "report" => Ok(rec.report(word(&w, 1)?, json!({}))),
                "count" => Ok(count.load(Ordering::Relaxed).to_string()),
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// Publishes stamped samples on `topic`: `wait` (for a subscriber), `run N PERIOD_US` (paced, for latency),
/// `rate PER_SECOND WINDOW_MS` (for throughput).
pub(super) async fn raw_source(topic: &str) -> Result<()> {
    let (_ctx, mut node) = raw_node("raw_source")?;
    let publisher = Arc::new(raw_publisher(&mut node, topic)?);
    let node = Arc::new(node);
    serve(|w| {
        let (p, node) = (publisher.clone(), node.clone());
        async move {
            match w[0].as_str() {
                "wait" => {
                    tokio::time::timeout(WAIT, p.wait_for_subscription(&node))
                        .await
                        .map_err(|_| anyhow!("no subscriber within {WAIT:?}"))?;
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
                "rate" => {
                    let (rate, ms): (f64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    let sent = at_rate(rate, Duration::from_millis(ms), |i| {
                        let _ = p.publish(stamped(i));
                    })
                    .await;
                    Ok(sent.to_string())
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// A plain forwarding node: every sample on `from` is published unchanged on `to` (the floor for any relay).
pub(super) async fn raw_forward(from: &str, to: &str) -> Result<()> {
    let (_ctx, mut node) = raw_node("raw_forward")?;
    let sub = raw_subscription(&mut node, from)?;
    let publisher = raw_publisher(&mut node, to)?;
    tokio::spawn(async move {
        let stream = sub.async_stream();
        futures::pin_mut!(stream);
        while let Some(Ok((h, _))) = stream.next().await {
            let _ = publisher.publish(h);
        }
    });
    serve(|w| async move { bail!("unknown command {}", w[0]) }).await;
    Ok(())
}

/// The wire's floor: receives 100-byte UDP datagrams on `127.0.0.1:port` in a thread of its own (no runtime,
/// no DDS) and records each one's age from the stamp inside (`seq`, `t0` little-endian). `report WARMUP`.
pub(super) async fn udp_sink(port: u16) -> Result<()> {
    let sock = std::net::UdpSocket::bind(("127.0.0.1", port)).context("bind the UDP sink")?;
    let rec = Record::default();
    let r = rec.clone();
    std::thread::spawn(move || {
        let mut buf = [0u8; 256];
        while let Ok(n) = sock.recv(&mut buf) {
            let now = now_ns();
            if n >= 16 {
                let seq = u64::from_le_bytes(buf[0..8].try_into().unwrap_or_default());
                let t0 = u64::from_le_bytes(buf[8..16].try_into().unwrap_or_default());
                r.push(seq, now.saturating_sub(t0));
            }
        }
    });
    serve_reports(rec).await;
    Ok(())
}

/// Sends stamped 100-byte UDP datagrams to `127.0.0.1:port`: `wait` (nothing to wait for), `run N PERIOD_US`.
pub(super) async fn udp_source(port: u16) -> Result<()> {
    let sock =
        Arc::new(std::net::UdpSocket::bind(("127.0.0.1", 0)).context("bind the UDP source")?);
    sock.connect(("127.0.0.1", port))
        .context("connect the UDP source")?;
    serve(|w| {
        let sock = sock.clone();
        async move {
            match w[0].as_str() {
                "wait" => Ok("ok".into()),
                "run" => {
                    let (n, period): (u64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    paced(n, Duration::from_micros(period), |i| {
                        let mut b = [0u8; 100];
                        b[0..8].copy_from_slice(&i.to_le_bytes());
                        b[8..16].copy_from_slice(&now_ns().to_le_bytes());
                        let _ = sock.send(&b);
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
