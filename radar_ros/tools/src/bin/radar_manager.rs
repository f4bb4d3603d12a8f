//! `radar_manager [NAME]`: a standalone RADAR connection manager node (default name `radar_manager`),
//! serving connect/disconnect/list and publishing `connections`, until SIGINT or SIGTERM.
//! Honours ROS_DOMAIN_ID and ROS_AUTOMATIC_DISCOVERY_RANGE.

#[tokio::main]
async fn main() {
    radar_tools::logging::init("info,rustdds=error,ros2_client=error");
    let name = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "radar_manager".into());
    let radar = match radar_ros::Radar::new() {
        Ok(r) => r,
        Err(e) => {
            eprintln!("radar_manager: {}", e.report());
            std::process::exit(2);
        }
    };
    let manager = match radar.serve_manager(&name) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("radar_manager: {}", e.report());
            std::process::exit(2);
        }
    };
    println!(
        "radar_manager serving as {} in domain {}",
        manager.name(),
        radar.domain_id()
    );
    // until SIGINT or SIGTERM: radar_ros then stops the manager node, leaves the ROS graph and ends the process
    let _manager = manager;
    std::future::pending::<()>().await;
}
