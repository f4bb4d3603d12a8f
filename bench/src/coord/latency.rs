//! Latency scenarios: one signal's hop (radar and the raw baselines), an interrupt, an action goal.

use super::*;

/// Which process hosts the manager of a latency run's connection.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Host {
    /// A third process (two DDS hops).
    Third,
    /// The response's, writing on the response's `start` anyway (two hops).
    ResponseRelaying,
    /// The response's (one hop: the event's writer to the manager's reader).
    Response,
    /// The event's (one hop: the manager's writer to the response's reader).
    Event,
}

impl Host {
    /// The key and label of this host's latency row.
    pub(super) fn row(self) -> (&'static str, &'static str) {
        match self {
            Host::Third => (
                "radar_manager_process",
                "radar_ros trigger -> start, manager in a third process (2 hops)",
            ),
            Host::ResponseRelaying => (
                "radar_embedded_relay",
                "radar_ros trigger -> start, manager in the response's process, relayed (2 hops; `local_delivery(false)`)",
            ),
            Host::Response => (
                "radar_embedded",
                "radar_ros trigger -> start, manager in the response's process (1 hop)",
            ),
            Host::Event => (
                "radar_embedded_event",
                "radar_ros trigger -> start, manager in the event's process (1 hop)",
            ),
        }
    }
}

impl Bench {
    /// Trigger -> start latency through radar_ros, and the three baselines.
    pub(super) async fn latency(&mut self) -> Result<()> {
        let (n, p) = (self.plan.latency_n + self.plan.warmup, self.plan.period_us);
        let run = format!("run {n} {p}");
        self.udp_latency(&run).await?;
        self.futex_latency(&run).await?;
        self.raw_latency(&run, false).await?;
        self.raw_latency(&run, true).await?;
        // rclpy, one hop
        let py = self.rclpy_1hop(&run, "/bench/lat").await;
        self.push_baseline("rclpy_1hop", "rclpy, 1 hop (publisher -> subscriber)", py)?;
        // Fast DDS itself (C++, over UDP), one hop
        let fd = self.fastdds_1hop(&run, "rt/bench/lat_fastdds", None).await;
        self.push_baseline(
            "fastdds_1hop",
            "Fast DDS 2.9 (C++, UDPv4), 1 hop (writer -> WaitSet thread)",
            fd,
        )?;
        // and as rclcpp and rclpy nodes run it by default: its builtin transports, shared memory on one host
        let fd = self
            .fastdds_1hop_with(&run, "rt/bench/lat_fastdds_default", None, "default")
            .await;
        self.push_baseline(
            "fastdds_1hop_default",
            "Fast DDS 2.9 (C++, default transports: shared memory on one host), 1 hop (writer -> WaitSet thread)",
            fd,
        )?;
        for host in [
            Host::Third,
            Host::ResponseRelaying,
            Host::Response,
            Host::Event,
        ] {
            self.radar_latency(n, p, host).await?;
        }
        // again, the trigger written by the pacing thread itself, as raw ros2-client's source publishes from
        // its pacing loop (the rows above hand each sequence number to the event's check on another thread)
        self.event_trigger = true;
        for host in [Host::Third, Host::Response, Host::Event] {
            self.radar_latency(n, p, host).await?;
        }
        self.event_trigger = false;
        // all in one process: what radar_ros itself adds, without DDS
        let d = self.domain();
        let mut all = self
            .child(
                d,
                &[
                    "events",
                    "--names",
                    "/bench/ev",
                    "--local-response",
                    "/bench/resp",
                ],
            )
            .await?;
        all.ask("active /bench/ev", START).await?;
        let (before, sent_before) = (sched_now(&[all.pid()])?, udp_datagrams());
        all.ask(&format!("run /bench/ev {n} {p}"), self.run_timeout(n))
            .await?;
        tokio::time::sleep(Duration::from_millis(500)).await;
        let (after, sent_after) = (sched_now(&[all.pid()])?, udp_datagrams());
        let mut r = all
            .ask_json(&format!("report {}", self.plan.warmup), START)
            .await?;
        r["usage"] = usage_per_signal(before, after, n);
        add_datagrams(&mut r["usage"], sent_before, sent_after, n);
        let note = format!(
            "{} starts ignored (response busy)",
            r["extra"]["ignored_starts"]
        );
        self.push_latency(
            "radar_one_process",
            "radar_ros trigger -> start, event, manager and response in one process (no DDS hop)",
            &r,
            &note,
        )?;
        all.quit().await;
        Ok(())
    }

    /// rclpy's one hop on `topic`: its source publishing to its sink, paced by `run`.
    async fn rclpy_1hop(&mut self, run: &str, topic: &str) -> Result<Value> {
        let d = self.domain();
        let mut sink = self.python(d, &["sink", "--topic", topic]).await?;
        let mut src = self.python(d, &["source", "--topic", topic]).await?;
        src.ask("wait", START).await?;
        let r = self.paced(&mut src, run, &mut sink).await?;
        src.quit().await;
        sink.quit().await;
        Ok(r)
    }

    /// Fast DDS's own one hop on the DDS topic `topic` (`bench/fastdds/fastdds_hop.cpp`): its writer to a reader
    /// taken from a WaitSet's thread, paced by `run`; secured from the keystore's `enclave` directory if given.
    pub(super) async fn fastdds_1hop(
        &mut self,
        run: &str,
        topic: &str,
        enclave: Option<&Path>,
    ) -> Result<Value> {
        self.fastdds_1hop_with(run, topic, enclave, "udp").await
    }

    /// [`Self::fastdds_1hop`] over Fast DDS's `transports`: `udp` (UDPv4 alone, as RustDDS) or `default` (its
    /// builtin ones: shared memory between processes of one host).
    async fn fastdds_1hop_with(
        &mut self,
        run: &str,
        topic: &str,
        enclave: Option<&Path>,
        transports: &str,
    ) -> Result<Value> {
        let d = self.domain();
        let mut args = vec!["--topic", topic, "--transports", transports];
        let enclave = enclave.map(|e| e.to_string_lossy().into_owned());
        if let Some(e) = &enclave {
            args.extend(["--enclave", e.as_str()]);
        }
        let sink_args: Vec<&str> = ["sink"].into_iter().chain(args.iter().copied()).collect();
        let source_args: Vec<&str> = ["source"].into_iter().chain(args.iter().copied()).collect();
        let mut sink = self.fastdds(d, &sink_args).await?;
        let mut src = self.fastdds(d, &source_args).await?;
        src.ask("wait", START).await?;
        let r = self.paced(&mut src, run, &mut sink).await?;
        src.quit().await;
        sink.quit().await;
        Ok(r)
    }

    /// rclpy's publisher -> a Python response's start slot through the package (`inline`: a plain function the
    /// engine calls on its thread), its manager in the response's process; the row and its note.
    async fn python_response_hop(&mut self, run: &str, inline: bool) -> Result<(Value, String)> {
        let d = self.domain();
        let mut args = vec!["radar-sink", "--topic", "/bench/lat_package"];
        if inline {
            args.push("--inline");
        }
        let mut sink = self.python(d, &args).await?;
        let mut src = self
            .python(d, &["source", "--topic", "/bench/lat_package"])
            .await?;
        src.ask("wait", START).await?;
        let r = self.paced(&mut src, run, &mut sink).await?;
        src.quit().await;
        sink.quit().await;
        let mut note = format!(
            "radar_ros package {}; {} starts queued or ignored (response busy)",
            r["extra"]["build"].as_str().unwrap_or("?"),
            r["extra"]["not_started"]
        );
        // RADAR_BENCH_STAGES=1 (read by the Python process): the p50 of each stage, in order
        if let Some(stages) = r["extra"]["stages_us"].as_array() {
            let parts: Vec<String> = stages
                .iter()
                .map(|s| format!("{} {} us", s[0].as_str().unwrap_or("?"), s[1]))
                .collect();
            note.push_str(&format!("; stages (p50): {}", parts.join(", ")));
        }
        Ok((r, note))
    }

    /// The Python package (issue 24): rclpy's publisher -> a Python response's start slot through the package,
    /// next to rclpy's own one hop, in the same run. Needs the package in the venv (`tests/python_package.sh`,
    /// or `pip install ./radar_ros/python` for a release build).
    pub(super) async fn python_package(&mut self) -> Result<()> {
        let (n, p) = (self.plan.latency_n + self.plan.warmup, self.plan.period_us);
        let run = format!("run {n} {p}");
        let r = self.rclpy_1hop(&run, "/bench/lat_rclpy").await?;
        self.push_latency(
            "rclpy_1hop_same_run",
            "rclpy, 1 hop (publisher -> subscriber), beside the Python package row",
            &r,
            "",
        )?;
        let (r, note) = self.python_response_hop(&run, false).await?;
        self.push_latency(
            "radar_python_1hop",
            "radar_ros Python package: rclpy publisher -> Python response's start slot (async def; manager in the response's process, 1 hop)",
            &r,
            &note,
        )?;
        let (r, note) = self.python_response_hop(&run, true).await?;
        self.push_latency(
            "radar_python_inline_1hop",
            "radar_ros Python package: rclpy publisher -> Python response's start slot (inline: a plain def called on the engine's thread, as rclpy calls a callback; 1 hop)",
            &r,
            &note,
        )?;
        // a Python event's trigger -> a Rust response's start, beside a Rust event's in the same run (the
        // manager in the response's process: one hop both)
        let (r, children) = self.radar_hop(n, p, Host::Response).await?;
        self.push_latency(
            "radar_embedded_beside_python",
            "radar_ros Rust event -> Rust response (manager in the response's process, 1 hop), beside the Python event row",
            &r,
            "",
        )?;
        for c in children {
            c.quit().await;
        }
        let d = self.domain();
        let mut ev = self
            .python(d, &["radar-source", "--topic", "/bench/py_ev"])
            .await?;
        let mut resp = self
            .child(
                d,
                &[
                    "response",
                    "--name",
                    "/bench/resp",
                    "--connect",
                    "/bench/py_ev",
                ],
            )
            .await?;
        ev.ask("wait", START).await?;
        let r = self.paced(&mut ev, &run, &mut resp).await?;
        ev.quit().await;
        resp.quit().await;
        let note = format!(
            "{} starts ignored (response busy)",
            r["extra"]["ignored_starts"]
        );
        self.push_latency(
            "radar_python_event_1hop",
            "radar_ros Python package: Python event (async def check) -> Rust response's start (manager in the response's process, 1 hop)",
            &r,
            &note,
        )
    }

    /// Paced latency from a raw ros2-client publisher to a raw subscriber: one hop, or two through a plain
    /// forwarding node.
    /// The wire's floor: a 100-byte UDP datagram between two processes on loopback, paced like the rest.
    async fn udp_latency(&mut self, run: &str) -> Result<()> {
        // a port of its own per run: the first domain's port range is far from DDS's (7400 + 250 * domain)
        let d = self.domain();
        let port = (40_000 + u32::from(d) % 20_000).to_string();
        self.floor_row(
            run,
            d,
            ["udp-sink", "udp-source"],
            ["--port", &port],
            "udp_floor",
            "UDP loopback, 1 datagram (the wire's floor, no DDS)",
        )
        .await
    }

    /// The floor of a same-host signal: a futex wake between two processes sharing a page of memory
    /// (`futex-sink` / `futex-source`), paced like the rest.
    async fn futex_latency(&mut self, run: &str) -> Result<()> {
        let d = self.domain();
        let shm = format!("radar_bench_futex_{}_{d}", std::process::id());
        self.floor_row(
            run,
            d,
            ["futex-sink", "futex-source"],
            ["--shm", &shm],
            "futex_floor",
            "a futex wake between two processes (shared memory, no DDS: a same-host signal's floor)",
        )
        .await
    }

    /// A floor row: the roles `sink` then `source` (both given `args`) on domain `d`, paced by `run`.
    async fn floor_row(
        &mut self,
        run: &str,
        d: u16,
        [sink, source]: [&str; 2],
        args: [&str; 2],
        key: &str,
        label: &str,
    ) -> Result<()> {
        let mut sink = self.child(d, &[sink, args[0], args[1]]).await?;
        let mut src = self.child(d, &[source, args[0], args[1]]).await?;
        let r = self.paced(&mut src, run, &mut sink).await?;
        self.push_latency(key, label, &r, "")?;
        src.quit().await;
        sink.quit().await;
        Ok(())
    }

    async fn raw_latency(&mut self, run: &str, forward: bool) -> Result<()> {
        let (r, children) = self.raw_hop(run, forward).await?;
        let (key, label) = if forward {
            (
                "raw_2hop",
                "raw ros2-client, 2 hops (through a forwarding node)",
            )
        } else {
            (
                "raw_1hop",
                "raw ros2-client, 1 hop (publisher -> subscriber)",
            )
        };
        self.push_latency(key, label, &r, "")?;
        for c in children {
            c.quit().await;
        }
        Ok(())
    }

    /// One paced raw run: the sink's report, and the processes (source first, sink last).
    pub(super) async fn raw_hop(
        &mut self,
        run: &str,
        forward: bool,
    ) -> Result<(Value, Vec<Child>)> {
        let d = self.domain();
        let mut sink = self
            .child(d, &["raw-sink", "--topic", "/bench/lat"])
            .await?;
        let (fwd, topic) = if forward {
            let args = [
                "raw-forward",
                "--from",
                "/bench/lat_in",
                "--to",
                "/bench/lat",
            ];
            (Some(self.child(d, &args).await?), "/bench/lat_in")
        } else {
            (None, "/bench/lat")
        };
        let mut src = self.child(d, &["raw-source", "--topic", topic]).await?;
        src.ask("wait", START).await?;
        let others: Vec<u32> = fwd.iter().map(Child::pid).collect();
        let r = self.paced_with(&mut src, run, &mut sink, &others).await?;
        Ok((
            r,
            [Some(src), fwd, Some(sink)].into_iter().flatten().collect(),
        ))
    }

    /// Paced trigger -> start latency from a radar_ros event to a response in another process, connected by
    /// the manager of `host`.
    async fn radar_latency(&mut self, n: u64, p: u64, host: Host) -> Result<()> {
        let (r, children) = self.radar_hop(n, p, host).await?;
        let note = format!(
            "{} starts ignored (response busy)",
            r["extra"]["ignored_starts"]
        );
        let (key, label) = host.row();
        let (key, label) = match self.event_trigger {
            false => (key.to_owned(), label.to_owned()),
            true => (
                format!("{key}_trigger"),
                format!("{label}, emitted by the pacing thread (Trigger)"),
            ),
        };
        self.push_latency(&key, &label, &r, &note)?;
        for c in children {
            c.quit().await;
        }
        Ok(())
    }

    /// One paced run from an event to a response connected by the manager of `host`: the response's
    /// report, and the processes (the event's first, the response's second).
    pub(super) async fn radar_hop(
        &mut self,
        n: u64,
        p: u64,
        host: Host,
    ) -> Result<(Value, Vec<Child>)> {
        let d = self.domain();
        let mut ev_args = vec!["events", "--names", "/bench/ev"];
        if self.event_trigger {
            ev_args.push("--trigger");
        }
        let mut args = vec!["response", "--name", "/bench/resp"];
        match host {
            Host::Third => {}
            Host::Response => args.extend(["--connect", "/bench/ev"]),
            Host::ResponseRelaying => args.extend(["--connect", "/bench/ev", "--relay"]),
            Host::Event => ev_args.extend(["--connect", "/bench/resp"]),
        }
        // the response first: an event that connects looks it up
        let mut resp_slot = None;
        let mut ev = if host == Host::Event {
            resp_slot = Some(self.child(d, &args).await?);
            self.child(d, &ev_args).await?
        } else {
            self.child(d, &ev_args).await?
        };
        let mut resp = match resp_slot {
            Some(r) => r,
            None => self.child(d, &args).await?,
        };
        let mgr = if host == Host::Third {
            let mut m = self.child(d, &["manager"]).await?;
            m.ask("connect /bench/ev /bench/resp", START).await?;
            Some(m)
        } else {
            None
        };
        ev.ask("active /bench/ev", START).await?;
        let others: Vec<u32> = mgr.iter().map(Child::pid).collect();
        let r = self
            .paced_with(
                &mut ev,
                &format!("run /bench/ev {n} {p}"),
                &mut resp,
                &others,
            )
            .await?;
        Ok((
            r,
            [Some(ev), Some(resp), mgr].into_iter().flatten().collect(),
        ))
    }
    /// `interrupt` published -> `interrupted` emitted (the start behaviour cancelled, the slot begun).
    pub(super) async fn interrupt(&mut self) -> Result<()> {
        let d = self.domain();
        let mut long = self
            .child(d, &["long-response", "--name", "/bench/long"])
            .await?;
        let mut drv = self
            .child(d, &["interrupter", "--name", "/bench/long"])
            .await?;
        let (n, w) = (
            self.plan.interrupt_n,
            self.plan.warmup.min(self.plan.interrupt_n / 5),
        );
        let sent = drv
            .ask_json(&format!("run {}", n + w), Duration::from_secs(60 + n / 50))
            .await?;
        tokio::time::sleep(Duration::from_millis(200)).await;
        let at = long.ask_json("report", START).await?;
        let sent: Vec<(u64, u64)> = serde_json::from_value(sent["sent"].clone())?;
        let at: std::collections::HashMap<u64, u64> =
            serde_json::from_value::<Vec<(u64, u64)>>(at["at"].clone())?
                .into_iter()
                .collect();
        let lat: Vec<u64> = sent
            .iter()
            .filter(|(seq, _)| *seq >= w)
            .filter_map(|(seq, t0)| at.get(seq).map(|t1| t1.saturating_sub(*t0)))
            .collect();
        let report = serde_json::json!({ "lat_ns": lat });
        self.push_latency(
            "radar_interrupt",
            "radar_ros interrupt -> interrupted (start behaviour cancelled), 1 hop",
            &report,
            "",
        )?;
        let last = self.results.latency.last_mut().unwrap();
        last.missing = n.saturating_sub(lat.len() as u64);
        drv.quit().await;
        long.quit().await;
        Ok(())
    }

    /// Action latency against one rclpy `test_msgs/action/Fibonacci` server: `start` published -> the
    /// server's execute callback begins, and `interrupt` published -> the server's cancel callback, through
    /// `Radar::action_response`; next to rclpy's own ActionClient doing the same (`send_goal_async`,
    /// `cancel_goal_async`) in the same run.
    pub(super) async fn action(&mut self) -> Result<()> {
        let d = self.domain();
        let (n, m) = (self.plan.action_goals, self.plan.action_cancels);
        let warm = (n / 10).max(2);
        let mut server = self
            .python(d, &["action-server", "--topic", "/bench/fib"])
            .await?;
        let timeout = Duration::from_secs(60 + n / 5);
        for radar_side in [false, true] {
            let mut client = if radar_side {
                self.child(d, &["action-driver", "--action", "/bench/fib"])
                    .await?
            } else {
                let mut c = self
                    .python(d, &["action-client", "--topic", "/bench/fib"])
                    .await?;
                c.ask("wait", START).await?;
                c
            };
            let goals = client.ask_json(&format!("run {n}"), timeout).await?;
            let at = server.ask_json("report", START).await?;
            let goal_lat = pair_latencies(&goals["sent"], &at["exec"], warm)?;
            let cancels = client.ask_json(&format!("cancel-run {m}"), timeout).await?;
            let at = server.ask_json("report", START).await?;
            let cancel_lat = pair_latencies(&cancels["sent"], &at["cancel"], 1)?;
            let (who, what) = if radar_side {
                (
                    "radar",
                    "radar_ros `start` -> rclpy server's execute callback (Radar::action_response)",
                )
            } else {
                (
                    "rclpy",
                    "rclpy ActionClient send_goal -> rclpy server's execute callback (baseline)",
                )
            };
            let key = format!("action_goal_{who}");
            self.push_latency(&key, what, &json!({ "lat_ns": goal_lat }), "")?;
            self.results.latency.last_mut().unwrap().missing =
                (n - warm).saturating_sub(goal_lat.len() as u64);
            let (key, what) = if radar_side {
                (
                    "action_cancel_radar",
                    "radar_ros `interrupt` -> rclpy server's cancel callback",
                )
            } else {
                (
                    "action_cancel_rclpy",
                    "rclpy ActionClient cancel_goal -> rclpy server's cancel callback (baseline)",
                )
            };
            self.push_latency(key, what, &json!({ "lat_ns": cancel_lat }), "")?;
            self.results.latency.last_mut().unwrap().missing =
                (m - 1).saturating_sub(cancel_lat.len() as u64);
            client.quit().await;
        }
        server.quit().await;
        Ok(())
    }
}
