//! Action clients on the transport of their node: over DDS ros2-client's `ActionClient` (requests and replies
//! matched by request id), over Zenoh ros2-client's Zenoh `ActionClient` (each call one query, its answer one
//! future). What `components/action/client.rs` needs of either: send a goal and await its answer (from the
//! start slot and, rule A5, from a cancel), ask for the result once per goal and await it, cancel, read a goal's
//! feedback.

#[cfg(feature = "zenoh")]
use futures::FutureExt;
use futures::{Stream, StreamExt};
use ros2_client::{action::GoalId, action_msgs::GoalStatusEnum, RmwRequestId};

use crate::error::Text;

/// An action client, on the transport of its node (made once: the variants' sizes differ).
#[allow(clippy::large_enum_variant)]
pub(crate) enum ActionClient<G, R, F>
where
    G: ros2_client::Message + Clone,
    R: ros2_client::Message + Clone,
    F: ros2_client::Message,
{
    /// Over DDS.
    Dds(ros2_client::dds::ActionClient<G, R, F>),
    /// Over Zenoh, as rmw_zenoh's: queries on the `send_goal`, `get_result` and `cancel_goal` services.
    #[cfg(feature = "zenoh")]
    Zenoh(std::sync::Arc<ros2_client::zenoh::ActionClient<G, R, F>>),
}

/// A call sent, whose answer may be awaited more than once (the start slot, then a cancel: rule A5).
#[derive(Clone)]
pub(crate) enum Call<T: Clone> {
    /// Over DDS: the request's id; the reply is read by it.
    Dds(RmwRequestId),
    /// Over Zenoh: the query, sent at once by a task of its own, and its answer; the task is aborted when the
    /// last copy of the call is dropped (a response dropped mid-goal leaves no query asked again and again).
    #[cfg(feature = "zenoh")]
    Zenoh {
        /// The answer, awaited by each who asks.
        answer: futures::future::Shared<futures::future::BoxFuture<'static, Result<T, Text>>>,
        /// Aborts the task when the last copy goes.
        _task: std::sync::Arc<AbortOnDrop>,
    },
    #[cfg(not(feature = "zenoh"))]
    #[allow(dead_code)] // `T` is Zenoh's only
    Never(std::marker::PhantomData<T>),
}

/// A goal's end as the result call says it: its status and result.
pub(crate) type Outcome<R> = (GoalStatusEnum, R);

/// The wire's status code as `action_msgs/msg/GoalStatus` numbers it (anything else: unknown).
#[cfg(feature = "zenoh")]
fn status_of(code: i8) -> GoalStatusEnum {
    use GoalStatusEnum as E;
    [
        E::Unknown,
        E::Accepted,
        E::Executing,
        E::Canceling,
        E::Succeeded,
        E::Canceled,
        E::Aborted,
    ]
    .into_iter()
    .find(|s| *s as i8 == code)
    .unwrap_or(E::Unknown)
}

/// `work` run now in a task of its own, its answer awaitable by any number of clones (a query goes out when
/// its future is first polled: a task polls it at once, as DDS writes a request at once).
#[cfg(feature = "zenoh")]
fn sent<T: Clone + Send + Sync + 'static>(
    work: impl std::future::Future<Output = Result<T, Text>> + Send + 'static,
) -> Call<T> {
    let task = tokio::spawn(work);
    let abort = std::sync::Arc::new(AbortOnDrop(task.abort_handle()));
    Call::Zenoh {
        answer: task
            .map(|r| r.unwrap_or_else(|e| Err(Text(format!("the call's task ended: {e}")))))
            .boxed()
            .shared(),
        _task: abort,
    }
}

/// Aborts a call's task when dropped.
#[cfg(feature = "zenoh")]
pub(crate) struct AbortOnDrop(tokio::task::AbortHandle);

#[cfg(feature = "zenoh")]
impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

impl<G, R, F> ActionClient<G, R, F>
where
    G: ros2_client::Message + Clone + Send + Sync + 'static,
    R: ros2_client::Message + Clone + Send + Sync + 'static,
    F: ros2_client::Message + Send + Sync + 'static,
{
    /// Sends `goal` with a new goal id.
    pub(crate) fn send_goal(&self, goal: G) -> Result<(Call<bool>, GoalId), Text> {
        match self {
            ActionClient::Dds(c) => c
                .send_goal(goal)
                .map(|(req, id)| (Call::Dds(req), id))
                .map_err(|e| Text(format!("{e:?}"))),
            #[cfg(feature = "zenoh")]
            ActionClient::Zenoh(c) => {
                let (c, id) = (c.clone(), GoalId::new_random());
                let call = sent(async move {
                    c.async_send_goal(id, goal)
                        .await
                        .map(|r| r.accepted)
                        .map_err(|e| Text(e.to_string()))
                });
                Ok((call, id))
            }
        }
    }

    /// Whether the server accepted the goal `call` sent (goal `goal`).
    ///
    /// Over DDS the answer is the reply, or the goal in the server's status list, whichever comes first: a
    /// server answers as soon as it has the goal, and if its reply writer has not yet matched our reply reader
    /// (discovery runs on each side at its own pace; rmw_fastrtps waits ~100 ms for the match, then drops the
    /// reply) the answer is lost and never sent again, while the status list (transient local) reaches us
    /// whenever its writer matches. A goal in the list was accepted; a rejected goal is never in it.
    pub(crate) async fn goal_answer(&self, call: &Call<bool>, goal: GoalId) -> Result<bool, Text> {
        match (self, call) {
            (ActionClient::Dds(c), Call::Dds(req)) => {
                use futures::FutureExt;
                let reply = c.goal_client().async_receive_response(*req).fuse();
                let listed = async {
                    let statuses = c.status_stream(goal);
                    futures::pin_mut!(statuses);
                    while let Some(s) = statuses.next().await {
                        match s {
                            Ok(s) if s.status != GoalStatusEnum::Unknown => return s.status,
                            _ => {}
                        }
                    }
                    // the stream ended (the client is going away): the reply is all there is
                    std::future::pending().await
                }
                .fuse();
                futures::pin_mut!(reply, listed);
                futures::select_biased! {
                    r = reply => r.map(|r| r.accepted).map_err(|e| Text(format!("{e:?}"))),
                    status = listed => {
                        tracing::debug!(?status, "no answer to the goal came; the server's status list has it");
                        Ok(true)
                    }
                }
            }
            #[cfg(feature = "zenoh")]
            (_, Call::Zenoh { answer, .. }) => answer.clone().await,
            _ => Err(Text("a call of another transport".into())),
        }
    }

    /// Asks for goal `goal`'s result (once per goal: a server may answer only one request for it).
    pub(crate) fn request_result(&self, goal: GoalId) -> Result<Call<Outcome<R>>, Text> {
        match self {
            ActionClient::Dds(c) => c
                .request_result(goal)
                .map(Call::Dds)
                .map_err(|e| Text(format!("{e:?}"))),
            #[cfg(feature = "zenoh")]
            ActionClient::Zenoh(c) => {
                let c = c.clone();
                Ok(sent(async move { zenoh_result(&c, goal).await }))
            }
        }
    }

    /// The goal's status and result, as `call` asked for them.
    pub(crate) async fn result(&self, call: &Call<Outcome<R>>) -> Result<Outcome<R>, Text> {
        match (self, call) {
            (ActionClient::Dds(c), Call::Dds(req)) => c
                .result_client()
                .async_receive_response(*req)
                .await
                .map(|r| (r.status, r.result))
                .map_err(|e| Text(format!("{e:?}"))),
            #[cfg(feature = "zenoh")]
            (_, Call::Zenoh { answer, .. }) => answer.clone().await,
            _ => Err(Text("a call of another transport".into())),
        }
    }

    /// Asks the server to cancel goal `goal`; its answer's return code.
    pub(crate) async fn cancel(&self, goal: GoalId) -> Result<String, Text> {
        match self {
            ActionClient::Dds(c) => c
                .async_cancel_goal(goal, ros2_client::builtin_interfaces::Time::ZERO)
                .await
                .map(|r| format!("{:?}", r.return_code))
                .map_err(|e| Text(format!("{e:?}"))),
            #[cfg(feature = "zenoh")]
            ActionClient::Zenoh(c) => c
                .async_cancel_goal(goal)
                .await
                .map(|r| format!("{:?}", r.return_code))
                .map_err(|e| Text(e.to_string())),
        }
    }

    /// Goal `goal`'s feedback as it comes (others' goals left out; a message that does not decode skipped).
    pub(crate) fn feedback(&self, goal: GoalId) -> impl Stream<Item = F> + '_ {
        #[cfg(not(feature = "zenoh"))]
        {
            let ActionClient::Dds(c) = self;
            c.feedback_stream(goal)
                .filter_map(|f| std::future::ready(f.ok()))
        }
        #[cfg(feature = "zenoh")]
        match self {
            ActionClient::Dds(c) => futures::future::Either::Left(
                c.feedback_stream(goal)
                    .filter_map(|f| std::future::ready(f.ok())),
            ),
            ActionClient::Zenoh(c) => futures::future::Either::Right(
                c.feedback_subscription()
                    .async_stream()
                    .take_while(|r| {
                        std::future::ready(!matches!(r, Err(ros2_client::ReadError::Closed)))
                    })
                    .filter_map(move |r| {
                        std::future::ready(match r {
                            Ok((m, _)) if m.goal_id == goal => Some(m.feedback),
                            _ => None,
                        })
                    }),
            ),
        }
    }
}

/// Over Zenoh, the goal's result: asked again when the query timed out while the goal ran (a query lives a
/// minute, a goal may run longer), not when no server answered at all.
#[cfg(feature = "zenoh")]
async fn zenoh_result<G, R, F>(
    c: &ros2_client::zenoh::ActionClient<G, R, F>,
    goal: GoalId,
) -> Result<Outcome<R>, Text>
where
    G: serde::Serialize,
    R: serde::de::DeserializeOwned,
    F: serde::de::DeserializeOwned,
{
    loop {
        let asked = std::time::Instant::now();
        match c.async_get_result(goal).await {
            Ok((code, r)) => return Ok((status_of(code), r)),
            Err(ros2_client::ServiceError::NoReply)
                if asked.elapsed() >= std::time::Duration::from_secs(30) =>
            {
                tracing::debug!("no result within the query's timeout; asking again")
            }
            Err(e) => return Err(Text(e.to_string())),
        }
    }
}

#[cfg(all(test, feature = "zenoh"))]
mod tests {
    use super::*;

    /// Sets its flag when dropped: tells that a task's future was dropped (the task aborted).
    struct Dropped(std::sync::Arc<std::sync::atomic::AtomicBool>);

    impl Drop for Dropped {
        fn drop(&mut self) {
            self.0.store(true, std::sync::atomic::Ordering::SeqCst);
        }
    }

    /// A call whose answer never comes (a result asked of a server that ignores the cancel) does not outlive
    /// its last copy: its task is aborted; while a copy remains, the task runs.
    #[tokio::test]
    async fn a_call_dropped_aborts_its_task() {
        let flag = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let guard = Dropped(flag.clone());
        let call: Call<bool> = sent(async move {
            let _guard = guard;
            std::future::pending::<Result<bool, Text>>().await
        });
        let copy = call.clone();
        drop(call);
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
        assert!(
            !flag.load(std::sync::atomic::Ordering::SeqCst),
            "a copy remains: the task runs"
        );
        drop(copy);
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(5);
        while !flag.load(std::sync::atomic::Ordering::SeqCst) {
            assert!(
                std::time::Instant::now() < deadline,
                "the task still runs 5 s after the call was dropped"
            );
            tokio::task::yield_now().await;
        }
    }
}
