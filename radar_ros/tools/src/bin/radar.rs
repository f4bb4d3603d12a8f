//! `radar`: RADAR on a ROS 2 graph from the shell (see the `radar_tools` crate docs for the verbs).

use clap::Parser;

#[tokio::main]
async fn main() {
    let cli = radar_tools::cli::Cli::parse();
    let _ = tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
                "warn,rustdds=error,ros2_client::distributions=error,ros2_client::service::wrappers=error"
                    .into()
            }),
        )
        .with_writer(std::io::stderr)
        .try_init();
    if let Err(e) = radar_tools::cli::run(cli).await {
        eprintln!("radar: {e}");
        std::process::exit(1);
    }
}
