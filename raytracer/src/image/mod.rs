//! Images: the film a render writes into, tone mapping to 8-bit PNG, and
//! linear output as Radiance HDR (RGBE), OpenEXR and PFM.
//!
//! The film stores linear RGB radiance (Radiance's units, W/sr/m² per
//! channel) in `f64`, row-major with row 0 at the **top** of the picture.
//! Output format is chosen by the file extension ([`ImageFormat::from_path`]).

pub mod compare;
pub mod exr;
mod film;
mod format;
pub mod hdr;
pub mod pfm;
pub mod tonemap;

pub use film::{brightness, Film, HdrInfo};
pub use format::{encode_image, write_image, ImageFormat, IMAGE_EXTENSIONS};
pub use tonemap::{Exposure, Reinhard, ToneMap, ToneOperator, Transfer};
