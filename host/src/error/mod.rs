//! raykit's error type: every failure names what went wrong and, where there is
//! one, the fix. One public [`Error`], nested by domain: each domain's enum is
//! defined in its own module here ([`DeviceError`], [`ModuleError`],
//! [`LinkError`], [`SbtError`], [`AccelError`], [`ResourceError`],
//! [`LaunchError`], [`DeviceGroupError`]), so a caller matches
//! `Error::Sbt(SbtError::Hole { .. })` or just prints the message.

mod accel;
mod device;
mod device_group;
mod launch;
mod link;
mod module;
mod resource;
mod sbt;

use ash::vk;

pub use accel::AccelError;
pub use device::{DeviceError, DeviceReport};
pub use device_group::DeviceGroupError;
pub(crate) use launch::exceptions_error;
pub use launch::{LaunchError, UserException};
pub use link::LinkError;
pub use module::ModuleError;
pub use resource::ResourceError;
pub use sbt::SbtError;

/// Result with raykit's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in raykit, by domain.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Errors of the device and the backend (see [`DeviceError`]).
    #[error(transparent)]
    Device(#[from] DeviceError),

    /// Errors of modules (see [`ModuleError`]).
    #[error(transparent)]
    Module(#[from] ModuleError),

    /// Errors of linking program groups into pipelines and pipeline libraries (see [`LinkError`]).
    #[error(transparent)]
    Link(#[from] LinkError),

    /// Errors of shader binding tables (see [`SbtError`]).
    #[error(transparent)]
    Sbt(#[from] SbtError),

    /// Errors of acceleration-structure builds (see [`AccelError`]).
    #[error(transparent)]
    Accel(#[from] AccelError),

    /// Errors of buffers and textures (see [`ResourceError`]).
    #[error(transparent)]
    Resource(#[from] ResourceError),

    /// Errors of launches (see [`LaunchError`]).
    #[error(transparent)]
    Launch(#[from] LaunchError),

    /// Errors of device groups and their split launches. (see [`DeviceGroupError`]).
    #[error(transparent)]
    DeviceGroup(#[from] DeviceGroupError),

    /// Something one device of a group was asked failed: its error, with the device.
    #[error("device {device} of the group ({name}): {source}")]
    InDevice {
        /// The device's index in the group.
        device: usize,
        /// Its name.
        name: String,
        /// What went wrong there.
        #[source]
        source: Box<Error>,
    },
}

impl From<raykit_spirv::LayoutError> for Error {
    fn from(e: raykit_spirv::LayoutError) -> Self {
        match e {
            raykit_spirv::LayoutError::InvalidSpirv(reason) => Error::Module(ModuleError::InvalidSpirv { reason }),
            other => Error::Link(LinkError::ParamsLayout(Box::new(other))),
        }
    }
}

impl Error {
    /// Wraps a failed Vulkan call.
    pub(crate) fn vk(call: &'static str) -> impl FnOnce(vk::Result) -> Error {
        move |result| match result {
            vk::Result::ERROR_DEVICE_LOST => Error::Device(DeviceError::DeviceLost { during: call }),
            result => Error::Device(DeviceError::Vulkan { call, result }),
        }
    }
}
