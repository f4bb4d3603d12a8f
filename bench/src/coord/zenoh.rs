//! One hop over Zenoh (issue 37, the `zenoh` feature): raw ros2-client over its Zenoh backend, peer to peer
//! (rmw_zenoh's default layout: the sessions meet through a router's gossip, then talk directly) and through
//! the router (both sides its clients: every sample crosses two TCP legs and the router), beside raw
//! ros2-client over DDS in the same run, and Zenoh's own floor (a plain Zenoh pair, no ros2-client). The same message, QoS, pacing and clock as the DDS baseline.
//! Then radar_ros's own one hop (an event's `triggered` to a response's start slot, the manager beside the
//! response) over Zenoh, peer to peer and through the router (`RMW_IMPLEMENTATION=rmw_zenoh_cpp` in the
//! children), beside the same over DDS in the same run.

use super::latency::Host;
use super::*;

impl Bench {
    /// The Zenoh rows and the DDS row beside them.
    pub(super) async fn zenoh(&mut self) -> Result<()> {
        let (n, p) = (self.plan.latency_n + self.plan.warmup, self.plan.period_us);
        let run = format!("run {n} {p}");
        let (r, children) = self.raw_hop(&run, false).await?;
        self.push_latency(
            "raw_1hop_beside_zenoh",
            "raw ros2-client over DDS, 1 hop (publisher -> subscriber), beside the Zenoh rows",
            &r,
            "",
        )?;
        for c in children {
            c.quit().await;
        }
        let d = self.domain();
        // a port of the domain's own, far from DDS's (7400 + 250 * domain)
        let port = 30_000 + u32::from(d);
        let router_conf = format!(
            "mode=\"router\";listen/endpoints=[\"tcp/127.0.0.1:{port}\"];connect/endpoints=[];\
             scouting/multicast/enabled=false;scouting/gossip/enabled=true;\
             routing/router/peers_failover_brokering=false"
        );
        let router = self
            .child_with(
                d,
                &["zenoh-router"],
                &[("ZENOH_CONFIG_OVERRIDE", &router_conf)],
            )
            .await?;
        // Zenoh's own floor: a plain Zenoh pair, no ros2-client, peer to peer as the next row
        {
            let conf = format!("mode=\"peer\";connect/endpoints=[\"tcp/127.0.0.1:{port}\"]");
            let env = [("ZENOH_CONFIG_OVERRIDE", conf.as_str())];
            let args = |role| [role, "--topic", "/zenoh_floor"];
            let mut sink = self.child_with(d, &args("zenoh-floor-sink"), &env).await?;
            let mut src = self
                .child_with(d, &args("zenoh-floor-source"), &env)
                .await?;
            src.ask("wait", START).await?;
            let r = self.paced(&mut src, &run, &mut sink).await?;
            self.push_latency(
                "zenoh_floor",
                "Zenoh alone (no ros2-client), 100 bytes peer to peer, taken in Zenoh's callback",
                &r,
                "",
            )?;
            src.quit().await;
            sink.quit().await;
        }
        for (mode, key, label) in [
            (
                "peer",
                "zenoh_p2p_1hop",
                "raw ros2-client over Zenoh, 1 hop peer to peer (met through the router's gossip)",
            ),
            (
                "client",
                "zenoh_router_1hop",
                "raw ros2-client over Zenoh, 1 hop through the router (both its clients)",
            ),
        ] {
            let conf = format!("mode=\"{mode}\";connect/endpoints=[\"tcp/127.0.0.1:{port}\"]");
            let env = [("ZENOH_CONFIG_OVERRIDE", conf.as_str())];
            let topic = format!("/bench/{key}");
            let mut sink = self
                .child_with(d, &["zenoh-sink", "--topic", &topic], &env)
                .await?;
            let mut src = self
                .child_with(d, &["zenoh-source", "--topic", &topic], &env)
                .await?;
            src.ask("wait", START).await?;
            let r = self.paced(&mut src, &run, &mut sink).await?;
            self.push_latency(key, label, &r, "")?;
            if let (Some(z), Some(dds)) = (self.p50(key), self.p50("raw_1hop_beside_zenoh")) {
                let note = format!("p50 {:.2}x DDS's beside it", z / dds);
                if let Some(row) = self.results.latency.last_mut() {
                    row.note = note;
                }
            }
            src.quit().await;
            sink.quit().await;
        }
        // radar_ros's own hop: over DDS, then over Zenoh (the children choose it as ROS 2 programs do)
        let (r, children) = self.radar_hop(n, p, Host::Response).await?;
        self.push_latency(
            "radar_1hop_beside_zenoh",
            "radar_ros over DDS, 1 hop (event -> response, manager beside the response), beside the Zenoh rows",
            &r,
            "",
        )?;
        for c in children {
            c.quit().await;
        }
        for (mode, key, label) in [
            (
                "peer",
                "radar_zenoh_p2p_1hop",
                "radar_ros over Zenoh, 1 hop (event -> response, manager beside the response), peer to peer",
            ),
            (
                "client",
                "radar_zenoh_router_1hop",
                "radar_ros over Zenoh, 1 hop (event -> response, manager beside the response), through the router",
            ),
        ] {
            let conf = format!("mode=\"{mode}\";connect/endpoints=[\"tcp/127.0.0.1:{port}\"]");
            let saved = self.child_env.clone();
            self.child_env.extend([
                ("RMW_IMPLEMENTATION".to_owned(), "rmw_zenoh_cpp".to_owned()),
                ("ZENOH_CONFIG_OVERRIDE".to_owned(), conf),
            ]);
            let hop = self.radar_hop(n, p, Host::Response).await;
            self.child_env = saved;
            let (r, children) = hop?;
            self.push_latency(key, label, &r, "")?;
            if let (Some(z), Some(dds), Some(raw)) = (
                self.p50(key),
                self.p50("radar_1hop_beside_zenoh"),
                self.p50(if mode == "peer" {
                    "zenoh_p2p_1hop"
                } else {
                    "zenoh_router_1hop"
                }),
            ) {
                let note = format!(
                    "p50 {:.2}x radar_ros over DDS beside it, {:.2}x raw ros2-client over Zenoh",
                    z / dds,
                    z / raw
                );
                if let Some(row) = self.results.latency.last_mut() {
                    row.note = note;
                }
            }
            for c in children {
                c.quit().await;
            }
        }
        self.discovery(port).await?;
        router.quit().await;
        Ok(())
    }

    /// A program joining a graph of many components (half events, half responses, in one other process): how
    /// long until it lists them all (`Radar::components`), over DDS and over Zenoh (peer to peer, the router
    /// at `port` up), a fresh joining process per sample.
    async fn discovery(&mut self, port: u32) -> Result<()> {
        let (n, runs) = (self.plan.discovery_n, self.plan.discovery_runs);
        let half = (n / 2).to_string();
        let peer = format!("mode=\"peer\";connect/endpoints=[\"tcp/127.0.0.1:{port}\"]");
        for (key, label, env) in [
            ("discovery_dds", "over DDS", vec![]),
            (
                "discovery_zenoh",
                "over Zenoh (peer to peer)",
                vec![
                    ("RMW_IMPLEMENTATION", "rmw_zenoh_cpp"),
                    ("ZENOH_CONFIG_OVERRIDE", peer.as_str()),
                ],
            ),
        ] {
            let d = self.domain();
            let comps = Child::start(
                &self.exe,
                &[
                    "child",
                    "components",
                    "--events",
                    &half,
                    "--responses",
                    &half,
                ],
                d,
                &env,
                Duration::from_secs(600),
            )
            .await?;
            let mut samples = Vec::new();
            for _ in 0..runs {
                let mut joiner = self.child_with(d, &["discover"], &env).await?;
                let a = joiner
                    .ask_json(&format!("wait {n}"), Duration::from_secs(320))
                    .await?;
                samples.push(a["ns"].as_u64().unwrap_or(0));
                joiner.quit().await;
            }
            comps.quit().await;
            self.push_setup(
                key,
                &format!("a joining program lists {n} components (one other process), {label}"),
                samples,
            )?;
        }
        Ok(())
    }

    /// The p50 of the latency row `key` measured so far in this run, if there is one.
    fn p50(&self, key: &str) -> Option<f64> {
        self.results
            .latency
            .iter()
            .find(|l| l.key == key)
            .map(|l| l.summary.p50_us)
    }
}
