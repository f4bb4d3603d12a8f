//! Why a verb failed: [`Error`], which the `radar` command prints after `radar: ` with its causes
//! ([`radar_ros::error::Report`]) before it exits with status 1.

/// Why a `radar` verb failed. Each variant's message says what to do next; causes are in `source()` only.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// radar_ros could not do what the verb asked (an unknown name, a timeout, a type mismatch, the transport).
    #[error(transparent)]
    Radar(#[from] radar_ros::Error),
    /// A file, a socket or a signal handler: `what` the verb could not do ("read /tmp/run.mcap").
    #[error("could not {what}")]
    Io {
        /// What the verb tried.
        what: String,
        /// The OS's answer.
        #[source]
        source: std::io::Error,
    },
    /// A library beside radar_ros (Zenoh, MCAP, JSON) failed at `what`.
    #[error("{what}")]
    Other {
        /// What the verb tried, and where.
        what: String,
        /// The library's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// What was asked cannot be done as asked (an argument, an input file, the graph's answer, a build without a
    /// feature): the message says what to give instead.
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    /// A file, socket or handler error: "could not {what}: {source}".
    pub(crate) fn io(what: impl Into<String>, source: std::io::Error) -> Error {
        Error::Io {
            what: what.into(),
            source,
        }
    }

    /// Another library's error, after `what`.
    pub(crate) fn other(
        what: impl Into<String>,
        source: impl Into<Box<dyn std::error::Error + Send + Sync>>,
    ) -> Error {
        Error::Other {
            what: what.into(),
            source: source.into(),
        }
    }

    /// The error with its causes, one line, as `radar` prints it.
    pub fn report(&self) -> radar_ros::error::Report<'_> {
        radar_ros::error::Report(self)
    }
}

impl From<String> for Error {
    fn from(message: String) -> Error {
        Error::Invalid(message)
    }
}

impl From<&str> for Error {
    fn from(message: &str) -> Error {
        Error::Invalid(message.to_owned())
    }
}

impl From<serde_json::Error> for Error {
    fn from(e: serde_json::Error) -> Error {
        Error::other("could not write JSON", e)
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::*;
    use crate::cli::{run, Cli};

    #[tokio::test]
    async fn a_verb_fails_with_a_typed_error_that_keeps_its_cause() {
        // a file that is not there: Io, with the OS's error as the cause
        let missing =
            std::env::temp_dir().join(format!("radar-missing-{}.mcap", std::process::id()));
        let cli = Cli::parse_from(["radar", "verify", missing.to_str().unwrap()]);
        match run(cli).await {
            Err(Error::Io { what, source }) => {
                assert_eq!(what, format!("read {}", missing.display()));
                assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
            }
            other => panic!("an Io error for a missing file, not {other:?}"),
        }
        // a file that is not MCAP: Other, with MCAP's error as the cause, printed once by the report
        let junk = std::env::temp_dir().join(format!("radar-junk-{}.mcap", std::process::id()));
        std::fs::write(&junk, b"not a recording").unwrap();
        let e = run(Cli::parse_from(["radar", "verify", junk.to_str().unwrap()]))
            .await
            .unwrap_err();
        let _ = std::fs::remove_file(&junk);
        let Error::Other { what, source } = &e else {
            panic!("an Other error for a file that is not MCAP, not {e:?}");
        };
        assert_eq!(
            what,
            &format!(
                "{} is not an MCAP file, or one cut off before its first message",
                junk.display()
            )
        );
        let report = e.report().to_string();
        assert_eq!(report, format!("{what}: {source}"));
        assert!(!e.to_string().contains(&source.to_string()), "{e}");
    }
}
