//! The engine's error type. Every fallible public function returns [`Result`]; nothing in the library
//! panics on a `VkResult` or on user input.

use std::path::PathBuf;

/// Everything that can go wrong in the engine, each variant saying what the user can do about it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene description (TOML, OBJ, texture) is malformed; `context` names the file and the field.
    #[error("scene error in {context}: {message}")]
    Scene { context: String, message: String },
    /// A requested size, sample count or similar is outside what the engine accepts.
    #[error("{what} = {value} is out of range: {limit}")]
    Limit { what: &'static str, value: String, limit: String },
    /// A file could not be read or written. The message includes the cause, so it is not also a
    /// `source()`: `{:#}` (anyhow's chain) would print it twice.
    #[error("I/O error on {path}: {cause}")]
    Io { path: PathBuf, cause: std::io::Error },
    /// An image file could not be decoded or encoded.
    #[error("image error on {path}: {message}")]
    Image { path: PathBuf, message: String },
    /// An output file cannot be written there (checked before any work), or writing it failed — in
    /// which case any previous file of that name is left as it was.
    #[error("cannot write {path}: {message}")]
    Output { path: PathBuf, message: String },
    /// The user interrupted the work (Ctrl-C); nothing is left in flight on the device.
    #[error("interrupted")]
    Interrupted,
    /// A Vulkan call failed; `call` names it.
    #[error("Vulkan call {call} failed: {result}")]
    Vulkan { call: &'static str, result: ash::vk::Result },
    /// The Vulkan loader or driver could not be found.
    #[error("cannot load Vulkan: {0} (is libvulkan1 installed? run scripts/setup.sh)")]
    Loader(String),
    /// No physical device matches the request.
    #[error("no Vulkan device matches {wanted:?}; available devices: {available:?}")]
    NoDevice { wanted: String, available: Vec<String> },
    /// The device lacks something a technique needs.
    #[error("device `{device}` lacks {feature}, which {needed_by} needs")]
    MissingFeature { device: String, feature: String, needed_by: String },
    /// GPU memory allocation failed.
    #[error("GPU allocation failed: {0}")]
    Allocation(gpu_allocator::AllocationError),
    /// The validation layer reported errors while validation was on.
    #[error("Vulkan validation reported {errors} error(s) and {warnings} warning(s); first: {first}")]
    Validation { errors: u32, warnings: u32, first: String },
    /// A frame graph was declared inconsistently (a pass' accesses contradict each other); names the
    /// pass and the resource.
    #[error("frame graph: {0}")]
    Graph(String),
    /// An environment variable has a value Shutter does not understand.
    #[error("environment variable {name}={value:?}: expected {expected}")]
    Environment { name: &'static str, value: String, expected: &'static str },
    /// A request that the chosen technique does not support.
    #[error("{0}")]
    Unsupported(String),
}

impl Error {
    pub(crate) fn scene(context: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Scene { context: context.into(), message: message.into() }
    }
    pub(crate) fn io(path: impl Into<PathBuf>, cause: std::io::Error) -> Self {
        Error::Io { path: path.into(), cause }
    }
}

// Not `#[from]`: that would make the allocation error a `source()` as well as part of the message.
impl From<gpu_allocator::AllocationError> for Error {
    fn from(e: gpu_allocator::AllocationError) -> Self {
        Error::Allocation(e)
    }
}

/// The member of `all` called `s` by `name`, else an [`Error::Unsupported`] naming `what` and listing
/// every name: the `FromStr` of the command-line enums (bound kinds, shading rates, hull expansions,
/// transparency methods).
pub(crate) fn parse_named<T: Copy>(
    all: &[T],
    name: impl Fn(T) -> &'static str,
    what: &str,
    s: &str,
) -> Result<T> {
    all.iter().copied().find(|&t| name(t) == s).ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|&t| name(t)).collect();
        Error::Unsupported(format!("unknown {what} `{s}`; available: {}", names.join(", ")))
    })
}

/// Maps a raw `VkResult` to [`Error::Vulkan`] naming the call.
pub(crate) trait VkContext<T> {
    fn vk(self, call: &'static str) -> Result<T>;
}
impl<T> VkContext<T> for std::result::Result<T, ash::vk::Result> {
    fn vk(self, call: &'static str) -> Result<T> {
        self.map_err(|result| Error::Vulkan { call, result })
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
