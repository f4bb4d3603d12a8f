//! The floor of a same-host signal (issue 71): two processes, one page of shared memory, one futex. The source
//! writes a signal's sequence number and stamp into the next slot of a ring in the page, bumps the futex word
//! and wakes the sink, which was asleep in `FUTEX_WAIT` on it: one store and one wake-up, what any same-host
//! transport needs at least. The sink reads every slot written since it last woke (signals sent in a burst,
//! as the pacing thread catches up, are each measured).

use std::{
    fs::OpenOptions,
    os::fd::AsRawFd,
    path::{Path, PathBuf},
    sync::atomic::{AtomicU32, AtomicU64, Ordering},
    time::Duration,
};

use super::{now_ns, paced, serve, serve_reports, word, Record};
use anyhow::{bail, Context as _, Result};

/// Slots in the ring: far more than signals sent within one wake-up.
const SLOTS: usize = 128;

/// The shared page: the futex word (how many signals were sent), and a ring of the signals' numbers and stamps
/// (signal `k`, counting from 0, in slot `k % SLOTS`).
#[repr(C)]
struct Page {
    word: AtomicU32,
    _pad: u32,
    slots: [(AtomicU64, AtomicU64); SLOTS],
}

const PAGE: usize = 4096;
const _: () = assert!(std::mem::size_of::<Page>() <= PAGE);

/// `/dev/shm/NAME`, the page's file.
fn path(name: &str) -> PathBuf {
    Path::new("/dev/shm").join(name)
}

/// Maps the page of `path` (made, one page long, by the sink) for the rest of the process.
fn map(path: &Path, create: bool) -> Result<&'static Page> {
    let f = OpenOptions::new()
        .read(true)
        .write(true)
        .create(create)
        .truncate(create)
        .open(path)
        .with_context(|| format!("open {}", path.display()))?;
    if create {
        f.set_len(PAGE as u64)?;
    }
    // SAFETY: a shared mapping of a file one page long, never unmapped (it lives as long as the process);
    // `Page` is atomics only and smaller than the page, which the kernel zero-fills and aligns.
    let p = unsafe {
        libc::mmap(
            std::ptr::null_mut(),
            PAGE,
            libc::PROT_READ | libc::PROT_WRITE,
            libc::MAP_SHARED,
            f.as_raw_fd(),
            0,
        )
    };
    if p == libc::MAP_FAILED {
        bail!(
            "mmap {}: {}",
            path.display(),
            std::io::Error::last_os_error()
        );
    }
    Ok(unsafe { &*(p as *const Page) })
}

/// Sleeps while the futex word is `seen` (a shared futex: no `FUTEX_PRIVATE_FLAG`, the page is another
/// process's too).
fn wait(word: &AtomicU32, seen: u32) {
    // SAFETY: FUTEX_WAIT on an aligned u32 of a live mapping, with no timeout
    unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAIT,
            seen,
            std::ptr::null::<libc::timespec>(),
        );
    }
}

/// Wakes one sleeper on the futex word.
fn wake(word: &AtomicU32) {
    // SAFETY: FUTEX_WAKE on an aligned u32 of a live mapping
    unsafe {
        libc::syscall(libc::SYS_futex, word.as_ptr(), libc::FUTEX_WAKE, 1);
    }
}

/// Writes signal `seq`, stamped `t0`, into the next slot and counts it in the futex word (the source alone
/// writes).
fn send(page: &Page, seq: u64, t0: u64) {
    let k = page.word.load(Ordering::Relaxed);
    let (s, t) = &page.slots[k as usize % SLOTS];
    s.store(seq, Ordering::Relaxed);
    t.store(t0, Ordering::Relaxed);
    page.word.store(k.wrapping_add(1), Ordering::Release);
}

/// Hands `push` every signal written after the `seen`th up to the `now_word`th, with its age at `now`; the
/// count seen after them.
fn drain(
    page: &Page,
    mut seen: u32,
    now_word: u32,
    now: u64,
    mut push: impl FnMut(u64, u64),
) -> u32 {
    while seen != now_word {
        let (s, t) = &page.slots[seen as usize % SLOTS];
        push(
            s.load(Ordering::Relaxed),
            now.saturating_sub(t.load(Ordering::Relaxed)),
        );
        seen = seen.wrapping_add(1);
    }
    seen
}

/// Makes the page `/dev/shm/NAME` and records each signal's age as its thread wakes; `report WARMUP`. The
/// page's file goes when the role quits.
pub(super) async fn futex_sink(name: &str) -> Result<()> {
    let file = path(name);
    let page = map(&file, true)?;
    let rec = Record::default();
    let r = rec.clone();
    std::thread::spawn(move || {
        let mut seen = page.word.load(Ordering::Acquire);
        loop {
            let now_word = page.word.load(Ordering::Acquire);
            if now_word == seen {
                wait(&page.word, seen);
                continue;
            }
            seen = drain(page, seen, now_word, now_ns(), |seq, age| r.push(seq, age));
        }
    });
    serve_reports(rec).await;
    let _ = std::fs::remove_file(&file);
    Ok(())
}

/// Signals through the page `/dev/shm/NAME` the sink made: `wait` (nothing to wait for), `run N PERIOD_US`.
pub(super) async fn futex_source(name: &str) -> Result<()> {
    let page = map(&path(name), false)?;
    serve(|w| async move {
        match w[0].as_str() {
            "wait" => Ok("ok".into()),
            "run" => {
                let (n, period): (u64, u64) = (word(&w, 1)?, word(&w, 2)?);
                paced(n, Duration::from_micros(period), |i| {
                    send(page, i, now_ns());
                    wake(&page.word);
                })
                .await;
                Ok(format!("sent {n}"))
            }
            c => bail!("unknown command {c}"),
        }
    })
    .await;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signals sent in a burst, before the sink wakes, are each read once, in order, with their own stamps.
    #[test]
    fn a_burst_is_read_whole() {
        let file = path(&format!("radar_bench_futex_test_{}", std::process::id()));
        let page = map(&file, true).unwrap();
        let _ = std::fs::remove_file(&file);
        for i in 0..5 {
            send(page, 100 + i, 1_000 + i);
        }
        let mut got = Vec::new();
        let seen = drain(page, 0, page.word.load(Ordering::Acquire), 2_000, |s, a| {
            got.push((s, a))
        });
        assert_eq!(seen, 5);
        assert_eq!(
            got,
            (0..5).map(|i| (100 + i, 1_000 - i)).collect::<Vec<_>>()
        );
    }
}
