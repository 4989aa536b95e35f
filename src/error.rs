//! The library's error type. Every fallible public function returns [`Result`]; binaries wrap it in `anyhow`.
//! User input (files, flags) never panics: it ends in one of these variants with a message that names the
//! file, the byte offset and the reason where there is one.

use std::path::PathBuf;

/// Everything that can go wrong in Meniscus.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The Vulkan loader (libvulkan.so.1) could not be opened.
    #[error("cannot load the Vulkan loader ({0}); install it with `apt-get install libvulkan1 mesa-vulkan-drivers` (lavapipe runs on any CPU)")]
    NoLoader(String),
    /// No physical device fits (none at all, or none matching `MENISCUS_DEVICE`).
    #[error("no usable Vulkan device: {0}; on a machine without a GPU install lavapipe: `apt-get install mesa-vulkan-drivers`")]
    NoDevice(String),
    /// A Vulkan call failed.
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan {
        /// The Vulkan function.
        call: &'static str,
        /// What it returned.
        result: ash::vk::Result,
    },
    /// GPU memory could not be allocated.
    #[error("GPU memory allocation for {what} failed: {source}")]
    Alloc {
        /// The resource being allocated.
        what: String,
        /// The allocator's error.
        source: gpu_allocator::AllocationError,
    },
    /// A file could not be read or written.
    #[error("{}: {err}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        err: std::io::Error,
    },
    /// A particle or settings file is malformed.
    #[error("{}: byte {offset}: {reason}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// Byte offset where it goes wrong (0 when the whole file is at fault).
        offset: u64,
        /// What is wrong.
        reason: String,
    },
    /// An output path that would destroy something (an input, a file of another kind) or has the wrong name.
    #[error("{}: refusing to write: {reason}", path.display())]
    Output {
        /// The output path.
        path: PathBuf,
        /// Why it is refused.
        reason: String,
    },
    /// A value the user gave (flag, scene name, settings) is not acceptable.
    #[error("{0}")]
    Invalid(String),
    /// More data than the device can hold.
    #[error("{0}")]
    Limit(String),
}

/// Shorthand used across the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Turn an `ash` result into ours, naming the call that failed.
pub trait VkContext<T> {
    /// Map the `vk::Result` error to [`Error::Vulkan`] naming `call`.
    fn vk(self, call: &'static str) -> Result<T>;
}

impl<T> VkContext<T> for Result<T, ash::vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Error::Io { path: path.into(), err: source }
    }
}
