#![doc = include_str!("../../README.md")]
#![deny(missing_docs)]

pub mod accel;
mod buffer_table;
pub mod context;
pub mod error;
pub mod launch;
pub mod log;
pub mod memory;
pub mod module;
pub mod pipeline;
pub mod program_group;
pub mod sbt;

pub use accel::{Aabb, Aabbs, BuildInput, BuildOptions, Gas, GasBuilder, GeometryFlags, Ias, IasBuilder, Indices, Instance, InstanceFlags, PendingBuild, Triangles};
pub use context::{Context, ContextOptions, DeviceLimits};
pub use error::{DeviceReport, Error, Result, UserException};
pub use raykit_device::layout::{BlockMember, BlockType, LayoutError, ParamsBlock, ParamsDelivery};
pub use log::{MessageLog, Severity, ValidationMessage};
pub use memory::DeviceBuffer;
pub use module::{spirv_path, EntryPointInfo, Module};
pub use pipeline::{params_delivery, LinkOptions, Pipeline};
pub use program_group::{EntryName, HitGroupBuilder, ProgramGroup};
pub use sbt::{Sbt, SbtBuilder, SbtRecord, SbtRegion};

pub use ash;
pub use glam;
/// The device crate's shared types, re-exported for host code.
pub use raykit_device::{self as device, Buffer, EntryPoint, LaunchParams, ProgramKind, Traversable};
