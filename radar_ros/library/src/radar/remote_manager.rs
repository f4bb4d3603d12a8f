//! [`Radar::remote_manager`]: another program's connection manager, through its services
//! (`connections/remote.rs`).

use crate::connections::remote::RemoteManager;
use crate::{error::Error, node::services::service_client, radar::Radar, wait::Wait};

impl Radar {
    /// Clients of the manager node `name`'s services, once they are matched both ways (default limit
    /// [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change), so that no request is lost.
    pub fn remote_manager(&self, name: &str) -> Wait<'static, RemoteManager> {
        let radar = self.clone();
        let name = self.resolve(name).map(|n| n.fully_qualified());
        Wait::discovery(move |timeout| async move {
            let name = name?;
            static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
            let k = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let base = format!("{}_client_{k}", radar.program_node().base());
            let mut node = radar.participant().new_node(radar.namespace(), &base)?;
            let m = RemoteManager {
                owner: radar.participant().clone(),
                connect: service_client(&mut node, &name, "connect", "Connect")?,
                disconnect: service_client(&mut node, &name, "disconnect", "Disconnect")?,
                list: service_client(&mut node, &name, "list", "List")?,
                _node: node,
                name: name.clone(),
            };
            let local = radar.participant().served_managers();
            let wanted =
                crate::wire::dds_names::service_topics(&name, &["connect", "disconnect", "list"]);
            let deadline = tokio::time::Instant::now() + timeout;
            let matched = || {
                (local.contains(&name)
                    || !radar.graph().participants_matched_on(&wanted).is_empty())
                .then_some(())
            };
            match radar.graph().wait_for(deadline, matched).await {
                Some(()) => Ok(m),
                None => Err(Error::Timeout {
                    what: format!(
                        "the manager {name}'s services (managers seen: {})",
                        match radar.introspect().managers() {
                            m if m.is_empty() => "none".to_owned(),
                            m => m.join(", "),
                        }
                    ),
                    after: timeout,
                }),
            }
        })
    }
}
