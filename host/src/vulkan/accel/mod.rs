//! Acceleration structures on Vulkan: the structure with its storage
//! (`structure`), and recording and submitting builds (`build`).

pub(crate) mod build;
pub(crate) mod gas;
pub(crate) mod ias;
pub(crate) mod structure;
