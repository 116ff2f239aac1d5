//! What every acceleration structure has, whatever the backend: its build
//! options and the memory sizes a build asks for.

/// Which way the builder trades build time against trace time (OptiX's
/// `OPTIX_BUILD_FLAG_PREFER_FAST_TRACE` / `_BUILD`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildPreference {
    /// Slower builds, faster traversal (the default, for static geometry).
    #[default]
    FastTrace,
    /// Faster builds, slower traversal (for geometry rebuilt every frame).
    FastBuild,
    /// Let the driver choose.
    Neither,
}

/// Build flags of one acceleration structure.
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct BuildOptions {
    /// Build-time versus trace-time preference.
    pub preference: BuildPreference,
    /// Allow [`Gas::update`](super::Gas::update) / [`Ias::update`](super::Ias::update) (refit) later.
    pub allow_update: bool,
    /// Allow [`Gas::compact`](super::Gas::compact) later.
    pub allow_compaction: bool,
}

impl BuildOptions {
    /// Prefer fast traversal (the default).
    #[must_use]
    pub fn fast_trace(mut self) -> Self {
        self.preference = BuildPreference::FastTrace;
        self
    }

    /// Prefer fast builds.
    #[must_use]
    pub fn fast_build(mut self) -> Self {
        self.preference = BuildPreference::FastBuild;
        self
    }

    /// Allow later refits (`update`).
    #[must_use]
    pub fn allow_update(mut self, allow: bool) -> Self {
        self.allow_update = allow;
        self
    }

    /// Allow later compaction.
    #[must_use]
    pub fn allow_compaction(mut self, allow: bool) -> Self {
        self.allow_compaction = allow;
        self
    }
}

/// Memory an acceleration structure needs, from the driver's size query
/// (OptiX's `OptixAccelBufferSizes`).
#[derive(Copy, Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct AccelSizes {
    /// Bytes of the structure itself (`accelerationStructureSize`).
    pub structure: u64,
    /// Scratch bytes a build needs (`buildScratchSize`).
    pub build_scratch: u64,
    /// Scratch bytes an update needs (`updateScratchSize`).
    pub update_scratch: u64,
}
