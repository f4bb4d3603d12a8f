//! `ROS_DOMAIN_ID` as every ROS 2 tool reads it: what a `Radar` and `ZenohSignals` are on.

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
    if (102..=214).contains(&n) {
        tracing::warn!(
            domain = n,
            "ROS_DOMAIN_ID {n} maps to UDP ports in the Linux ephemeral range; prefer 0-101 or 215-232"
        );
    }
    Ok(n as u16)
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
