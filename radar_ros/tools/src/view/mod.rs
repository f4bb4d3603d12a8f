//! `radar view`: a running RADAR system in a browser, live. The feed ([`feed`]) follows the graph, the hub
//! ([`hub`]) keeps the [`model`] and sends each page a snapshot and then its changes (bounded per second), and
//! the server ([`server`]) serves the page and its WebSocket.

mod feed;
#[cfg(feature = "foxglove")]
mod foxglove;
mod hub;
pub(crate) mod model;
mod server;

use std::{net::IpAddr, sync::Arc};

use radar_ros::Radar;
use serde_json::json;

use crate::common::{Fallible, Out, Stop};

/// What `radar view` was asked for (its command-line arguments).
#[derive(clap::Args)]
pub(crate) struct Options {
    /// The port to listen on (0: any free one; the first line says which).
    #[arg(long, default_value_t = 8780)]
    pub(crate) port: u16,
    /// The address to listen on; 0.0.0.0 lets other machines open the page.
    #[arg(long, default_value = "127.0.0.1", value_name = "ADDR")]
    pub(crate) bind: IpAddr,
    /// Let the page start, interrupt and exit responses (what `radar act` does).
    #[arg(long)]
    pub(crate) allow_act: bool,
    /// Updates sent to each page a second, at most (changes in between are merged).
    #[arg(long, default_value_t = 10.0, value_name = "PER_SECOND")]
    pub(crate) rate: f64,
    /// Stop after this many seconds (default: until Ctrl-C).
    #[arg(long, value_name = "SECONDS")]
    pub(crate) duration: Option<f64>,
    /// Under DDS Security (ROS_SECURITY_ENABLE=true), the enclave the view runs in: its own, so that its
    /// permissions can be what a viewer needs (ROS_SECURITY_ENCLAVE_OVERRIDE still wins). Make it with
    /// `radar security create_enclave KEYSTORE /radar_view`.
    #[arg(long, default_value = "/radar_view", value_name = "NAME")]
    pub(crate) enclave: String,
    /// Also serve the live data to Foxglove or Lichtblick (the Foxglove SDK's WebSocket protocol) on this port
    /// (0: any free one), on --bind's address: components' states and signals as channels, and the
    /// connection graph. Needs the `foxglove` cargo feature.
    #[arg(long, value_name = "PORT")]
    pub(crate) foxglove: Option<u16>,
}

impl Options {
    /// The security the view's participant runs with: what the environment says, in the view's own enclave
    /// unless ROS_SECURITY_ENCLAVE_OVERRIDE names one; `None` when not secured (the environment decides).
    pub(crate) fn security(&self) -> Fallible<Option<radar_ros::security::SecurityOptions>> {
        let plain = radar_ros::ros_args::RosArgs::parse(["radar"])?;
        let Some(mut s) = radar_ros::security::SecurityOptions::from_env(&plain)? else {
            return Ok(None);
        };
        if std::env::var("ROS_SECURITY_ENCLAVE_OVERRIDE").map_or(true, |v| v.is_empty()) {
            s.enclave = self.enclave.clone();
        }
        Ok(Some(s))
    }
}

/// Serves the view until Ctrl-C, SIGTERM or `duration`.
pub(crate) async fn view(radar: &Radar, out: &Out, o: Options) -> Fallible<()> {
    let mut stop = Stop::catch()?;
    if !(o.rate.is_finite() && o.rate > 0.0 && o.rate <= 100.0) {
        return Err(format!(
            "--rate {}: give the number of updates a second, above 0 and at most 100",
            o.rate
        )
        .into());
    }
    let listener = tokio::net::TcpListener::bind((o.bind, o.port))
        .await
        .map_err(|e| {
            crate::Error::io(
                format!(
                    "listen on {}:{} (another radar view there? give --port N, or --port 0 for any free port)",
                    o.bind, o.port
                ),
                e,
            )
        })?;
    let addr = listener
        .local_addr()
        .map_err(|e| crate::Error::io("tell the port listened on", e))?;
    if !addr.ip().is_loopback() {
        eprintln!(
            "radar view: listening on {addr}: other machines can open it{}",
            match o.allow_act {
                true => ", and with --allow-act anyone who can reach it can start and interrupt responses",
                false => "",
            }
        );
    }
    let (seen_tx, seen_rx) = tokio::sync::mpsc::unbounded_channel();
    let (ask_tx, ask_rx) = tokio::sync::mpsc::unbounded_channel();
    let info = json!({ "domain": radar.domain_id(), "allow_act": o.allow_act, "rate": o.rate });
    let info = info.as_object().cloned().unwrap_or_default();
    let hub = tokio::spawn(hub::run(
        model::Limits::default(),
        o.rate,
        info,
        seen_rx,
        ask_rx,
    ));
    let feed = tokio::spawn(feed::run(radar.clone(), seen_tx));
    let foxglove = match o.foxglove {
        None => None,
        Some(port) => Some(foxglove_server(o.bind, port, &ask_tx).await?),
    };
    let url = format!("http://{addr}/");
    let foxglove_url = foxglove.as_ref().map(|(url, _)| url.clone());
    if out.json {
        println!(
            "{}",
            json!({ "url": url, "domain": radar.domain_id(), "foxglove": foxglove_url })
        );
    } else {
        println!(
            "radar view of ROS_DOMAIN_ID {}: open {url} in a browser (Ctrl-C to stop)",
            radar.domain_id()
        );
        if let Some(f) = &foxglove_url {
            println!("Foxglove or Lichtblick: open the connection {f}");
        }
    }
    let shared = Arc::new(server::Shared::new(radar.clone(), ask_tx, o.allow_act));
    let serve = axum::serve(listener, server::app(shared));
    let result = tokio::select! {
        r = serve => r.map_err(|e| crate::Error::io("go on serving the view (its server stopped)", e)),
        _ = stop.after(o.duration) => Ok(()),
    };
    feed.abort();
    hub.abort();
    if let Some((_, task)) = foxglove {
        task.abort();
    }
    result
}

/// The Foxglove server (`--foxglove PORT`): its URL and the task that feeds it.
#[cfg(feature = "foxglove")]
async fn foxglove_server(
    bind: IpAddr,
    port: u16,
    asks: &tokio::sync::mpsc::UnboundedSender<hub::Ask>,
) -> Fallible<(String, tokio::task::JoinHandle<()>)> {
    let (port, task) = foxglove::start(bind, port, asks.clone()).await?;
    let host = match bind {
        IpAddr::V6(a) => format!("[{a}]"),
        a => a.to_string(),
    };
    Ok((format!("ws://{host}:{port}"), task))
}

/// Without the `foxglove` feature: says how to build it.
#[cfg(not(feature = "foxglove"))]
async fn foxglove_server(
    _bind: IpAddr,
    _port: u16,
    _asks: &tokio::sync::mpsc::UnboundedSender<hub::Ask>,
) -> Fallible<(String, tokio::task::JoinHandle<()>)> {
    Err("--foxglove: this radar was built without Foxglove: build it with `cargo build -p radar_tools \
         --features foxglove`"
        .into())
}
