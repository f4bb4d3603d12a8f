//! radar_ros's build script: the guard on the transport stack. radar_ros keeps its promises (one-shot
//! `ros2 topic pub`, bounded latched state, clean exits, the lease, causes on the wire, ...) only with the RustDDS
//! and ros2-client it carries in `third_party/`, patched; each says so through its build script (`links`
//! metadata). A build against another copy (a `[patch]` or `[replace]` in the user's workspace, a crates.io
//! release) stops here, saying what to do.

/// The patches radar_ros needs: `third_party/rustdds/RADAR_PATCHES.md` and `third_party/ros2-client/RADAR_PATCHES.md`.
const RUSTDDS_PATCHES: u32 = 70;
const ROS2_CLIENT_PATCHES: u32 = 26;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    let mut wrong = Vec::new();
    for (what, var, need, path, package) in [
        (
            "RustDDS",
            "DEP_RADAR_RUSTDDS_PATCHES",
            RUSTDDS_PATCHES,
            "third_party/rustdds",
            "radar-rustdds",
        ),
        (
            "ros2-client",
            "DEP_RADAR_ROS2_CLIENT_PATCHES",
            ROS2_CLIENT_PATCHES,
            "third_party/ros2-client",
            "radar-ros2-client",
        ),
    ] {
        println!("cargo:rerun-if-env-changed={var}");
        let found = std::env::var(var).ok().and_then(|v| v.parse::<u32>().ok());
        if found.is_none_or(|n| n < need) {
            wrong.push(format!(
                "radar_ros is being built against a {what} without radar_ros's patches ({} of {need} found). \
                 radar_ros needs the {what} of its own repository ({path}, package `{package}`), which it \
                 depends on by path: remove the `[patch]` (or `[replace]`) in your workspace that puts another \
                 {what} in its place, and depend on radar_ros by path or git as its README says \
                 (\"Use radar_ros in your crate\").",
                found.map_or("none".to_owned(), |n| n.to_string())
            ));
        }
    }
    if !wrong.is_empty() {
        for w in wrong {
            eprintln!("error: {w}");
        }
        std::process::exit(1);
    }
}
