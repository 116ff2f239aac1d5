//! A process-wide lock that keeps pipeline destruction apart from pipeline creation.
//!
//! NVIDIA's driver (580, seen on H100 and H200) takes two internal locks in opposite
//! orders in `vkCreateRayTracingPipelinesKHR` and in `vkDestroyPipeline`: a thread
//! creating a pipeline while another destroys one can deadlock both, and every
//! later call that needs either lock (memory allocation among them) hangs behind
//! them. The locks are the driver's, not the device's, so pipelines of different
//! devices in one process collide as well.
//!
//! Creations take this lock shared, so they still run in parallel with each other;
//! destroying a pipeline, and creating or destroying a device, take it exclusively.
//! The lock is held only around the one Vulkan call, never while raykit's other
//! locks are taken inside it, so it cannot join a cycle of raykit's own.

use std::sync::{PoisonError, RwLock, RwLockReadGuard, RwLockWriteGuard};

static DRIVER_LOCK: RwLock<()> = RwLock::new(());

/// Held while a pipeline (or pipeline library) is created.
pub(crate) fn shared() -> RwLockReadGuard<'static, ()> {
    DRIVER_LOCK.read().unwrap_or_else(PoisonError::into_inner)
}

/// Held while a pipeline is destroyed, or a device created or destroyed.
pub(crate) fn exclusive() -> RwLockWriteGuard<'static, ()> {
    DRIVER_LOCK.write().unwrap_or_else(PoisonError::into_inner)
}
