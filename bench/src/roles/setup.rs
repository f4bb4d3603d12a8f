//! The manager role: connections made and ended on command, timed.

use super::*;

/// A deliberative program with the embedded manager, in its own process: makes and drops connections
/// between components in other processes, and times it.
pub(super) async fn manager() -> Result<()> {
    let radar = radar()?;
    let held: Arc<Mutex<Vec<ConnectionGuard>>> = Default::default();
    serve(|w| {
        let (radar, held) = (radar.clone(), held.clone());
        async move {
            match w[0].as_str() {
                "connect" => {
                    let (ev, resp): (String, String) = (word(&w, 1)?, word(&w, 2)?);
                    let ev = radar.event(&ev).timeout(WAIT).await?;
                    let resp = radar.response(&resp).timeout(WAIT).await?;
                    let c = radar
                        .whenever(ev.triggered())
                        .start(&resp)
                        .timeout(WAIT)
                        .await?;
                    held.lock().unwrap().push(c);
                    Ok("armed".into())
                }
                "connect-many" => {
                    let (src, sink, n): (String, String, usize) =
                        (word(&w, 1)?, word(&w, 2)?, word(&w, 3)?);
                    let t = now_ns();
                    let made: Vec<ConnectionGuard> = futures::stream::iter(0..n)
                        .map(|i| {
                            let (radar, src, sink) = (radar.clone(), src.clone(), sink.clone());
                            async move {
                                let ev = radar.event(&format!("{src}_{i}")).timeout(WAIT).await?;
                                let r =
                                    radar.response(&format!("{sink}_{i}")).timeout(WAIT).await?;
                                radar
                                    .whenever(ev.triggered())
                                    .start(&r)
                                    .timeout(WAIT)
                                    .await
                                    .map_err(anyhow::Error::from)
                            }
                        })
                        .buffer_unordered(32)
                        .try_collect()
                        .await?;
                    held.lock().unwrap().extend(made);
                    Ok(format!("armed {}", (now_ns() - t) / 1_000_000))
                }
                "drop" => {
                    held.lock().unwrap().clear();
                    Ok("ok".into())
                }
                "setup-live" | "setup-known" => {
                    let (ev, resp, m): (String, String, usize) =
                        (word(&w, 1)?, word(&w, 2)?, word(&w, 3)?);
                    setup_loop(&radar, &ev, &resp, m, w[0] == "setup-live").await
                }
                "setup-fresh" => {
                    let (ev, resp): (String, String) = (word(&w, 1)?, word(&w, 2)?);
                    let r = radar.response(&resp).timeout(WAIT).await?;
                    let e = radar.event(&ev).timeout(WAIT).await?;
                    let found = now_ns();
                    let c = radar
                        .whenever(e.triggered())
                        .start(&r)
                        .timeout(WAIT)
                        .await?;
                    let armed = now_ns();
                    drop(c);
                    Ok(json!({ "found": found, "armed": armed }).to_string())
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}

/// Times `whenever EV start RESP` to armed, dropping the guard, and the drop to the event going inactive,
/// `m` times. `live`: another connection from EV stays armed meanwhile (its relay reader is reused; the event
/// never deactivates, so that time is not taken).
pub(super) async fn setup_loop(
    radar: &Radar,
    ev: &str,
    resp: &str,
    m: usize,
    live: bool,
) -> Result<String> {
    let e = radar.event(ev).timeout(WAIT).await?;
    let r = radar.response(resp).timeout(WAIT).await?;
    let state = radar.state_subscription::<EventState>(&e.name().topic("state"))?;
    state.wait_for_publishers(1).timeout(WAIT).await?;
    let keep = if live {
        Some(
            radar
                .whenever(e.triggered())
                .start(&r)
                .timeout(WAIT)
                .await?,
        )
    } else {
        None
    };
    let wait_state = |active: bool| {
        let state = &state;
        async move {
            let deadline = tokio::time::Instant::now() + WAIT;
            loop {
                let left = deadline.saturating_duration_since(tokio::time::Instant::now());
                let s = state.recv().timeout(left).await?;
                if s.active == active {
                    return Ok::<(), anyhow::Error>(());
                }
            }
        }
    };
    let (mut setup, mut activate, mut disconnect, mut deactivate) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for _ in 0..m {
        let t0 = now_ns();
        let c = radar
            .whenever(e.triggered())
            .start(&r)
            .timeout(WAIT)
            .await?;
        let t1 = now_ns();
        setup.push(t1 - t0);
        if !live {
            wait_state(true).await?;
            activate.push(now_ns() - t1);
        }
        let t2 = now_ns();
        drop(c);
        let t3 = now_ns();
        disconnect.push(t3 - t2);
        if !live {
            wait_state(false).await?;
            deactivate.push(now_ns() - t3);
        }
    }
    drop(keep);
    Ok(
        json!({ "setup": setup, "activate": activate, "disconnect": disconnect,
               "deactivate": deactivate })
        .to_string(),
    )
}
