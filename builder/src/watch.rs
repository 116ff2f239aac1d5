//! Hot reload: a watcher (notify, debounced) that rebuilds a device crate when
//! one of its sources changes and hands each result to the renderer, which swaps
//! its pipeline on success and keeps the old one on a compile error.

use std::path::Path;
use std::sync::mpsc::{channel, Receiver};
use std::time::{Duration, Instant};

use notify_debouncer_mini::notify::{RecommendedWatcher, RecursiveMode};
use notify_debouncer_mini::{new_debouncer, DebounceEventResult, Debouncer};

use crate::codegen::ShaderBuilder;
use crate::device::{BuiltModule, DeviceBuild};
use crate::error::{Error, Result};

/// One rebuild the watcher made.
#[derive(Debug)]
pub struct Rebuild {
    /// The new module, or why there is none (a [`Error::Compile`] carries rustc's
    /// messages): keep running the previous one.
    pub result: Result<BuiltModule>,
    /// When the first change that triggered it was seen.
    pub changed_at: Instant,
}

/// Watches a device crate's sources and rebuilds it on each (debounced) change.
pub struct DeviceWatcher {
    rebuilds: Receiver<Rebuild>,
    _debouncer: Debouncer<RecommendedWatcher>,
}

impl std::fmt::Debug for DeviceWatcher {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DeviceWatcher").finish_non_exhaustive()
    }
}

fn watch_error(e: impl std::fmt::Display) -> Error {
    Error::Watch { reason: e.to_string() }
}

/// Whether a changed path is a source (not build output under a `target`
/// directory, nor a lock file cargo rewrites).
fn is_source(path: &Path) -> bool {
    !path.components().any(|c| c.as_os_str() == "target") && path.file_name().is_none_or(|n| n != "Cargo.lock")
}

impl DeviceWatcher {
    /// Starts watching the inputs of `build` ([`DeviceBuild::inputs`]); changes
    /// closer together than `debounce` make one rebuild. The codegen backend is
    /// made ready first, so each rebuild only compiles the crate.
    pub fn new(build: DeviceBuild, debounce: Duration) -> Result<DeviceWatcher> {
        let builder = ShaderBuilder::ensure(crate::Report::Quiet)?;
        let (events_tx, events) = channel::<DebounceEventResult>();
        let mut debouncer = new_debouncer(debounce, events_tx).map_err(watch_error)?;
        for dir in build.inputs() {
            debouncer.watcher().watch(&dir, RecursiveMode::Recursive).map_err(watch_error)?;
        }
        let (rebuilds_tx, rebuilds) = channel();
        // Events also come from reading the sources (the compiler opens them)
        // and from cargo rewriting the lock file: only a change of the sources'
        // or manifests' content starts a build.
        let mut last = build.source_fingerprint().ok();
        let build = build.force(true);
        std::thread::Builder::new()
            .name("raykit-device-watcher".to_owned())
            .spawn(move || {
                while let Ok(batch) = events.recv() {
                    let changed_at = Instant::now();
                    let relevant = match batch {
                        Ok(events) => events.iter().any(|e| is_source(&e.path)),
                        Err(_) => true,
                    };
                    if !relevant {
                        continue;
                    }
                    let now = build.source_fingerprint().ok();
                    if now.is_some() && now == last {
                        continue;
                    }
                    last = now;
                    let result = build.build_with(&builder);
                    if rebuilds_tx.send(Rebuild { result, changed_at }).is_err() {
                        return;
                    }
                }
            })
            .map_err(watch_error)?;
        Ok(DeviceWatcher { rebuilds, _debouncer: debouncer })
    }

    /// The next rebuild, if one finished.
    pub fn try_next(&self) -> Option<Rebuild> {
        self.rebuilds.try_recv().ok()
    }

    /// Waits up to `timeout` for the next rebuild.
    pub fn next_timeout(&self, timeout: Duration) -> Option<Rebuild> {
        self.rebuilds.recv_timeout(timeout).ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn build_output_is_not_a_source() {
        assert!(is_source(Path::new("/p/device/src/lib.rs")));
        assert!(!is_source(Path::new("/p/device/target/spirv/x.spv")));
        assert!(!is_source(Path::new("/p/device/Cargo.lock")));
    }
}
