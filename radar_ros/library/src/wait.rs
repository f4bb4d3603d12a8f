//! The one way radar_ros waits: every call that waits returns a [`Wait`], which does nothing until it is
//! awaited, and takes `.timeout(d)` to change how long it may take.
//!
//! - Waiting for discovery (a component, a publisher or subscriber, a connection to arm) has a default limit,
//!   [`DEFAULT_TIMEOUT`] (5 s), after which it fails with [`Error::Timeout`](crate::Error::Timeout).
//! - Waiting for a signal (`recv`, `waitfor`) has none: a signal may take hours. `.timeout(d)` bounds the
//!   whole call, discovery included.
//!
//! ```no_run
//! # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
//! use std::time::Duration;
//! let dock = radar.response("dock").await?;                                // up to 5 s
//! let arm = radar.response("arm").timeout(Duration::from_secs(30)).await?; // up to 30 s
//! # Ok(()) }
//! ```

use std::{
    future::{Future, IntoFuture},
    pin::Pin,
    time::Duration,
};

use crate::error::{Error, Result};

/// How long calls that wait for discovery wait unless given `.timeout(d)`.
pub const DEFAULT_TIMEOUT: Duration = Duration::from_secs(5);

type Run<'a, T> = Box<
    dyn FnOnce(Option<Duration>) -> Pin<Box<dyn Future<Output = Result<T>> + Send + 'a>>
        + Send
        + 'a,
>;

/// A call that waits: nothing happens until it is awaited; `.timeout(d)` changes how long it may take.
///
/// - Waiting for discovery (a component, a publisher or subscriber, a connection to arm) has a default limit,
///   [`DEFAULT_TIMEOUT`] (5 s), after which it fails with [`Error::Timeout`].
/// - Waiting for a signal (`recv`, `waitfor`) has none: a signal may take hours. `.timeout(d)` bounds the
///   whole call, discovery included.
///
/// ```no_run
/// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
/// use std::time::Duration;
/// let dock = radar.response("dock").await?;                                // up to 5 s
/// let arm = radar.response("arm").timeout(Duration::from_secs(30)).await?; // up to 30 s
/// # Ok(()) }
/// ```
#[must_use = "nothing happens until this is awaited"]
pub struct Wait<'a, T> {
    run: Run<'a, T>,
    timeout: Option<Duration>,
}

impl<'a, T: 'a> Wait<'a, T> {
    /// A wait that gets the limit to apply (`None`: none was asked for).
    pub(crate) fn new<F, Fut>(default: Option<Duration>, f: F) -> Wait<'a, T>
    where
        F: FnOnce(Option<Duration>) -> Fut + Send + 'a,
        Fut: Future<Output = Result<T>> + Send + 'a,
    {
        Wait {
            run: Box::new(move |t| Box::pin(f(t))),
            timeout: default,
        }
    }

    /// A wait for discovery: `f` gets the limit, [`DEFAULT_TIMEOUT`] unless `.timeout(d)` changed it, and
    /// fails with [`Error::Timeout`] itself when it runs out.
    pub(crate) fn discovery<F, Fut>(f: F) -> Wait<'a, T>
    where
        F: FnOnce(Duration) -> Fut + Send + 'a,
        Fut: Future<Output = Result<T>> + Send + 'a,
    {
        Wait::new(Some(DEFAULT_TIMEOUT), move |t| {
            f(t.unwrap_or(DEFAULT_TIMEOUT))
        })
    }

    /// A wait for a signal (`what`): unbounded unless `.timeout(d)`, then [`Error::Timeout`] after it.
    pub(crate) fn signal<Fut>(what: String, fut: Fut) -> Wait<'a, T>
    where
        Fut: Future<Output = Result<T>> + Send + 'a,
    {
        Wait::new(None, move |t| async move {
            match t {
                None => fut.await,
                Some(d) => tokio::time::timeout(d, fut)
                    .await
                    .map_err(|_| Error::Timeout { what, after: d })?,
            }
        })
    }

    /// Waits at most `d` (instead of the default: [`DEFAULT_TIMEOUT`] for discovery, none for a signal).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// let r = radar.response("dock").timeout(std::time::Duration::from_secs(20)).await?;
    /// # Ok(()) }
    /// ```
    pub fn timeout(mut self, d: Duration) -> Wait<'a, T> {
        self.timeout = Some(d);
        self
    }
}

impl<'a, T: 'a> IntoFuture for Wait<'a, T> {
    type Output = Result<T>;
    type IntoFuture = Pin<Box<dyn Future<Output = Result<T>> + Send + 'a>>;
    fn into_future(self) -> Self::IntoFuture {
        (self.run)(self.timeout)
    }
}

impl<T> std::fmt::Debug for Wait<'_, T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Wait")
            .field("timeout", &self.timeout)
            .finish_non_exhaustive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn a_discovery_wait_gets_the_default_or_the_asked_limit() {
        let got = Wait::discovery(|t| async move { Ok(t) }).await.unwrap();
        assert_eq!(got, DEFAULT_TIMEOUT);
        let got = Wait::discovery(|t| async move { Ok(t) })
            .timeout(Duration::from_secs(9))
            .await
            .unwrap();
        assert_eq!(got, Duration::from_secs(9));
    }

    #[tokio::test(start_paused = true)]
    async fn a_signal_wait_is_unbounded_unless_told() {
        let never = Wait::<()>::signal("a signal on /x".into(), std::future::pending());
        let e = never.timeout(Duration::from_secs(2)).await.unwrap_err();
        assert_eq!(
            e.to_string(),
            "timed out after 2s waiting for a signal on /x"
        );
        let late = Wait::signal("a signal on /x".into(), async {
            tokio::time::sleep(Duration::from_secs(3600)).await;
            Ok(7)
        });
        assert_eq!(late.await.unwrap(), 7, "no limit by default");
    }
}
