//! `radar`: RADAR on a ROS 2 graph from the shell (see the `radar_tools` crate docs for the verbs).

use clap::Parser;

#[tokio::main]
async fn main() {
    let cli = radar_tools::cli::Cli::parse();
    radar_tools::logging::init(
        "warn,rustdds=error,ros2_client::distributions=error,ros2_client::service::wrappers=error",
    );
    if let Err(e) = radar_tools::cli::run(cli).await {
        eprintln!("radar: {}", e.report());
        std::process::exit(1);
    }
}
