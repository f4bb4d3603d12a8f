// radar_ros patch 5 (RADAR_PATCHES.md): this copy of ros2-client carries radar_ros's patches. radar_ros's build
// script reads this (as DEP_RADAR_ROS2_CLIENT_PATCHES) and refuses to build against a ros2-client without them.
fn main() {
    println!("cargo:patches=26");
    println!("cargo:rerun-if-changed=build.rs");
}
