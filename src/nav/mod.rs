//! Navigation with a dynamic neural field (paper section 3): the Amari field over heading
//! directions (eqs 28–31), its stimuli and velocity laws (eqs 32–37). GIST, the simulator and
//! the experiments come next.

pub mod carmen;
pub mod controller;
pub mod dnf;
pub mod gist;
pub mod replay;
pub mod sim;
pub mod stimulus;
