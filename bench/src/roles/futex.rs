//! The floor of a same-host signal (issue 71): two processes, one page of shared memory, one futex. The source
//! writes a signal's sequence number and stamp into the page, bumps the futex word and wakes the sink, which
//! was asleep in `FUTEX_WAIT` on it: one store and one wake-up, what any same-host transport needs at least.

use std::{
    fs::OpenOptions,
    os::fd::AsRawFd,
    path::{Path, PathBuf},
    sync::atomic::{AtomicU32, AtomicU64, Ordering},
    time::Duration,
};

use super::{now_ns, paced, serve, serve_reports, word, Record};
use anyhow::{bail, Context as _, Result};

/// The shared page: the futex word (how many signals were sent), and the last signal's number and stamp.
#[repr(C)]
struct Page {
    word: AtomicU32,
    _pad: u32,
    seq: AtomicU64,
    t0: AtomicU64,
}

const PAGE: usize = 4096;

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
            let now = now_ns();
            seen = now_word;
            let (seq, t0) = (
                page.seq.load(Ordering::Acquire),
                page.t0.load(Ordering::Acquire),
            );
            r.push(seq, now.saturating_sub(t0));
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
                    page.seq.store(i, Ordering::Relaxed);
                    page.t0.store(now_ns(), Ordering::Relaxed);
                    page.word.fetch_add(1, Ordering::Release);
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
