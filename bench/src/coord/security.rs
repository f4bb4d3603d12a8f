//! DDS Security (issue 25): trigger -> start and connection setup with every process secured (enclaves of one
//! keystore, `ROS_SECURITY_*` as ROS 2 users set them), against the same scenarios plain, in the same run.
//! Needs radar_bench built with its `security` feature.

use super::*;

impl Bench {
    /// Latency (manager in the response's process, one hop) and `whenever -> armed` (source known, manager in
    /// a third process), plain then secured.
    pub(super) async fn security(&mut self) -> Result<()> {
        #[cfg(not(feature = "security"))]
        bail!(
            "radar_bench was built without its `security` feature (OpenSSL): \
             `tests/isolated.sh cargo run --release -p radar_bench --features security -- all --only security`"
        );
        #[cfg(feature = "security")]
        {
            use radar_ros::security::keystore;
            let ks =
                std::env::temp_dir().join(format!("radar_bench_keystore_{}", std::process::id()));
            let _ = std::fs::remove_dir_all(&ks);
            keystore::create_keystore(&ks)?;
            keystore::create_enclave(&ks, "/bench", &keystore::Grant::all())?;
            let saved = std::mem::take(&mut self.child_env);
            let r = self.security_rows(&ks, &saved).await;
            self.child_env = saved;
            let _ = std::fs::remove_dir_all(&ks);
            r
        }
    }

    #[cfg(feature = "security")]
    async fn security_rows(&mut self, ks: &Path, base_env: &[(String, String)]) -> Result<()> {
        let (n, p) = (self.plan.latency_n + self.plan.warmup, self.plan.period_us);
        for secured in [false, true] {
            self.child_env = base_env.to_vec();
            if secured {
                for (k, v) in [
                    ("ROS_SECURITY_KEYSTORE", ks.to_string_lossy().as_ref()),
                    ("ROS_SECURITY_ENABLE", "true"),
                    ("ROS_SECURITY_STRATEGY", "Enforce"),
                    ("ROS_SECURITY_ENCLAVE_OVERRIDE", "/bench"),
                ] {
                    self.child_env.push((k.into(), v.into()));
                }
            }
            let (key, how) = if secured {
                (
                    "secured",
                    "secured (DDS Security: encrypted, access controlled)",
                )
            } else {
                ("plain", "plain")
            };
            let (r, children) = self.radar_hop(n, p, latency::Host::Response).await?;
            let note = format!(
                "{} starts ignored (response busy)",
                r["extra"]["ignored_starts"]
            );
            self.push_latency(
                &format!("security_trigger_start_{key}"),
                &format!("radar_ros trigger -> start, 1 hop, {how}"),
                &r,
                &note,
            )?;
            for c in children {
                c.quit().await;
            }
            // Fast DDS's own hop, plain and secured from the same enclave (the same governance): what DDS
            // Security costs in the DDS under rmw_fastrtps, beside what it costs radar_ros, in the same run
            let enclave = secured.then(|| ks.join("enclaves/bench"));
            let topic = format!("rt/bench/fastdds_{key}");
            let run = format!("run {n} {p}");
            let fd = self.fastdds_1hop(&run, &topic, enclave.as_deref()).await;
            self.push_baseline(
                &format!("security_fastdds_1hop_{key}"),
                &format!("Fast DDS 2.9 (C++, UDPv4), 1 hop, {how}"),
                fd,
            )?;
            // where its time goes: the same hop again with RustDDS's probe on (stamped after decoding when
            // secured: decoding is in "parse the RTPS message")
            let plain_env = self.child_env.clone();
            self.child_env
                .push(("RUSTDDS_PROBE_TOPIC".into(), "rt/bench/ev/triggered".into()));
            let hop = self.radar_hop(n, p, latency::Host::Response).await;
            let r = self.probe_children(hop).await;
            self.push_breakdown(
                &format!("security_{key}"),
                &format!("radar_ros, manager in the response's process, {how}"),
                r,
            );
            self.child_env = plain_env;

            let d = self.domain();
            let ev = self
                .child(d, &["events", "--names", "/bench/sec_setup"])
                .await?;
            let resp = self
                .child(d, &["response", "--name", "/bench/sec_resp"])
                .await?;
            let mut mgr = self.child(d, &["manager"]).await?;
            let m = self.plan.setup_n;
            let known = mgr
                .ask_json(
                    &format!("setup-known /bench/sec_setup /bench/sec_resp {m}"),
                    Duration::from_secs(60 + 2 * m as u64),
                )
                .await?;
            self.push_setup(
                &format!("security_setup_{key}"),
                &format!("whenever -> armed, source known, manager in a third process, {how}"),
                serde_json::from_value(known["setup"].clone())?,
            )?;
            for c in [mgr, resp, ev] {
                c.quit().await;
            }
            self.first_signal_rows(key, how).await?;
        }
        Ok(())
    }

    /// A program's first signal to a new peer: a deliberative program (manager, third process) waits for the
    /// event `/bench/born` to connect it to a response; the event's process is then started, and its event
    /// triggers once, as soon as it is listened to (a condition already true), stamped with the time the
    /// coordinator started the process. The row: process started -> the response's start slot runs (the new
    /// participant's discovery, the authentication handshake and key exchange when secured, the lookup,
    /// arming, and two hops); a round whose trigger never arrives is counted missing.
    /// Fresh processes and a domain of their own each round.
    #[cfg(feature = "security")]
    async fn first_signal_rows(&mut self, key: &str, how: &str) -> Result<()> {
        const ROUNDS: usize = 5;
        let mut lat: Vec<u64> = Vec::new();
        for _ in 0..ROUNDS {
            let d = self.domain();
            let mut resp = self
                .child(d, &["response", "--name", "/bench/born_resp"])
                .await?;
            let mut mgr = self.child(d, &["manager"]).await?;
            let this = &*self;
            let (armed, ev) = tokio::join!(
                mgr.ask("connect /bench/born /bench/born_resp", START),
                async {
                    // the program is looking the event up before its process exists
                    tokio::time::sleep(Duration::from_millis(300)).await;
                    let born = crate::clock::now_ns().to_string();
                    this.child(d, &["events", "--names", "/bench/born", "--born", &born])
                        .await
                }
            );
            let ev = ev?;
            armed?;
            let deadline = tokio::time::Instant::now() + START;
            let got = loop {
                let r = resp.ask_json("report 0", START).await?;
                let got: Vec<u64> = serde_json::from_value(r["lat_ns"].clone())?;
                if !got.is_empty() || tokio::time::Instant::now() > deadline {
                    break got;
                }
                tokio::time::sleep(Duration::from_millis(20)).await;
            };
            lat.extend(got.first());
            for c in [mgr, resp, ev] {
                c.quit().await;
            }
        }
        self.push_latency(
            &format!("security_first_signal_{key}"),
            &format!(
                "a new peer's first signal: its process started -> the response's start slot ({ROUNDS} rounds, \
                 its one trigger; program in a third process), {how}"
            ),
            &json!({ "lat_ns": lat }),
            "",
        )?;
        let last = self.results.latency.last_mut().unwrap();
        last.missing = (ROUNDS - lat.len()) as u64;
        Ok(())
    }
}
