//! Failure scenarios: a fresh process per one-shot publish, a peer killed with SIGKILL.

use super::*;

impl Bench {
    /// Runs one fresh rclpy process that publishes a stamped Header once into `topic`, exactly as
    /// `ros2 topic pub --once` does, and waits for it to exit.
    async fn oneshot_process(&self, domain: u16, topic: &str, seq: u64) -> Result<()> {
        let py = self.opts.venv.join("bin/python");
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("python/rclpy_hop.py");
        let out = tokio::time::timeout(
            START,
            tokio::process::Command::new(&py)
                .arg(&script)
                .args(["oneshot", "--topic", topic, "--seq", &seq.to_string()])
                .env("ROS_DOMAIN_ID", domain.to_string())
                .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
                .kill_on_drop(true)
                .output(),
        )
        .await
        .map_err(|_| anyhow!("a one-shot publisher did not finish within {START:?}"))??;
        if !out.status.success() {
            bail!(
                "a one-shot publisher failed ({}): {}",
                out.status,
                String::from_utf8_lossy(&out.stderr)
            );
        }
        Ok(())
    }

    /// `ros2 topic pub --once` from a fresh process: publish -> the response's start behaviour runs (and the
    /// same into a plain rclpy subscriber, the baseline). Lost = published but never arrived.
    pub(super) async fn oneshot(&mut self) -> Result<()> {
        let n = self.plan.oneshot_n;
        let d = self.domain();
        let mut resp = self
            .child(d, &["response", "--name", "/bench/oneshot"])
            .await?;
        for i in 0..n {
            self.oneshot_process(d, "/bench/oneshot/start", i).await?;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
        let r = resp.ask_json("report 0", START).await?;
        resp.quit().await;
        self.push_latency(
            "oneshot_radar",
            "fresh rclpy process, one publish (`ros2 topic pub --once`) -> radar_ros response started",
            &r,
            "one process per sample",
        )?;
        let last = self.results.latency.last_mut().unwrap();
        last.missing = n.saturating_sub(last.summary.n as u64);

        // the baseline in the same domain, on its own topic (domains are few)
        let mut sink = self
            .python(d, &["sink", "--topic", "/bench/oneshot_base"])
            .await?;
        for i in 0..n {
            self.oneshot_process(d, "/bench/oneshot_base", i).await?;
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
        let r = sink.ask_json("report 0", START).await?;
        sink.quit().await;
        self.push_latency(
            "oneshot_rclpy",
            "fresh rclpy process, one publish -> rclpy subscriber (baseline)",
            &r,
            "one process per sample",
        )?;
        let last = self.results.latency.last_mut().unwrap();
        last.missing = n.saturating_sub(last.summary.n as u64);
        Ok(())
    }

    /// SIGKILL of a deliberative program that made `whenever` through a standalone manager's service: time
    /// until the manager has removed its connection, and until the event it listened to reports inactive.
    pub(super) async fn kill(&mut self) -> Result<()> {
        let (mut removed, mut inactive) = (Vec::new(), Vec::new());
        // round after round in one domain (every process of a round is gone before the next)
        let d = self.domain();
        for _ in 0..self.plan.kill_rounds {
            let mut ev = self
                .child(d, &["events", "--names", "/bench/kill_ev"])
                .await?;
            let resp = self
                .child(d, &["response", "--name", "/bench/kill_resp"])
                .await?;
            let mut mgr = self
                .child(d, &["service-manager", "--name", "/bench_manager"])
                .await?;
            let caller = self
                .child(
                    d,
                    &[
                        "service-caller",
                        "--manager",
                        "/bench_manager",
                        "--source",
                        "/bench/kill_ev/triggered",
                        "--target",
                        "/bench/kill_resp/start",
                    ],
                )
                .await?;
            ev.ask("active /bench/kill_ev", START).await?;
            if mgr.ask("count", START).await? != "1" {
                bail!("the manager does not hold the caller's connection");
            }
            mgr.send("wait-empty").await?;
            ev.send("inactive /bench/kill_ev").await?;
            // the manager and the event must be waiting before the kill
            tokio::time::sleep(Duration::from_millis(100)).await;
            let t0 = crate::clock::now_ns();
            caller.kill().await;
            let long = Duration::from_secs(130);
            let gone: u64 = mgr.answer(long).await?.parse()?;
            let idle: u64 = ev.answer(long).await?.parse()?;
            removed.push(gone.saturating_sub(t0));
            inactive.push(idle.saturating_sub(t0));
            for c in [mgr, resp, ev] {
                c.quit().await;
            }
        }
        for (key, label, samples) in [
            (
                "kill_connections_removed",
                "SIGKILL of the caller -> its connection removed by the standalone manager",
                removed,
            ),
            (
                "kill_event_inactive",
                "SIGKILL of the caller -> the event it listened to reports inactive",
                inactive,
            ),
        ] {
            let summary = summarize(&samples).ok_or_else(|| anyhow!("{label}: no samples"))?;
            self.results.kill.push(Latency {
                key: key.into(),
                label: label.into(),
                summary,
                missing: 0,
                note: String::new(),
                usage: None,
                samples,
            });
        }
        Ok(())
    }
}
