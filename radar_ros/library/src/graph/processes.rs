//! Which process a participant runs in, and whether it still runs (rule C5 for a component started twice, or
//! again at once).
//!
//! A radar_ros participant announces its process in its USER_DATA, beside ROS 2's `enclave=`:
//! `radarprocess=<boot id>.<pid namespace>.<pid>.<start time>;` (the key in letters only, the value in letters, digits
//! and dots: rclpy's parser of USER_DATA drops the whole list, `enclave=` with it, over a key with `_` in it;
//! `tests/interop.rs` checks that rclpy still reads the enclave). Another radar_ros program on the same host
//! (the same boot, the same pid namespace) can then tell whether that process still runs: `/proc/<pid>` is
//! there and started at that time. A process killed and started again at once (a respawn) is so seen gone at
//! once, without waiting for its lease; a second live process of one name is seen alive. On another host, or in
//! another pid namespace (a container), nothing is known: the lease tells.

use radar_semantics::instances::Liveness;

const KEY: &str = "radarprocess=";

/// This process as it announces itself: `<boot id>.<pid namespace>.<pid>.<start time>` (empty parts where
/// `/proc` does not tell).
pub(crate) fn this_process() -> String {
    let pid = std::process::id();
    format!(
        "{}.{}.{pid}.{}",
        boot_id().unwrap_or_default(),
        pid_namespace().unwrap_or_default(),
        start_time(pid).unwrap_or_default()
    )
}

/// The USER_DATA entry that announces this process.
pub(crate) fn user_data_entry() -> String {
    format!("{KEY}{};", this_process())
}

/// This boot of this host, as hex digits.
fn boot_id() -> Option<String> {
    let id = std::fs::read_to_string("/proc/sys/kernel/random/boot_id").ok()?;
    Some(id.chars().filter(char::is_ascii_hexdigit).collect())
}

/// This process's pid namespace, as its inode number (`pid:[4026531836]`).
fn pid_namespace() -> Option<String> {
    let link = std::fs::read_link("/proc/self/ns/pid").ok()?;
    Some(
        link.to_string_lossy()
            .chars()
            .filter(char::is_ascii_digit)
            .collect(),
    )
}

/// Field 22 of `/proc/<pid>/stat`: when the process started, in clock ticks since boot.
fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // the command name (field 2) is in parentheses and may hold spaces: count from after it
    let rest = &stat[stat.rfind(')')? + 2..];
    rest.split_whitespace().nth(19)?.parse().ok()
}

/// What `user_data` (a participant's USER_DATA) says of whether its process still runs.
pub(crate) fn liveness(user_data: &[u8]) -> Liveness {
    let Some(announced) = std::str::from_utf8(user_data)
        .ok()
        .and_then(|s| s.split(';').find_map(|kv| kv.trim().strip_prefix(KEY)))
    else {
        return Liveness::Unknown;
    };
    let mut parts = announced.split('.');
    let (Some(boot), Some(ns), Some(pid), Some(start)) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Liveness::Unknown;
    };
    let same_host = !boot.is_empty()
        && Some(boot) == boot_id().as_deref()
        && !ns.is_empty()
        && Some(ns) == pid_namespace().as_deref();
    let Ok(pid) = pid.parse::<u32>() else {
        return Liveness::Unknown;
    };
    if !same_host {
        return Liveness::Unknown;
    }
    match start_time(pid) {
        Some(t) if t.to_string() == start => Liveness::Alive,
        _ => Liveness::Dead,
    }
}

/// How a user recognises the process of a participant that announced `user_data`: `process 1234 on this
/// host`, `process 1234 on another host`, else by the participant's GUID prefix (an rclpy or other program).
pub(crate) fn describe(user_data: &[u8], prefix: &[u8]) -> String {
    let announced = std::str::from_utf8(user_data)
        .ok()
        .and_then(|s| s.split(';').find_map(|kv| kv.trim().strip_prefix(KEY)));
    let hex: String = prefix.iter().map(|b| format!("{b:02x}")).collect();
    match announced.map(|a| a.split('.').collect::<Vec<_>>()) {
        Some(parts) if parts.len() == 4 => {
            let here = Some(parts[0]) == boot_id().as_deref()
                && Some(parts[1]) == pid_namespace().as_deref();
            format!(
                "process {} on {} (participant {hex})",
                parts[2],
                if here { "this host" } else { "another host" }
            )
        }
        _ => format!("participant {hex}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn this_process_is_alive_and_a_gone_one_is_dead_and_another_hosts_unknown() {
        assert_eq!(liveness(user_data_entry().as_bytes()), Liveness::Alive);
        assert_eq!(
            liveness(format!("enclave=/;{}", user_data_entry()).as_bytes()),
            Liveness::Alive
        );
        // a child that has exited: this host, no such process (or one started at another time)
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        let start = start_time(pid).unwrap_or(0);
        child.wait().unwrap();
        let mine = this_process();
        let parts: Vec<&str> = mine.split('.').collect();
        let gone = format!("{KEY}{}.{}.{pid}.{start};", parts[0], parts[1]);
        assert_eq!(liveness(gone.as_bytes()), Liveness::Dead);
        // the same pid, started at another time (the pid reused): not the one announced
        let reused = format!("{KEY}{}.{}.{}.1;", parts[0], parts[1], std::process::id());
        assert_eq!(liveness(reused.as_bytes()), Liveness::Dead);
        // another boot (another host), or nothing announced (rclpy, Fast DDS)
        let elsewhere = format!(
            "{KEY}00000000000000000000000000000000.{}.{pid}.{start};",
            parts[1]
        );
        assert_eq!(liveness(elsewhere.as_bytes()), Liveness::Unknown);
        assert_eq!(liveness(b"enclave=/;"), Liveness::Unknown);
        assert_eq!(
            describe(user_data_entry().as_bytes(), &[0xab, 1]),
            format!(
                "process {} on this host (participant ab01)",
                std::process::id()
            )
        );
        assert_eq!(describe(b"enclave=/;", &[0xab]), "participant ab");
    }
}
