//! `radar view` at scale: the time to a page's first full picture of 2,000 components, the update rate a page
//! receives while responses are started fast (and what the view costs in CPU), and a real browser's memory
//! after minutes of updates (Debian's chromium through Playwright, `bench/python/view_memory.py`, its heap read
//! through the browser's own `performance.memory`).

use std::collections::HashSet;

use futures::StreamExt;
use tokio::io::AsyncBufReadExt;
use tokio_tungstenite::tungstenite::Message;

use super::*;

/// What a page received over a while.
#[derive(Default)]
struct Received {
    messages: u64,
    bytes: u64,
    components: u64,
    lines: u64,
    dropped: u64,
}

type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// Reads `ws` until `until`, counting what came.
async fn receive(mut ws: Socket, until: tokio::time::Instant) -> (Socket, Received) {
    let mut r = Received::default();
    while let Ok(Some(Ok(m))) = tokio::time::timeout_at(until, ws.next()).await {
        if let Message::Text(t) = m {
            let v: Value = serde_json::from_str(&t).unwrap_or_default();
            r.messages += 1;
            r.bytes += t.len() as u64;
            r.components += v["components"].as_array().map_or(0, |a| a.len() as u64);
            r.lines += v["timeline"].as_array().map_or(0, |a| a.len() as u64);
            r.dropped += v["dropped"].as_u64().unwrap_or(0);
        }
    }
    (ws, r)
}

impl Bench {
    /// The view scenario (see the module's docs).
    pub(super) async fn view(&mut self) -> Result<()> {
        let radar_bin = self.exe.with_file_name("radar");
        if !radar_bin.exists() {
            bail!(
                "{} is missing: build it with this profile (cargo build --release -p radar_tools)",
                radar_bin.display()
            );
        }
        let d = self.domain();
        let quick = self.opts.quick;
        let (events, responses) = if quick { (10, 10) } else { (1000, 1000) };
        let n = events + responses;
        let (es, rs) = (events.to_string(), responses.to_string());
        let mut sys = Child::start(
            &self.exe,
            &["child", "view-system", "--events", &es, "--responses", &rs],
            d,
            &[],
            Duration::from_secs(900),
        )
        .await?;

        // from the view's start to a page holding every component with its state
        let t0 = Instant::now();
        let mut view = tokio::process::Command::new(&radar_bin)
            .args(["view", "--port", "0", "--json"])
            .env("ROS_DOMAIN_ID", d.to_string())
            .stdout(std::process::Stdio::piped())
            .kill_on_drop(true)
            .spawn()
            .context("starting radar view")?;
        let mut lines = tokio::io::BufReader::new(view.stdout.take().context("stdout")?).lines();
        let first = tokio::time::timeout(START, lines.next_line())
            .await
            .context("radar view said nothing")??
            .context("radar view ended")?;
        let said: Value = serde_json::from_str(&first)?;
        let url = said["url"].as_str().context("no url")?.to_owned();
        let ws_url = format!("{}ws", url.replacen("http://", "ws://", 1));
        let (mut ws, _) = tokio_tungstenite::connect_async(&ws_url).await?;
        let mut with_state = HashSet::new();
        let deadline = tokio::time::Instant::now() + Duration::from_secs(600);
        while with_state.len() < n {
            let m = tokio::time::timeout_at(deadline, ws.next())
                .await
                .map_err(|_| anyhow!("the page had {} of {n} components", with_state.len()))?
                .context("the view closed")??;
            if let Message::Text(t) = m {
                let v: Value = serde_json::from_str(&t)?;
                for c in v["components"].as_array().into_iter().flatten() {
                    if !c["state"].is_null() {
                        with_state.insert(c["name"].as_str().unwrap_or_default().to_owned());
                    }
                }
            }
        }
        let first_picture_s = t0.elapsed().as_secs_f64();

        // a page that joins now: its snapshot
        let t = Instant::now();
        let (mut late, _) = tokio_tungstenite::connect_async(&ws_url).await?;
        let snapshot = loop {
            match late.next().await.context("no snapshot")?? {
                Message::Text(t) => break t,
                _ => continue,
            }
        };
        let snapshot_ms = t.elapsed().as_secs_f64() * 1e3;
        drop(late);

        // updates while responses are started fast
        let pid = view.id().unwrap_or(0);
        let (window_ms, rates) = if quick {
            (2000, vec![50.0])
        } else {
            (10_000, vec![200.0, 2000.0])
        };
        let mut steps = Vec::new();
        for rate in rates {
            let until = tokio::time::Instant::now() + Duration::from_millis(window_ms + 1500);
            let reading = tokio::spawn(receive(ws, until));
            let cpu0 = cpu_time(pid)?;
            let t = Instant::now();
            let sent: u64 = sys
                .ask(
                    &format!("churn {rate} {window_ms}"),
                    Duration::from_millis(window_ms) + START,
                )
                .await?
                .parse()?;
            let (back, r) = reading.await?;
            let secs = t.elapsed().as_secs_f64();
            let cpu = (cpu_time(pid)? - cpu0).as_secs_f64() / secs;
            ws = back;
            let per_s = |x: u64| x as f64 / secs;
            steps.push(json!({
                "starts_per_s": rate, "starts_sent": sent, "messages_per_s": per_s(r.messages),
                "kib_per_s": per_s(r.bytes) / 1024.0, "component_updates_per_s": per_s(r.components),
                "lines_per_s": per_s(r.lines), "dropped_per_s": per_s(r.dropped), "view_cpu": cpu,
            }));
        }
        drop(ws);

        // a real browser's memory after minutes of updates (left out of quick runs: `--only view` runs it)
        let browser = if !quick || !self.opts.only.is_empty() {
            Some(self.browser_memory(&mut sys, &url, n, quick).await?)
        } else {
            eprintln!(
                "radar_bench: the browser part of view left out of quick (`--only view` runs it)"
            );
            None
        };
        // the watched system told to stop while the view still watches every component
        let (stop, stop_code) = sys.terminate(Duration::from_secs(120)).await?;
        let _ = view.kill().await;
        self.results.view.push(json!({
            "components": n, "events": events, "responses": responses,
            "sigterm_ms": stop.as_secs_f64() * 1e3, "sigterm_code": stop_code,
            "first_picture_s": first_picture_s, "snapshot_ms": snapshot_ms,
            "snapshot_kib": snapshot.len() as f64 / 1024.0, "steps": steps, "browser": browser,
        }));
        Ok(())
    }

    /// Chromium on the view's page while `sys` starts 200 responses a second, for 5 minutes (quick: 30 s).
    async fn browser_memory(
        &self,
        sys: &mut Child,
        url: &str,
        n: usize,
        quick: bool,
    ) -> Result<Value> {
        let py = self.opts.venv.join("bin/python");
        if !py.exists() {
            bail!(
                "the venv is missing at {} (it holds Playwright): run tests/python_env.sh",
                self.opts.venv.display()
            );
        }
        let minutes: f64 = if quick { 0.5 } else { 5.0 };
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/view_memory.py");
        let browser = tokio::process::Command::new(py)
            .arg(script)
            .args(["--url", url, "--expect", &n.to_string()])
            .args(["--minutes", &minutes.to_string()])
            .kill_on_drop(true)
            .output();
        let churn_ms = (minutes * 60_000.0) as u64 + 10_000;
        let ask = format!("churn 200 {churn_ms}");
        let churn = sys.ask(&ask, Duration::from_millis(churn_ms) + START);
        let (out, churned) = futures::join!(browser, churn);
        let out = out?;
        churned?;
        if !out.status.success() {
            bail!(
                "view_memory.py failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        let last = String::from_utf8_lossy(&out.stdout)
            .lines()
            .last()
            .unwrap_or_default()
            .to_owned();
        serde_json::from_str(&last).with_context(|| format!("view_memory.py said {last:?}"))
    }
}
