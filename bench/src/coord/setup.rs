//! Setup scenarios: how long making connections takes.

use super::*;

impl Bench {
    pub(super) fn push_setup(&mut self, key: &str, label: &str, samples: Vec<u64>) -> Result<()> {
        let summary = summarize(&samples).ok_or_else(|| anyhow!("{label}: no samples"))?;
        self.results.setup.push(Latency {
            key: key.into(),
            label: label.into(),
            summary,
            missing: 0,
            note: String::new(),
            usage: None,
            samples,
        });
        Ok(())
    }

    /// Connection setup (known source, source with a live relay, never-seen source) and disconnect.
    pub(super) async fn setup(&mut self) -> Result<()> {
        let d = self.domain();
        let mut ev = self
            .child(d, &["events", "--names", "/bench/setup_a,/bench/setup_b"])
            .await?;
        let resp = self
            .child(d, &["response", "--name", "/bench/resp"])
            .await?;
        let mut mgr = self.child(d, &["manager"]).await?;
        let m = self.plan.setup_n;
        let long = Duration::from_secs(60 + m as u64);
        let known = mgr
            .ask_json(&format!("setup-known /bench/setup_b /bench/resp {m}"), long)
            .await?;
        let live = mgr
            .ask_json(&format!("setup-live /bench/setup_a /bench/resp {m}"), long)
            .await?;
        let mut fresh = Vec::new();
        let mut fresh_found = Vec::new();
        for i in 0..self.plan.fresh_n {
            let name = format!("/bench/fresh_{i}");
            mgr.send(&format!("setup-fresh {name} /bench/resp")).await?;
            // the manager is looking for it before it exists
            tokio::time::sleep(Duration::from_millis(50)).await;
            let spawned: u64 = ev
                .ask(&format!("spawn {name}"), START)
                .await?
                .strip_prefix("spawned ")
                .and_then(|t| t.parse().ok())
                .ok_or_else(|| anyhow!("bad spawn answer"))?;
            let a: Value = serde_json::from_str(&mgr.answer(START).await?)?;
            let (found, armed) = (
                a["found"].as_u64().unwrap_or(0),
                a["armed"].as_u64().unwrap_or(0),
            );
            fresh_found.push(found.saturating_sub(spawned));
            fresh.push(armed.saturating_sub(spawned));
        }
        let v =
            |j: &Value, k: &str| -> Result<Vec<u64>> { Ok(serde_json::from_value(j[k].clone())?) };
        self.push_setup(
            "setup_known",
            "whenever -> armed, source known (looked up before, no relay reader yet)",
            v(&known, "setup")?,
        )?;
        self.push_setup(
            "setup_live",
            "whenever -> armed, source already relayed by another connection",
            v(&live, "setup")?,
        )?;
        self.push_setup(
            "setup_fresh",
            "event starts in another process -> connection armed (source never seen)",
            fresh,
        )?;
        self.push_setup(
            "setup_fresh_found",
            "event starts in another process -> found by name (part of the line above)",
            fresh_found,
        )?;
        self.push_setup(
            "activate",
            "armed -> the event reports itself active (its state topic, 1 hop)",
            v(&known, "activate")?,
        )?;
        self.push_setup(
            "disconnect",
            "guard dropped (disconnect call returns)",
            v(&known, "disconnect")?,
        )?;
        self.push_setup(
            "deactivate",
            "guard dropped -> the event reports itself inactive (checking stopped)",
            v(&known, "deactivate")?,
        )?;
        for c in [mgr, resp, ev] {
            c.quit().await;
        }
        Ok(())
    }
}
