//! The system `radar view` is measured against: many components in one process, whose responses are started
//! at a given rate (as a deliberative program would start them).

use super::*;

/// `events` idle events and `responses` responses (`/view/ev_i`, `/view/resp_i`) with a start publisher for
/// each: `churn RATE MS` starts them round robin at `RATE` a second for `MS` ms and answers how many.
pub(super) async fn view_system(events: usize, responses: usize) -> Result<()> {
    scale::raise_fd_limit();
    let radar = radar()?;
    let _events: Vec<EventHandle> = (0..events)
        .map(|i| radar.spawn_event(&format!("/view/ev_{i}"), scale::Idle))
        .collect::<radar_ros::Result<_>>()?;
    let _responses: Vec<_> = (0..responses)
        .map(|i| {
            radar.spawn_response(
                &format!("/view/resp_{i}"),
                FnResponse::new(|_: Empty| async { Ok::<_, SlotError>(Empty::default()) }),
            )
        })
        .collect::<radar_ros::Result<_>>()?;
    let starts: Arc<Vec<_>> = Arc::new(
        (0..responses)
            .map(|i| radar.signal_publisher::<Empty>(&format!("/view/resp_{i}/start")))
            .collect::<radar_ros::Result<_>>()?,
    );
    for s in starts.iter() {
        s.wait_for_subscribers(1).timeout(WAIT).await?;
    }
    serve(|w| {
        let starts = starts.clone();
        async move {
            match w[0].as_str() {
                "churn" => {
                    let (rate, ms): (f64, u64) = (word(&w, 1)?, word(&w, 2)?);
                    let n = starts.len().max(1) as u64;
                    let sent = at_rate(rate, Duration::from_millis(ms), |i| {
                        let _ = starts[(i % n) as usize].publish(Empty::default());
                    })
                    .await;
                    Ok(sent.to_string())
                }
                c => bail!("unknown command {c}"),
            }
        }
    })
    .await;
    Ok(())
}
