//! Another node's parameters, read through its parameter services (what `ros2 param dump` does): any ROS 2 node,
//! a radar_ros component or an rclcpp/rclpy node.

use crate::{error::Error, node::services::service_client_of, radar::Radar, wait::Wait};
use ros2_client::{
    rcl_interfaces::{
        GetParametersRequest, GetParametersResponse, ListParametersRequest, ListParametersResponse,
    },
    ParameterValue,
};

impl Radar {
    /// The parameters of the node `node` with their values, read through its parameter services once they
    /// are on the graph (default limit [`DEFAULT_TIMEOUT`](crate::DEFAULT_TIMEOUT), `.timeout(d)` to change):
    /// what `ros2 param dump` shows. A node of this process is not seen this way: use its
    /// [`Params`](crate::node::params::Params).
    ///
    /// ```no_run
    /// # async fn f(radar: radar_ros::Radar) -> radar_ros::Result<()> {
    /// for (name, value) in radar.parameters_of("/count_up").await? {
    ///     println!("{name}: {value:?}");
    /// }
    /// # Ok(()) }
    /// ```
    ///
    /// # Cancel safety
    /// Cancel safe: it only reads.
    pub fn parameters_of(&self, node: &str) -> Wait<'static, Vec<(String, ParameterValue)>> {
        let radar = self.clone();
        let fq = self.resolve(node).map(|n| n.fully_qualified());
        Wait::discovery(move |timeout| async move {
            let fq = fq?;
            let deadline = tokio::time::Instant::now() + timeout;
            let (list, get) = radar.participant().with_client_node(|node| {
                Ok((
                    service_client_of::<ListParametersRequest, ListParametersResponse>(
                        node,
                        &fq,
                        "list_parameters",
                        "rcl_interfaces",
                        "ListParameters",
                    )?,
                    service_client_of::<GetParametersRequest, GetParametersResponse>(
                        node,
                        &fq,
                        "get_parameters",
                        "rcl_interfaces",
                        "GetParameters",
                    )?,
                ))
            })?;
            let wanted =
                crate::wire::dds_names::service_topics(&fq, &["list_parameters", "get_parameters"]);
            let timed_out = || Error::Timeout {
                what: format!("the parameter services of {fq}"),
                after: timeout,
            };
            radar
                .graph()
                .wait_for(deadline, || {
                    (!radar.graph().participants_matched_on(&wanted).is_empty()).then_some(())
                })
                .await
                .ok_or_else(timed_out)?;
            let failed = |what: &str, e: &dyn std::fmt::Debug| {
                Error::transport(
                    format!("call {fq}/{what}"),
                    crate::error::Text(format!("{e:?}")),
                )
            };
            let names = tokio::time::timeout_at(
                deadline,
                list.async_call_service(ListParametersRequest {
                    prefixes: Vec::new(),
                    depth: 0,
                }),
            )
            .await
            .map_err(|_| timed_out())?
            .map_err(|e| failed("list_parameters", &e))?
            .result
            .names;
            let values = tokio::time::timeout_at(
                deadline,
                get.async_call_service(GetParametersRequest {
                    names: names.clone(),
                }),
            )
            .await
            .map_err(|_| timed_out())?
            .map_err(|e| failed("get_parameters", &e))?
            .values;
            let mut all: Vec<(String, ParameterValue)> = names
                .into_iter()
                .zip(values.into_iter().map(ParameterValue::from))
                .collect();
            all.sort_by(|a, b| a.0.cmp(&b.0));
            Ok(all)
        })
    }
}
