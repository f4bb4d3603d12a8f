//! radar_ros's build script: the guard on the transport stack. radar_ros keeps its promises (one-shot
//! `ros2 topic pub`, bounded latched state, clean exits, the lease, causes on the wire, ...) only with the RustDDS
//! and ros2-client it carries in `third_party/`, patched; each says so through its build script (`links`
//! metadata). A build against another copy (a `[patch]` or `[replace]` in the user's workspace, a crates.io
//! release) stops here, saying what to do.

/// The patches radar_ros needs: `third_party/rustdds/RADAR_PATCHES.md` and `third_party/ros2-client/RADAR_PATCHES.md`.
const RUSTDDS_PATCHES: u32 = 42;
const ROS2_CLIENT_PATCHES: u32 = 6;

/// The interface definitions shipped in `interfaces/` (`<pkg>/msg|srv|action/<Name>.<ext>`), as a table the
/// `codec` feature compiles in: `(path, text)` for every file, sorted by path.
fn bundle_interfaces() {
    let root =
        std::path::Path::new(&std::env::var("CARGO_MANIFEST_DIR").unwrap()).join("interfaces");
    println!("cargo:rerun-if-changed={}", root.display());
    let mut files = Vec::new();
    let mut dirs = vec![root.clone()];
    while let Some(d) = dirs.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                println!("cargo:rerun-if-changed={}", p.display());
                dirs.push(p);
            } else if p
                .extension()
                .is_some_and(|x| x == "msg" || x == "srv" || x == "action")
            {
                let rel = p
                    .strip_prefix(&root)
                    .unwrap()
                    .to_string_lossy()
                    .replace('\\', "/");
                files.push((rel, p));
            }
        }
    }
    files.sort();
    let mut out = String::from(
        "/// Interface definitions shipped with radar_ros: `(pkg/kind/Name.ext, text)`.\n",
    );
    out.push_str("pub(crate) static BUNDLED: &[(&str, &str)] = &[\n");
    for (rel, p) in &files {
        out.push_str(&format!(
            "    ({rel:?}, include_str!({:?})),\n",
            p.display().to_string()
        ));
    }
    out.push_str("];\n");
    let dest =
        std::path::Path::new(&std::env::var("OUT_DIR").unwrap()).join("bundled_interfaces.rs");
    std::fs::write(dest, out).unwrap();
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    bundle_interfaces();
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
