//! Navigation with a dynamic neural field (paper section 3): the Amari field over heading
//! directions (eqs 28–31, [`crate::low_level::dnf`]), its stimuli and velocity laws (eqs 32–37, [`StimulusConfig`]),
//! the camera's GIST (eqs 38–41, [`gist`]) and the visual obstacle model it feeds
//! ([`visual`]), all brought together by the [`Controller`] a robot calls every cycle. The
//! 2-D simulator ([`sim`]) and the laser-log replay ([`replay`], [`carmen`]) drive that same
//! controller; the controller depends on neither.

pub(crate) mod camera;
pub mod carmen;
pub(crate) mod controller;
pub(crate) mod dnf;
pub mod gist;
pub mod replay;
pub mod sim;
pub(crate) mod stimulus;
pub mod visual;

pub use camera::CameraConfig;
pub use controller::{Command, Controller, ControllerConfig, LaserScan, Mode};
pub use stimulus::StimulusConfig;
