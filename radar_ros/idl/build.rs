//! radar_idl's build script: the interface definitions shipped in `interfaces/` compiled in as a table.

/// The interface definitions shipped in `interfaces/` (`<pkg>/msg|srv|action/<Name>.<ext>`), as a table compiled
/// in: `(path, text)` for every file, sorted by path.
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
        "/// Interface definitions shipped with radar_idl: `(pkg/kind/Name.ext, text)`.\n",
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
}
