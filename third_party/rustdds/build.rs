// radar_ros patch 19 (RADAR_PATCHES.md): this copy of RustDDS carries radar_ros's patches. radar_ros's build
// script reads this (as DEP_RADAR_RUSTDDS_PATCHES) and refuses to build against a RustDDS without them.
fn main() {
    println!("cargo:patches=70");
    println!("cargo:rerun-if-changed=build.rs");
}
