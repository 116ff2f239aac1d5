//! Plain data both backends read: descriptions of contexts, build inputs, flags,
//! textures, program groups, SBT regions and specialization. The bottom layer of
//! the crate: it imports nothing of raykit's but the error type (and, for
//! [`context::ContextOptions`], the log callback and cache location it carries).

pub(crate) mod accel;
pub(crate) mod context;
pub(crate) mod group;
pub(crate) mod mesh;
pub(crate) mod program;
pub(crate) mod sbt;
pub(crate) mod specialization;
pub(crate) mod texture;
