//! Navigation with a dynamic neural field (paper section 3): the Amari field over heading
//! directions (eqs 28–31). Stimuli, GIST, velocity laws and the simulator come next.

pub mod dnf;
