//! The exception stage (`__exception__`): OptiX's exception program, run on
//! Vulkan as a callable after a user exception is thrown (see
//! [`crate::exception`](mod@crate::exception)).

use spirv_std::glam::UVec3;

use crate::exception::ExceptionDetails;
use crate::{Buffer, Element};

/// What an exception program may use: the exception, launch index and size,
/// buffers (to write a marker into the output, say).
pub struct Exception<'a> {
    details: ExceptionDetails,
    launch_dimensions: UVec3,
    device: super::DeviceAccess<'a>,
}

impl<'a> Exception<'a> {
    #[doc(hidden)]
    pub fn __new(details: ExceptionDetails, launch_dimensions: UVec3, device: super::DeviceAccess<'a>) -> Self {
        Exception { details, launch_dimensions, device }
    }

    /// The code the program threw (`optixGetExceptionCode`).
    #[doc(alias("optixGetExceptionCode"))]
    pub fn exception_code(&self) -> u32 {
        self.details.code
    }

    /// The launch index of the invocation that threw it (`optixGetLaunchIndex`).
    #[doc(alias("optixGetLaunchIndex"))]
    pub fn launch_index(&self) -> UVec3 {
        self.details.launch_index
    }

    /// The launch grid's size.
    #[doc(alias("optixGetLaunchDimensions"))]
    pub fn launch_dimensions(&self) -> UVec3 {
        self.launch_dimensions
    }

    /// `x + y * width + z * width * height` of the throwing invocation.
    pub fn launch_linear_index(&self) -> u32 {
        let (i, d) = (self.details.launch_index, self.launch_dimensions);
        i.x + d.x * (i.y + d.y * i.z)
    }

    /// Reads element `index` of `buffer`.
    pub fn load<T: Element>(&self, buffer: Buffer<T>, index: u32) -> T {
        super::load(self.device, buffer, index)
    }

    /// Writes element `index` of `buffer`.
    pub fn store<T: Element>(&mut self, buffer: Buffer<T>, index: u32, value: T) {
        super::store(self.device, buffer, index, value)
    }
}
