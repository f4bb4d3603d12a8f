//! Scale scenarios: many components and connections in one process (setup, idle cost, memory).

use super::*;

impl Bench {
    /// Many events, responses and connections in one process.
    pub(super) async fn scale(&mut self) -> Result<()> {
        let d = self.domain();
        for (e, r, c) in self.plan.scale.clone() {
            eprintln!("radar_bench: scale step {e} events + {r} responses, {c} connections");
            let report = self.scale_step(d, e, r, c).await?;
            self.results.scale.push(report);
        }
        Ok(())
    }

    /// One step of the scale curve, in a fresh process (one at a time, so one domain serves them all).
    async fn scale_step(&mut self, d: u16, e: usize, r: usize, c: usize) -> Result<Value> {
        let (es, rs, cs, idle) = (
            e.to_string(),
            r.to_string(),
            c.to_string(),
            self.plan.idle_ms.to_string(),
        );
        let (settle, settled) = (
            self.plan.settle_ms.to_string(),
            self.plan.settled_ms.to_string(),
        );
        let mut s = Child::start(
            &self.exe,
            &[
                "child",
                "scale",
                "--events",
                &es,
                "--responses",
                &rs,
                "--connections",
                &cs,
                "--idle-ms",
                &idle,
                "--settle-ms",
                &settle,
                "--settled-ms",
                &settled,
            ],
            d,
            &[],
            Duration::from_secs(1200),
        )
        .await?;
        let mut report = s.ask_json("report", START).await?;
        // told to stop with every component and connection still there (a service manager's SIGTERM)
        let (stop, code) = s.terminate(Duration::from_secs(120)).await?;
        report["sigterm_ms"] = (stop.as_secs_f64() * 1e3).into();
        report["sigterm_code"] = code.into();
        Ok(report)
    }

    /// RSS of a process whose response goes through many state changes (nobody subscribed to `state`), and
    /// of a raw ros2-client latched writer written as often.
    pub(super) async fn state_memory(&mut self) -> Result<()> {
        let n = self.plan.state_changes.to_string();
        // one process after the other, in one domain
        let d = self.domain();
        for (key, role, flag, label) in [
            (
                "radar_response",
                "state-churn",
                "--changes",
                "radar_ros response, state changes (3 per run), nobody subscribed",
            ),
            (
                "raw_latched",
                "raw-latched",
                "--writes",
                "raw ros2-client transient-local keep-last-1 writer, writes (baseline)",
            ),
        ] {
            let mut c = self.child(d, &[role, flag, &n]).await?;
            let mut r = c.ask_json("run", Duration::from_secs(1800)).await?;
            c.quit().await;
            r["key"] = key.into();
            r["label"] = label.into();
            self.results.state_memory.push(r);
        }
        Ok(())
    }
}
