//! The environment every transport reads: `ROS_DOMAIN_ID` as every ROS 2 tool reads it, and the lease
//! (`RADAR_LEASE_SECONDS`): what a `Radar` and `ZenohSignals` are on.

use std::time::Duration;

use crate::error::{Error, Result};

/// A lookup of environment variables, as [`std::env::var`] answers (tests give their own).
pub(crate) type Env<'a> = &'a dyn Fn(&str) -> std::result::Result<String, std::env::VarError>;

/// Parses a `ROS_DOMAIN_ID` value the way ROS 2 tools do: empty means 0, otherwise a whole number 0..=232.
pub(crate) fn parse_domain_id(value: &str) -> Result<u16> {
    let v = value.trim();
    if v.is_empty() {
        return Ok(0);
    }
    let bad = |reason: &str| {
        Error::Config {
        setting: "ROS_DOMAIN_ID",
        value: value.to_owned(),
        reason: format!(
            "{reason}; set ROS_DOMAIN_ID to a whole number from 0 to 232 (0-101 and 215-232 avoid the Linux \
             ephemeral port range), or unset it for domain 0"
        ),
    }
    };
    let n: u64 = v.parse().map_err(|_| bad("it is not a whole number"))?;
    if n > 232 {
        return Err(bad(
            "it is above 232, the largest domain whose UDP ports fit in 16 bits",
        ));
    }
    Ok(n as u16)
}

/// Over DDS, warns when `domain`'s UDP ports fall in the Linux ephemeral range (over Zenoh a domain is a key
/// prefix, with no ports of its own).
pub(crate) fn warn_if_ephemeral(domain: u16) {
    if (102..=214).contains(&domain) {
        tracing::warn!(
            domain,
            "ROS_DOMAIN_ID {domain} maps to UDP ports in the Linux ephemeral range; prefer 0-101 or 215-232"
        );
    }
}

/// `ROS_DOMAIN_ID` as every ROS 2 tool reads it (0 when unset).
pub(crate) fn domain_id_in(env: Env<'_>) -> Result<u16> {
    match env("ROS_DOMAIN_ID") {
        Ok(v) => parse_domain_id(&v),
        Err(std::env::VarError::NotPresent) => Ok(0),
        Err(std::env::VarError::NotUnicode(v)) => Err(Error::Config {
            setting: "ROS_DOMAIN_ID",
            value: v.to_string_lossy().into_owned(),
            reason: "it is not valid UTF-8; set it to a whole number from 0 to 232".into(),
        }),
    }
}

/// How long other participants keep a radar_ros participant alive after its last announcement, unless
/// [`RadarBuilder::lease`](crate::RadarBuilder::lease) or `RADAR_LEASE_SECONDS` says otherwise.
///
/// A RADAR program that is killed (`SIGKILL`, a crash, power loss) cannot say goodbye; its peers notice it when
/// its lease runs out. (Over Zenoh, where a router restart makes every peer's tokens vanish and come back, it
/// is how long a departure must last before it is believed: docs/zenoh.md.) With 3 s a dead deliberative program's connections are removed, and the events it
/// listened to stop checking, within about 3.6 s (lease plus one check period of 0.6 s) in radar_ros peers and
/// about 3 s in Fast DDS (rclpy) peers. The price: each participant announces itself every 0.6 s instead of
/// every 10 s. Measured (tcpdump, one idle participant): an announcement is one 292-byte SPDP datagram to the
/// multicast group, about 490 bytes/s per participant on the network (29 bytes/s with a 50 s lease), plus 11
/// copies to the same-host discovery ports on loopback. RustDDS's own default lease is 50 s; Fast DDS's is
/// 20 s. Peers keep their own lease; this sets only the one this participant announces. On a lossy network
/// (Wi-Fi) raise it, so that a few lost announcements in a row do not declare a live program dead.
pub const DEFAULT_LEASE: std::time::Duration = std::time::Duration::from_secs(3);

pub(crate) fn parse_lease(value: &str) -> Result<std::time::Duration> {
    let bad = |reason: &str| {
        Error::Config {
        setting: "RADAR_LEASE_SECONDS",
        value: value.to_owned(),
        reason: format!(
            "{reason}; give the lease in seconds, from 0.1 up (e.g. 3, or 1.5), or unset it for {}s",
            DEFAULT_LEASE.as_secs_f64()
        ),
    }
    };
    let secs: f64 = value
        .trim()
        .parse()
        .map_err(|_| bad("it is not a number"))?;
    if !secs.is_finite() || secs < 0.1 {
        return Err(bad("it is below 0.1 s"));
    }
    if secs > 86_400.0 {
        return Err(bad("it is above a day"));
    }
    Ok(std::time::Duration::from_secs_f64(secs))
}

/// `RADAR_LEASE_SECONDS` (seconds, may have a fraction; unset: [`DEFAULT_LEASE`]).
pub(crate) fn lease_in(env: Env<'_>) -> Result<Duration> {
    let value = match env("RADAR_LEASE_SECONDS") {
        Err(std::env::VarError::NotPresent) => return Ok(DEFAULT_LEASE),
        Err(std::env::VarError::NotUnicode(v)) => v.to_string_lossy().into_owned(),
        Ok(v) => v,
    };
    parse_lease(&value)
}
