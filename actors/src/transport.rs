//! The transport seam: how a registry reaches services hosted in other processes.
//!
//! A client resolves its address in the [`Registry`](crate::Registry) first. A service hosted
//! in the same process answers with its in-process endpoint, so local peers talk through actor
//! mailboxes and never pay a network hop. Only an address no local component hosts is asked of
//! the installed [`Transport`]. This trait is the one place where another process enters: the
//! zenoh transport implements it, and no other module names zenoh.
//!
//! Today every client resolves in-process only: this trait states the seam's place and its
//! first duty (discovery). The byte-level operations of each pattern, and the clients' fallback
//! to them, arrive with the zenoh transport itself, behind the same client types.

use crate::registry::{ServiceAddr, ServiceInfo};

/// Access to services hosted by other processes.
pub trait Transport: Send + Sync + 'static {
    /// A short name for messages and logs, e.g. `zenoh`.
    fn name(&self) -> &str;

    /// What the remote service at `addr` is, if a reachable peer hosts it.
    fn lookup(&self, addr: &ServiceAddr) -> Option<ServiceInfo>;
}
