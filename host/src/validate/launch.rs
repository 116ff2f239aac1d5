//! The checks every launch makes before it is submitted, on either backend: the
//! handles in the params and in the SBT's records name live objects of the
//! context, and the scenes the params name select no hit record past the SBT's
//! end. Each backend runs them under its own lock (the Vulkan timeline, the CPU
//! backend's scenes), so no drop can slip between the check and the submission;
//! what is live it answers through [`Liveness`].

use std::sync::Arc;

use crate::error::Result;
use crate::types::sbt::SbtRegion;
use crate::validate::handles::{check_handles, HandleField, TraversableState};
use crate::validate::hit_reach::HitReach;
use crate::validate::scene::check_scene;
use crate::validate::TraceReach;

/// A record whose data holds handles: where it is, where its handles are, and a
/// host copy of its data (the SBT buffer may be slow for the host to read).
#[derive(Debug)]
pub(crate) struct CheckedRecord {
    pub(crate) region: SbtRegion,
    pub(crate) index: usize,
    pub(crate) fields: Vec<HandleField>,
    pub(crate) data: Vec<u8>,
}

/// What a launch checks of its SBT: the records whose data holds handles, and
/// how many hit records there are.
#[derive(Copy, Clone, Debug)]
pub(crate) struct SbtChecks<'a> {
    pub(crate) records: &'a [CheckedRecord],
    pub(crate) hit_records: usize,
    /// The kinds of its hit groups, record by record.
    pub(crate) hit_kinds: &'a crate::validate::records::HitKinds,
}

/// What a backend knows of its context's live objects, under the lock its
/// launches are checked and submitted under.
pub(crate) trait Liveness {
    /// Whether `handle` names a live buffer of the context.
    fn buffer(&self, handle: u32) -> bool;
    /// Whether `handle` names a live texture of the context.
    fn texture(&self, handle: u32) -> bool;
    /// What the traversable at `address` is to the context.
    fn traversable(&self, address: u64) -> TraversableState;
    /// What the live IAS at `address` can select in the hit region (`None`: no live IAS).
    fn hit_reach(&self, address: u64) -> Option<Arc<HitReach>>;
}

/// What a launch is checked with: made by the public launch from what the
/// pipeline and SBT were checked with, and run by the backend under its lock.
#[derive(Copy, Clone)]
pub(crate) struct LaunchChecks<'a> {
    /// Where the params' handles are.
    pub(crate) fields: &'a [HandleField],
    /// The params' bytes.
    pub(crate) params: &'a [u8],
    pub(crate) sbt: SbtChecks<'a>,
    /// What the pipeline's traces select.
    pub(crate) reach: &'a TraceReach,
}

impl LaunchChecks<'_> {
    /// Runs the checks against what `live` says is live.
    pub(crate) fn run(&self, live: &impl Liveness) -> Result<()> {
        check_launch(live, self.fields, self.params, self.sbt, self.reach)
    }
}

/// The launch checks, in order: the params' handles (laid out as `fields` says),
/// each checked record's handles, then the reach of the params' scenes into the
/// SBT for the traces `reach` describes, and the kinds of the hit groups they select.
fn check_launch(
    live: &impl Liveness,
    fields: &[HandleField],
    params: &[u8],
    sbt: SbtChecks<'_>,
    reach: &TraceReach,
) -> Result<()> {
    let buffer = |handle| live.buffer(handle);
    let texture = |handle| live.texture(handle);
    let traversable = |address| live.traversable(address);
    if !fields.is_empty() {
        check_handles(fields, params, None, buffer, texture, traversable)?;
    }
    for record in sbt.records {
        let region: Option<(SbtRegion, usize)> = Some((record.region, record.index));
        check_handles(&record.fields, &record.data, region, buffer, texture, traversable)?;
    }
    check_scene(|address| live.hit_reach(address), fields, params, sbt.hit_records, sbt.hit_kinds, reach)
}
