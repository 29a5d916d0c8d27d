//! Errors shared by every backend: each backend has its own error type, and every such
//! type says which [`ErrorKind`] it is.

/// What went wrong, independent of the backend. Generic code matches on this.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The device did not answer (or deliver data) within its deadline.
    Timeout,
    /// The device is gone: unplugged port, closed socket, ended log.
    Disconnected,
    /// A command was refused because it would leave a safety or range limit.
    OutOfLimits,
    /// The device answered with something that does not follow its protocol.
    Protocol,
    /// Anything else.
    Other,
}

impl std::fmt::Display for ErrorKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ErrorKind::Timeout => "timeout",
            ErrorKind::Disconnected => "disconnected",
            ErrorKind::OutOfLimits => "out of limits",
            ErrorKind::Protocol => "protocol error",
            ErrorKind::Other => "other error",
        })
    }
}

/// A backend error: any error type that can say which [`ErrorKind`] it is.
pub trait Error: std::error::Error + Send + Sync + 'static {
    fn kind(&self) -> ErrorKind;
}

/// Gives a device its error type; every device-role trait has it as a supertrait.
pub trait ErrorType {
    type Error: Error;
}

impl<T: ErrorType + ?Sized> ErrorType for &mut T {
    type Error = T::Error;
}
