//! `radar router`: a Zenoh router as rmw_zenoh runs one (`ros2 run rmw_zenoh_cpp rmw_zenohd`), for a host whose
//! programs use Zenoh (docs/zenoh.md), without a ROS installation. Its configuration is read as rmw_zenohd
//! reads it: the JSON5 file `ZENOH_ROUTER_CONFIG_URI` names, or rmw_zenoh's default router (router mode,
//! listening on `tcp/[::]:7447`, gossip scouting on, multicast scouting off, timestamps; rmw_zenoh's file also
//! turns failover brokering off, a key the Zenoh here no longer has, which only made the router warn that it
//! is deprecated at every start, so it is left out), then `ZENOH_CONFIG_OVERRIDE` (`key=value;...`) on top;
//! `--listen` replaces the endpoints it listens on. Runs until SIGINT or SIGTERM, then closes the session.

use crate::common::Out;

/// rmw_zenoh's default router configuration, in what decides who meets whom.
#[cfg(feature = "zenoh")]
const DEFAULT: &[(&str, &str)] = &[
    ("mode", "\"router\""),
    ("listen/endpoints", "[\"tcp/[::]:7447\"]"),
    ("scouting/multicast/enabled", "false"),
    ("scouting/gossip/enabled", "true"),
    (
        "timestamping/enabled",
        "{ router: true, peer: true, client: false }",
    ),
    ("timestamping/drop_future_timestamp", "false"),
];

/// Runs the router until told to stop.
pub(crate) async fn router(listen: Vec<String>, out: &Out) -> Result<(), crate::Error> {
    #[cfg(feature = "zenoh")]
    {
        let config = config(&listen)?;
        let endpoints = config
            .get_json("listen/endpoints")
            .unwrap_or_else(|_| "?".into());
        let session = zenoh::open(config).await.map_err(|e| {
            crate::Error::other("the Zenoh router did not start (is the port taken?)", e)
        })?;
        let zid = session.info().zid().await.to_string();
        if out.json {
            println!(
                "{}",
                serde_json::json!({"router": zid, "listening": serde_json::from_str::<serde_json::Value>(&endpoints).unwrap_or_default()})
            );
        } else {
            println!("radar router {zid} listening on {endpoints}");
        }
        stopped().await?;
        session
            .close()
            .await
            .map_err(|e| crate::Error::other("could not close the Zenoh router", e))
    }
    #[cfg(not(feature = "zenoh"))]
    {
        let _ = (listen, out);
        Err("this radar was built without Zenoh: build radar_tools with `--features zenoh` \
             (docs/zenoh.md), or run rmw_zenoh's router (`ros2 run rmw_zenoh_cpp rmw_zenohd`) or zenohd"
            .into())
    }
}

/// The router's configuration: `ZENOH_ROUTER_CONFIG_URI`'s file or [`DEFAULT`], `ZENOH_CONFIG_OVERRIDE`, then
/// `--listen`.
#[cfg(feature = "zenoh")]
fn config(listen: &[String]) -> Result<zenoh::Config, crate::Error> {
    let mut config = match std::env::var("ZENOH_ROUTER_CONFIG_URI") {
        Ok(uri) if !uri.trim().is_empty() => zenoh::Config::from_file(uri.trim())
            .map_err(|e| crate::Error::other(format!("ZENOH_ROUTER_CONFIG_URI={uri}"), e))?,
        _ => {
            let mut c = zenoh::Config::default();
            for (key, value) in DEFAULT {
                c.insert_json5(key, value).map_err(|e| {
                    crate::Error::other(format!("the default router configuration's {key}"), e)
                })?;
            }
            c
        }
    };
    if let Ok(overrides) = std::env::var("ZENOH_CONFIG_OVERRIDE") {
        for entry in overrides
            .split(';')
            .map(str::trim)
            .filter(|e| !e.is_empty())
        {
            let (key, value) = entry.split_once('=').ok_or_else(|| {
                format!("ZENOH_CONFIG_OVERRIDE: {entry:?} is not key=value (e.g. listen/endpoints=[\"tcp/[::]:7447\"])")
            })?;
            config
                .insert_json5(key.trim(), value.trim())
                .map_err(|e| crate::Error::other(format!("ZENOH_CONFIG_OVERRIDE: {key}"), e))?;
        }
    }
    if !listen.is_empty() {
        let endpoints = serde_json::to_string(listen).expect("strings");
        config
            .insert_json5("listen/endpoints", &endpoints)
            .map_err(|e| crate::Error::other(format!("--listen {}", listen.join(" ")), e))?;
    }
    Ok(config)
}

/// Until SIGINT or SIGTERM.
#[cfg(feature = "zenoh")]
async fn stopped() -> Result<(), crate::Error> {
    use tokio::signal::unix::{signal, SignalKind};
    let mut term =
        signal(SignalKind::terminate()).map_err(|e| crate::Error::io("catch SIGTERM", e))?;
    tokio::select! {
        r = tokio::signal::ctrl_c() => r.map_err(|e| crate::Error::io("catch Ctrl-C", e)),
        _ = term.recv() => Ok(()),
    }
}
